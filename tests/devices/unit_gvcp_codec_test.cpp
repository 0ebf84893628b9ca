// GVCP and GVSP codecs against byte layouts written from the GigE Vision specification.

#include <gtest/gtest.h>

#include "gonio/devices/gvcp.h"
#include "gonio/devices/gvsp.h"

namespace {

namespace gvcp = gonio::devices::gvcp;
namespace gvsp = gonio::devices::gvsp;
namespace gvbs = gonio::devices::gvbs;
using Bytes = std::vector<std::uint8_t>;

TEST(Gvcp, ReadRegCommandBytes) {
    const Bytes b = gvcp::encode(gvcp::make_read_reg(0x1234, {0x0A00, 0x0938}));
    EXPECT_EQ(b,
              (Bytes{0x42,
                     0x01,
                     0x00,
                     0x80,
                     0x00,
                     0x08,
                     0x12,
                     0x34,
                     0x00,
                     0x00,
                     0x0A,
                     0x00,
                     0x00,
                     0x00,
                     0x09,
                     0x38}));
    auto c = gvcp::parse_command(b.data(), b.size());
    ASSERT_TRUE(c.has_value());
    auto a = gvcp::parse_read_reg(*c);
    ASSERT_TRUE(a.has_value());
    EXPECT_EQ(*a, (std::vector<std::uint32_t>{0x0A00, 0x0938}));
}

TEST(Gvcp, WriteRegAndMemoryRoundTrip) {
    auto w = gvcp::parse_command(
        gvcp::encode(gvcp::make_write_reg(7, {{0x0D18, 0x7F000001}})).data(), 16);
    ASSERT_TRUE(w.has_value());
    auto pairs = gvcp::parse_write_reg(*w);
    ASSERT_TRUE(pairs.has_value());
    EXPECT_EQ(pairs->at(0).first, 0x0D18u);
    EXPECT_EQ(pairs->at(0).second, 0x7F000001u);
    const Bytes rm = gvcp::encode(gvcp::make_read_mem(3, 0x200, 512));
    EXPECT_EQ(rm,
              (Bytes{0x42,
                     0x01,
                     0x00,
                     0x84,
                     0x00,
                     0x08,
                     0x00,
                     0x03,
                     0x00,
                     0x00,
                     0x02,
                     0x00,
                     0x00,
                     0x00,
                     0x02,
                     0x00}));
    const Bytes ack = gvcp::encode(
        gvcp::make_read_mem_ack(3, gvcp::Status::kSuccess, 0x200, Bytes{'L', 'o', 'c', 'a'}));
    auto pa = gvcp::parse_ack(ack.data(), ack.size());
    ASSERT_TRUE(pa.has_value());
    auto data = gvcp::parse_read_mem_ack(*pa, 0x200);
    ASSERT_TRUE(data.has_value());
    EXPECT_EQ(*data, (Bytes{'L', 'o', 'c', 'a'}));
    EXPECT_FALSE(gvcp::parse_read_mem_ack(*pa, 0x204).has_value());
}

TEST(Gvcp, RejectsMalformedCommands) {
    const Bytes bad_key{0x43, 0x01, 0x00, 0x80, 0x00, 0x00, 0x00, 0x01};
    auto k = gvcp::parse_command(bad_key.data(), bad_key.size());
    ASSERT_FALSE(k.has_value());
    EXPECT_NE(k.error().message.find("0x42"), std::string::npos) << k.error().message;
    const Bytes long_len{0x42, 0x01, 0x00, 0x80, 0x00, 0x08, 0x00, 0x01, 0, 0, 0, 0};
    auto l = gvcp::parse_command(long_len.data(), long_len.size());
    ASSERT_FALSE(l.has_value());
    EXPECT_NE(l.error().message.find("length field 8"), std::string::npos) << l.error().message;
    gvcp::CommandPacket odd;
    odd.command = gvcp::Command::kReadRegCmd;
    odd.data = {0, 0, 0};
    EXPECT_FALSE(gvcp::parse_read_reg(odd).has_value());
    EXPECT_EQ(gvcp::to_string(gvcp::Status::kAccessDenied), "GEV_STATUS_ACCESS_DENIED");
}

TEST(Gvcp, PacketResendStandardAndExtendedIds) {
    gvcp::PacketResend r{0, 0x1234, 5, 9};
    const Bytes std_ids = gvcp::encode(gvcp::make_packet_resend(1, r, false));
    EXPECT_EQ(std_ids, (Bytes{0x42, 0x00, 0x00, 0x40, 0x00, 0x0C, 0x00, 0x01, 0x00, 0x00,
                              0x12, 0x34, 0x00, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x09}));
    r.block_id = 0x0000000100000002ull;
    const Bytes ext = gvcp::encode(gvcp::make_packet_resend(2, r, true));
    auto c = gvcp::parse_command(ext.data(), ext.size());
    ASSERT_TRUE(c.has_value());
    auto back = gvcp::parse_packet_resend(*c);
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(back->block_id, 0x0000000100000002ull);
    EXPECT_EQ(back->first_packet_id, 5u);
    EXPECT_EQ(back->last_packet_id, 9u);
}

TEST(Gvbs, ParsesTheFirstUrl) {
    std::string reg = "Local:Cam.xml;100000;5083";
    reg.resize(512, '\0');
    auto u = gvbs::parse_local_url(reg);
    ASSERT_TRUE(u.has_value());
    EXPECT_EQ(u->file_name, "Cam.xml");
    EXPECT_EQ(u->address, 0x100000u);
    EXPECT_EQ(u->length, 0x5083u);
    EXPECT_FALSE(gvbs::parse_local_url("http://x/cam.xml").has_value());
    EXPECT_FALSE(gvbs::parse_local_url("Local:Cam.xml;10000g;20").has_value());
    EXPECT_FALSE(gvbs::parse_local_url("Local:Cam.xml;100").has_value());
}

TEST(Gvsp, LeaderPayloadTrailerBytes) {
    gvsp::ImageLeader l;
    l.timestamp = 0x0000000100000002ull;
    l.pixel_format = 0x01100007;
    l.size_x = 640;
    l.size_y = 480;
    const Bytes b = gvsp::encode_leader(0x0102, l);
    ASSERT_EQ(b.size(), 44u);
    EXPECT_EQ((Bytes(b.begin(), b.begin() + 8)),
              (Bytes{0x00, 0x00, 0x01, 0x02, 0x01, 0x00, 0x00, 0x00}));
    EXPECT_EQ((Bytes(b.begin() + 8, b.begin() + 24)),
              (Bytes{0x00,
                     0x00,
                     0x00,
                     0x01,
                     0x00,
                     0x00,
                     0x00,
                     0x01,
                     0x00,
                     0x00,
                     0x00,
                     0x02,
                     0x01,
                     0x10,
                     0x00,
                     0x07}));
    auto p = gvsp::parse(b.data(), b.size());
    ASSERT_TRUE(p.has_value());
    EXPECT_EQ(p->header.format, gvsp::Format::kLeader);
    EXPECT_EQ(p->leader.size_x, 640u);
    EXPECT_EQ(p->leader.size_y, 480u);
    EXPECT_EQ(p->leader.timestamp, 0x0000000100000002ull);
    const Bytes t = gvsp::encode_trailer(0x0102, 0x000ABC, gvsp::ImageTrailer{480});
    EXPECT_EQ(t,
              (Bytes{0x00,
                     0x00,
                     0x01,
                     0x02,
                     0x02,
                     0x00,
                     0x0A,
                     0xBC,
                     0x00,
                     0x00,
                     0x00,
                     0x01,
                     0x00,
                     0x00,
                     0x01,
                     0xE0}));
    const Bytes payload{0x00, 0x00, 0x01, 0x02, 0x03, 0x00, 0x00, 0x05, 0xAA, 0xBB};
    auto pp = gvsp::parse(payload.data(), payload.size());
    ASSERT_TRUE(pp.has_value());
    EXPECT_EQ(pp->header.packet_id, 5u);
    EXPECT_EQ(pp->data_size, 2u);
    EXPECT_EQ(pp->data[1], 0xBB);
    // 1500-byte packets leave 1500 - 20 (IP) - 8 (UDP) - 8 (GVSP) bytes of image data.
    EXPECT_EQ(gvsp::payload_bytes_per_packet(1500), 1464u);
    const Bytes ext{0x00, 0x00, 0x00, 0x00, 0x83, 0x00, 0x00, 0x00};
    EXPECT_FALSE(gvsp::parse(ext.data(), ext.size()).has_value());
}

}  // namespace
