// Register codecs of the drive profiles: word order, sign, address base, block scaling. Expected
// values come from the drive manuals' worked examples and from hand unit conversions.

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "gonio/devices/axis_profile.h"

namespace {

using gonio::devices::decode_value;
using gonio::devices::encode_value;
using gonio::devices::WordOrder;

TEST(ModbusCodec, NegativePositionHighWordFirstMatchesManualExample) {
    // Oriental Motor's example: -1000 steps is written as FFFFh (upper) then FC18h (lower).
    const auto w = encode_value(-1000, 32, WordOrder::kHighFirst);
    ASSERT_EQ(w.size(), 2u);
    EXPECT_EQ(w[0], 0xFFFF);
    EXPECT_EQ(w[1], 0xFC18);
    EXPECT_EQ(decode_value(w.data(), 32, true, WordOrder::kHighFirst), -1000);
}

TEST(ModbusCodec, LowWordFirstSwapsTheWords) {
    const auto w = encode_value(0x12345678, 32, WordOrder::kLowFirst);
    ASSERT_EQ(w.size(), 2u);
    EXPECT_EQ(w[0], 0x5678);
    EXPECT_EQ(w[1], 0x1234);
    EXPECT_EQ(decode_value(w.data(), 32, true, WordOrder::kLowFirst), 0x12345678);
    // Read in the wrong order the value is different: the order matters.
    EXPECT_NE(decode_value(w.data(), 32, true, WordOrder::kHighFirst), 0x12345678);
}

TEST(ModbusCodec, SixteenBitSignAndUnsigned) {
    const auto w = encode_value(-2, 16, WordOrder::kHighFirst);
    ASSERT_EQ(w.size(), 1u);
    EXPECT_EQ(w[0], 0xFFFE);
    EXPECT_EQ(decode_value(w.data(), 16, true, WordOrder::kHighFirst), -2);
    EXPECT_EQ(decode_value(w.data(), 16, false, WordOrder::kHighFirst), 65534);
}

TEST(ModbusCodec, RoundTripSeededRandom32BitValues) {
    const unsigned seed = 20261122;
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::int32_t> dist(INT32_MIN, INT32_MAX);
    for (int i = 0; i < 2000; ++i) {
        const std::int32_t v = i == 0 ? INT32_MIN : (i == 1 ? INT32_MAX : dist(rng));
        for (auto order : {WordOrder::kHighFirst, WordOrder::kLowFirst}) {
            const auto w = encode_value(v, 32, order);
            ASSERT_EQ(decode_value(w.data(), 32, true, order), v) << "seed " << seed << " i " << i;
        }
    }
}

TEST(ModbusCodec, AddressBaseFortyThousandOneMapsToWireZero) {
    gonio::devices::AxisProfile p;
    p.address_base = 40001;
    EXPECT_EQ(*gonio::devices::wire_address(p, 40001), 0);
    EXPECT_EQ(*gonio::devices::wire_address(p, 40013), 12);
    EXPECT_FALSE(gonio::devices::wire_address(p, 40000));
    p.address_base = 1;
    EXPECT_EQ(*gonio::devices::wire_address(p, 1), 0);
    p.address_base = 0;
    EXPECT_EQ(*gonio::devices::wire_address(p, 0x6200), 0x6200);
}

TEST(ModbusCodec, LeadshineBlockUsesRpmAndRampTimePerThousandRpm) {
    auto p = gonio::devices::load_axis_profile("leadshine");
    ASSERT_TRUE(p) << p.error().message;
    gonio::devices::BlockInputs in;
    in.target_steps = -70000;
    // 10000 pulses/rev: 10000 steps/s = 1 rev/s = 60 rpm. 20000 steps/s^2 = 120 rpm/s, so
    // reaching 1000 rpm takes 1000/120 s = 8333 ms.
    in.speed_steps_per_s = 10000;
    in.accel_steps_per_s2 = 20000;
    in.decel_steps_per_s2 = 40000;
    auto w = gonio::devices::encode_block(*p, p->move.block, in);
    ASSERT_TRUE(w) << w.error().message;
    ASSERT_EQ(w->size(), 7u);  // 6200h-6206h; the path is started through 6002h
    EXPECT_EQ(p->move.trigger.reg.address, 0x6002);
    EXPECT_EQ(p->move.trigger.value, 0x10u);  // 10h + path 0
    EXPECT_EQ((*w)[0], 1);                    // absolute positioning
    EXPECT_EQ((*w)[1], 0xFFFE);               // -70000 = 0xFFFEEE90, high word
    EXPECT_EQ((*w)[2], 0xEE90);               // low word
    EXPECT_EQ((*w)[3], 60);                   // rpm
    EXPECT_EQ((*w)[4], 8333);                 // ms per 1000 rpm
    EXPECT_EQ((*w)[5], 4167);                 // ms per 1000 rpm, twice the rate
    EXPECT_EQ((*w)[6], 0);                    // no pause
    const auto back = gonio::devices::decode_block(*p, p->move.block, w->data());
    EXPECT_EQ(back.target_steps, -70000);
    EXPECT_NEAR(back.speed_steps_per_s, 10000, 1e-9);
    EXPECT_NEAR(back.accel_steps_per_s2, 20000, 20000 * 1e-4);
}

TEST(ModbusCodec, BlockValueThatDoesNotFitIsAnErrorNotAWrap) {
    auto p = gonio::devices::load_axis_profile("leadshine");
    ASSERT_TRUE(p);
    gonio::devices::BlockInputs in;
    in.speed_steps_per_s = 1e8;  // 600000 rpm does not fit 16 bits
    in.accel_steps_per_s2 = 20000;
    in.decel_steps_per_s2 = 20000;
    auto w = gonio::devices::encode_block(*p, p->move.block, in);
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("speed"), std::string::npos) << w.error().message;
    in.speed_steps_per_s = 1000;
    in.accel_steps_per_s2 = 0;  // an infinite ramp time
    EXPECT_FALSE(gonio::devices::encode_block(*p, p->move.block, in));
}

TEST(ModbusCodec, OrientalDirectDataBlockLayout) {
    auto p = gonio::devices::load_axis_profile("oriental-az");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->move.block.address, 0x0058);
    EXPECT_EQ(p->move.block.register_count(), 16);  // 0058h..0067h
    gonio::devices::BlockInputs in;
    in.target_steps = 8500;
    in.speed_steps_per_s = 2000;
    in.accel_steps_per_s2 = 4000;
    in.decel_steps_per_s2 = 4000;
    auto w = gonio::devices::encode_block(*p, p->move.block, in);
    ASSERT_TRUE(w);
    ASSERT_EQ(w->size(), 16u);
    EXPECT_EQ((*w)[3], 1);     // 005Bh: operation type 1 = absolute positioning (lower word)
    EXPECT_EQ((*w)[4], 0);     // 005Ch: position, upper
    EXPECT_EQ((*w)[5], 8500);  // 005Dh: position, lower
    EXPECT_EQ((*w)[7], 2000);  // 005Fh: speed in Hz
    EXPECT_EQ((*w)[15], 1);    // 0067h: trigger
}

}  // namespace
