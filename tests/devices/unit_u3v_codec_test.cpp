// GenCP and U3V stream codecs: round trips, known byte layouts from the specification, malformed
// input rejected with a message naming the field.

#include <gtest/gtest.h>

#include <random>

#include "gonio/devices/gencp.h"
#include "gonio/devices/pixel_format.h"
#include "gonio/devices/u3v_bootstrap.h"
#include "gonio/devices/u3v_stream.h"

namespace {

namespace gencp = gonio::devices::gencp;
namespace u3v = gonio::devices::u3v;

TEST(GenCp, ReadMemCommandHasTheSpecifiedByteLayout) {
    const auto bytes = gencp::encode(gencp::make_read_mem(0x1234, 0x01D0, 8));
    // "U3VC", flags 0x4000 (request ack), id 0x0800, scd_length 12, request id 0x1234.
    const std::vector<std::uint8_t> expected = {0x55, 0x33, 0x56, 0x43, 0x00, 0x40, 0x00, 0x08,
                                                0x0C, 0x00, 0x34, 0x12, 0xD0, 0x01, 0x00, 0x00,
                                                0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x00};
    EXPECT_EQ(bytes, expected);
}

TEST(GenCp, CommandAndAckRoundTrip) {
    const std::vector<std::uint8_t> data = {1, 2, 3, 4, 5};
    const gencp::Command c = gencp::make_write_mem(77, 0xDEADBEEF00ull, data);
    const auto bytes = gencp::encode(c);
    auto back = gencp::decode_command(bytes.data(), bytes.size());
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->request_id, 77);
    auto w = gencp::parse_write_mem(*back);
    ASSERT_TRUE(w);
    EXPECT_EQ(w->address, 0xDEADBEEF00ull);
    EXPECT_EQ(w->data, data);

    const auto ack = gencp::encode(gencp::make_write_mem_ack(77, gencp::Status::kBusy, 5));
    auto a = gencp::decode_ack(ack.data(), ack.size());
    ASSERT_TRUE(a);
    EXPECT_EQ(a->status, gencp::Status::kBusy);
    EXPECT_EQ(a->id, gencp::CommandId::kWriteMemAck);
    EXPECT_EQ(*gencp::parse_write_mem_ack(*a), 5);

    const auto pend = gencp::encode(gencp::make_pending_ack(9, 750));
    auto p = gencp::decode_ack(pend.data(), pend.size());
    ASSERT_TRUE(p);
    EXPECT_EQ(p->id, gencp::CommandId::kPendingAck);
    EXPECT_EQ(*gencp::parse_pending_ack(*p), 750);
    EXPECT_EQ(gencp::to_string(gencp::Status::kInvalidAddress), "GENCP_INVALID_ADDRESS");
}

TEST(GenCp, MalformedPrefixesAreRejectedByField) {
    auto bytes = gencp::encode(gencp::make_read_mem(1, 0, 4));
    auto bad_magic = bytes;
    bad_magic[0] = 0;
    auto r = gencp::decode_command(bad_magic.data(), bad_magic.size());
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("magic"), std::string::npos);
    auto r2 = gencp::decode_command(bytes.data(), 11);
    ASSERT_FALSE(r2);
    EXPECT_NE(r2.error().message.find("prefix"), std::string::npos);
    auto r3 = gencp::decode_command(bytes.data(), bytes.size() - 1);
    ASSERT_FALSE(r3);
    EXPECT_NE(r3.error().message.find("scd_length"), std::string::npos);
    // An acknowledge is not a command and vice versa.
    const auto ack = gencp::encode(gencp::make_read_mem_ack(1, gencp::Status::kSuccess, {}));
    EXPECT_FALSE(gencp::decode_command(ack.data(), ack.size()));
    EXPECT_FALSE(gencp::decode_ack(bytes.data(), bytes.size()));
    EXPECT_FALSE(gencp::decode_ack(nullptr, 0));
}

TEST(U3vStream, LeaderAndTrailerRoundTripWithSpecifiedSizes) {
    u3v::Leader l;
    l.block_id = 0x0102030405060708ull;
    l.timestamp_ns = 987654321;
    l.pixel_format = gonio::devices::kPfncMono12;
    l.size_x = 2448;
    l.size_y = 2048;
    l.offset_x = 8;
    l.offset_y = 16;
    const auto lb = u3v::encode(l);
    ASSERT_EQ(lb.size(), 52u);
    EXPECT_EQ(lb[0], 0x55);  // "U3VL"
    EXPECT_EQ(lb[3], 0x4C);
    auto l2 = u3v::decode_leader(lb.data(), lb.size());
    ASSERT_TRUE(l2) << l2.error().message;
    EXPECT_EQ(l2->block_id, l.block_id);
    EXPECT_EQ(l2->timestamp_ns, l.timestamp_ns);
    EXPECT_EQ(l2->pixel_format, l.pixel_format);
    EXPECT_EQ(l2->size_x, 2448u);
    EXPECT_EQ(l2->offset_y, 16u);

    u3v::Trailer t;
    t.block_id = 5;
    t.valid_payload_size = 2448ull * 2048 * 2;
    t.size_y = 2048;
    const auto tb = u3v::encode(t);
    ASSERT_EQ(tb.size(), 32u);
    auto t2 = u3v::decode_trailer(tb.data(), tb.size());
    ASSERT_TRUE(t2);
    EXPECT_EQ(t2->valid_payload_size, t.valid_payload_size);
    EXPECT_EQ(t2->size_y, 2048u);
}

TEST(U3vStream, MalformedPacketsNeverCrashAndSayWhy) {
    auto lb = u3v::encode(u3v::Leader{});
    auto bad = lb;
    bad[0] ^= 0xFF;
    auto r = u3v::decode_leader(bad.data(), bad.size());
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("U3VL"), std::string::npos);
    auto shortl = u3v::decode_leader(lb.data(), 20);
    ASSERT_FALSE(shortl);
    EXPECT_NE(shortl.error().message.find("leader_size"), std::string::npos);
    auto tb = u3v::encode(u3v::Trailer{});
    EXPECT_FALSE(u3v::decode_trailer(tb.data(), 31));
    EXPECT_FALSE(u3v::decode_trailer(lb.data(), lb.size()));
    // Random bytes: decoders return, never crash (seeded).
    const unsigned seed = 2024;
    std::mt19937 rng(seed);
    for (int i = 0; i < 2000; ++i) {
        std::vector<std::uint8_t> junk(rng() % 80);
        for (auto& b : junk) {
            b = static_cast<std::uint8_t>(rng());
        }
        if (junk.size() >= 4 && (i & 1)) {
            junk[0] = 0x55, junk[1] = 0x33, junk[2] = 0x56, junk[3] = (i & 2) ? 0x4C : 0x54;
        }
        (void)u3v::decode_leader(junk.data(), junk.size());
        (void)u3v::decode_trailer(junk.data(), junk.size());
        (void)gencp::decode_ack(junk.data(), junk.size());
        (void)gencp::decode_command(junk.data(), junk.size());
        (void)u3v::decode_manifest(junk.data(), junk.size());
    }
    SUCCEED() << "seed " << seed;
}

TEST(U3vManifest, RoundTripAndZipFlag) {
    u3v::ManifestEntry e;
    e.file_version = 0x01020003;
    e.schema = (1u << 24) | u3v::kSchemaZip;
    e.address = 0x100000;
    e.size = 4321;
    e.sha1[0] = 0xAB;
    const auto bytes = u3v::encode_manifest({e, e});
    ASSERT_EQ(bytes.size(), 8u + 2 * 64);
    auto back = u3v::decode_manifest(bytes.data(), bytes.size());
    ASSERT_TRUE(back);
    ASSERT_EQ(back->size(), 2u);
    EXPECT_TRUE((*back)[1].zipped());
    EXPECT_EQ((*back)[1].address, 0x100000u);
    EXPECT_EQ((*back)[1].sha1[0], 0xAB);
    EXPECT_FALSE(u3v::decode_manifest(bytes.data(), bytes.size() - 1));
}

TEST(PixelFormat, PfncCodesAndNames) {
    using gonio::devices::PixelFormat;
    EXPECT_EQ(gonio::devices::pfnc_code(PixelFormat::kMono8), 0x01080001u);
    EXPECT_EQ(gonio::devices::pfnc_code(PixelFormat::kMono16), 0x01100007u);
    EXPECT_EQ(*gonio::devices::pixel_format_from_string("Mono12"), PixelFormat::kMono12);
    EXPECT_FALSE(gonio::devices::pixel_format_from_pfnc(0x02180014));  // RGB8 not supported
    EXPECT_STREQ(gonio::devices::to_string(PixelFormat::kMono12), "Mono12");
}

}  // namespace
