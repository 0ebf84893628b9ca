// GenICam XML reader, node map over a register space, single-file zip.

#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <random>

#include "gonio/devices/genicam.h"

namespace {

using gonio::devices::genicam::NodeMap;

// Device memory as a plain byte map: the register space the node map talks to.
struct Memory {
    std::map<std::uint64_t, std::uint8_t> bytes;
    gonio::devices::genicam::RegisterPort port() {
        return {
            [this](std::uint64_t a, std::size_t n) -> gonio::Expected<std::vector<std::uint8_t>> {
                std::vector<std::uint8_t> out(n);
                for (std::size_t i = 0; i < n; ++i) {
                    out[i] = bytes[a + i];
                }
                return out;
            },
            [this](std::uint64_t a, const std::vector<std::uint8_t>& d) -> gonio::Expected<void> {
                for (std::size_t i = 0; i < d.size(); ++i) {
                    bytes[a + i] = d[i];
                }
                return {};
            }};
    }
};

const char* kXml = R"(<?xml version="1.0"?>
<!-- a comment -->
<RegisterDescription ModelName="M &amp; N" VendorName="V">
  <Group Comment="nested">
    <Integer Name="Width"><pValue>WidthReg</pValue><Min>16</Min><Max>4096</Max><Inc>16</Inc></Integer>
  </Group>
  <IntReg Name="WidthReg"><Address>0x100</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <Endianess>LittleEndian</Endianess></IntReg>
  <Integer Name="BigE"><pValue>BigEReg</pValue></Integer>
  <IntReg Name="BigEReg"><Address>0x200</Address><Length>2</Length><AccessMode>RW</AccessMode>
    <Endianess>BigEndian</Endianess><Sign>Signed</Sign></IntReg>
  <Float Name="ExposureTime"><pValue>ExpReg</pValue><Min>1</Min><Max>1e6</Max></Float>
  <FloatReg Name="ExpReg"><Address>0x300</Address><Length>4</Length><AccessMode>RW</AccessMode></FloatReg>
  <Enumeration Name="Mode">
    <EnumEntry Name="A"><Value>0</Value></EnumEntry>
    <EnumEntry Name="B"><Value>5</Value></EnumEntry>
    <pValue>ModeReg</pValue>
  </Enumeration>
  <MaskedIntReg Name="ModeReg"><Address>0x400</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <LSB>4</LSB><MSB>7</MSB></MaskedIntReg>
  <Command Name="Go"><pValue>GoReg</pValue><CommandValue>3</CommandValue></Command>
  <IntReg Name="GoReg"><Address>0x500</Address><Length>4</Length><AccessMode>WO</AccessMode></IntReg>
  <Integer Name="Const"><Value>42</Value></Integer>
  <StringReg Name="Serial"><Address>0x600</Address><Length>8</Length><AccessMode>RO</AccessMode></StringReg>
  <Integer Name="Ro"><pValue>RoReg</pValue></Integer>
  <IntReg Name="RoReg"><Address>0x700</Address><Length>4</Length><AccessMode>RO</AccessMode></IntReg>
</RegisterDescription>
)";

TEST(GenicamXml, ParsesElementsAttributesEntitiesAndCdata) {
    auto doc = gonio::devices::genicam::parse_xml(
        "<a x='1' y=\"&lt;2&gt;\"><b>t&#65;<![CDATA[<raw>]]></b><c/></a>");
    ASSERT_TRUE(doc) << doc.error().message;
    EXPECT_EQ(doc->name, "a");
    EXPECT_EQ(*doc->attribute("y"), "<2>");
    ASSERT_EQ(doc->children.size(), 2u);
    EXPECT_EQ(doc->children[0].text, "tA<raw>");
}

TEST(GenicamXml, MalformedDocumentsGiveLineAndRule) {
    const std::pair<const char*, const char*> cases[] = {
        {"<a><b></a>", "does not match"},
        {"<a>\n\n<b x=1/></a>", "line 3"},
        {"<a>", "not closed"},
        {"", "root element"},
        {"<a>&bogus;</a>", "unknown entity"},
        {"<a></a><b/>", "after the root"},
        {"<a><![CDATA[x</a>", "CDATA"},
    };
    for (const auto& [text, part] : cases) {
        auto r = gonio::devices::genicam::parse_xml(text);
        ASSERT_FALSE(r) << text;
        EXPECT_NE(r.error().message.find(part), std::string::npos)
            << text << " -> " << r.error().message;
    }
    // Nesting is bounded: no stack exhaustion.
    std::string deep;
    for (int i = 0; i < 100000; ++i) {
        deep += "<a>";
    }
    auto r = gonio::devices::genicam::parse_xml(deep);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("deeper"), std::string::npos);
}

TEST(NodeMap, ResolvesFeaturesThroughTheirRegisters) {
    auto map = NodeMap::parse(kXml);
    ASSERT_TRUE(map) << map.error().message;
    EXPECT_EQ(map->model_name(), "M & N");
    Memory mem;
    map->set_port(mem.port());

    ASSERT_TRUE(map->set_int("Width", 640));
    EXPECT_EQ(mem.bytes[0x100], 0x80);  // 640 = 0x280 little-endian
    EXPECT_EQ(mem.bytes[0x101], 0x02);
    EXPECT_EQ(*map->get_int("Width"), 640);

    // Big-endian signed 16-bit: -2 is FF FE.
    ASSERT_TRUE(map->set_int("BigE", -2));
    EXPECT_EQ(mem.bytes[0x200], 0xFF);
    EXPECT_EQ(mem.bytes[0x201], 0xFE);
    EXPECT_EQ(*map->get_int("BigE"), -2);

    ASSERT_TRUE(map->set_float("ExposureTime", 1500.5));
    EXPECT_FLOAT_EQ(static_cast<float>(*map->get_float("ExposureTime")), 1500.5f);

    // Bit field 7..4 of 0x400; neighbouring bits untouched.
    mem.bytes[0x400] = 0x0F;
    ASSERT_TRUE(map->set_enum("Mode", "B"));
    EXPECT_EQ(mem.bytes[0x400], 0x5F);
    EXPECT_EQ(*map->get_enum("Mode"), "B");

    ASSERT_TRUE(map->execute("Go"));
    EXPECT_EQ(mem.bytes[0x500], 3);
    EXPECT_EQ(*map->get_int("Const"), 42);
    mem.bytes[0x600] = 'S';
    mem.bytes[0x601] = 'N';
    mem.bytes[0x602] = 0;
    EXPECT_EQ(*map->get_string("Serial"), "SN");
}

TEST(NodeMap, RulesAreEnforcedWithTheFeatureNamed) {
    auto map = NodeMap::parse(kXml);
    ASSERT_TRUE(map);
    Memory mem;
    map->set_port(mem.port());
    const std::pair<gonio::Expected<void>, const char*> cases[] = {
        {map->set_int("Width", 8), "outside"},
        {map->set_int("Width", 650), "increment"},
        {map->set_float("ExposureTime", 0), "outside"},
        {map->set_enum("Mode", "C"), "has no entry 'C'"},
        {map->set_int("Ro", 1), "read-only"},
        {map->set_int("Missing", 1), "not in the device's node map"},
        {map->execute("Width"), "not a Command"},
    };
    for (const auto& [r, part] : cases) {
        ASSERT_FALSE(r) << part;
        EXPECT_NE(r.error().message.find(part), std::string::npos) << r.error().message;
    }
    auto wo = map->get_int("GoReg");
    ASSERT_FALSE(wo);
    EXPECT_NE(wo.error().message.find("write-only"), std::string::npos);
    mem.bytes[0x400] = 0x30;  // Mode value 3: no entry
    auto e = map->get_enum("Mode");
    ASSERT_FALSE(e);
    EXPECT_NE(e.error().message.find("matches no entry"), std::string::npos);
}

TEST(NodeMap, MalformedDescriptionsAreRejected) {
    const std::pair<const char*, const char*> cases[] = {
        {"<Other/>", "not <RegisterDescription>"},
        {"<RegisterDescription><Integer Name='A'><pValue>Nope</pValue></Integer>"
         "</RegisterDescription>",
         "unknown node 'Nope'"},
        {"<RegisterDescription><IntReg Name='R'><Address>zz</Address><Length>4</Length></IntReg>"
         "</RegisterDescription>",
         "not an integer"},
        {"<RegisterDescription><IntReg Name='R'><Address>0</Address><Length>9</Length></IntReg>"
         "</RegisterDescription>",
         "> 8"},
        {"<RegisterDescription><Integer/></RegisterDescription>", "without a Name"},
        {"<RegisterDescription><Integer Name='A'/></RegisterDescription>", "neither"},
        {"<RegisterDescription><Integer Name='A'><Value>1</Value></Integer>"
         "<Integer Name='A'><Value>1</Value></Integer></RegisterDescription>",
         "defined twice"},
    };
    for (const auto& [text, part] : cases) {
        auto r = NodeMap::parse(text);
        ASSERT_FALSE(r) << text;
        EXPECT_NE(r.error().message.find(part), std::string::npos) << r.error().message;
    }
}

TEST(NodeMap, PointerCyclesAreCaught) {
    auto map = NodeMap::parse(
        "<RegisterDescription><Integer Name='A'><pValue>B</pValue></Integer>"
        "<Integer Name='B'><pValue>A</pValue></Integer></RegisterDescription>");
    ASSERT_TRUE(map);
    auto r = map->get_int("A");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("cycle"), std::string::npos);
}

TEST(GenicamZip, RoundTripAndCorruptionDetected) {
    std::string text(5000, 'x');
    for (std::size_t i = 0; i < text.size(); ++i) {
        text[i] = static_cast<char>('a' + (i * 7) % 26);
    }
    auto zip = gonio::devices::genicam::zip_single_file("d.xml", text);
    ASSERT_TRUE(zip);
    EXPECT_LT(zip->size(), text.size());
    auto back = gonio::devices::genicam::unzip_single_file(*zip);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(*back, text);
    auto bad = *zip;
    bad[40] ^= 0x55;  // inside the deflate stream
    auto r = gonio::devices::genicam::unzip_single_file(bad);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("zip"), std::string::npos);
    EXPECT_FALSE(gonio::devices::genicam::unzip_single_file({1, 2, 3}));
    // Truncations of every length: error, never a crash.
    for (std::size_t n = 0; n < zip->size(); n += 7) {
        std::vector<std::uint8_t> cut(zip->begin(), zip->begin() + static_cast<long>(n));
        EXPECT_FALSE(gonio::devices::genicam::unzip_single_file(cut)) << n;
    }
}

}  // namespace
