// Profile files and connection addresses: what is accepted, and that every error names the key and
// the rule.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>

#include "gonio/devices/address.h"
#include "gonio/devices/axis.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"

namespace {

using gonio::devices::BusKind;
using gonio::devices::parse_axis_profile;
using gonio::devices::parse_bus_address;

TEST(AxisProfile, ShippedProfilesLoadWithSources) {
    for (const char* name : {"generic", "oriental-az", "leadshine"}) {
        auto p = gonio::devices::load_axis_profile(name);
        ASSERT_TRUE(p) << p.error().message;
        EXPECT_EQ(p->name, name);
        EXPECT_FALSE(p->source.empty());
        EXPECT_TRUE(p->move.supported());
        EXPECT_TRUE(p->home.supported());
        EXPECT_TRUE(p->stop.supported());
        EXPECT_TRUE(p->reset_alarm.supported());
        EXPECT_GE(p->status.in_position, 0);
        EXPECT_GE(p->status.alarm, 0);
        EXPECT_GE(p->status.homed, 0);
    }
}

TEST(AxisProfile, UnknownProfileNamesThePlacesTried) {
    auto p = gonio::devices::load_axis_profile("no-such-drive");
    ASSERT_FALSE(p);
    EXPECT_NE(p.error().message.find("no-such-drive"), std::string::npos);
}

std::string minimal(const std::string& position_field) {
    return R"({"name": "t", "registers": {"position": )" + position_field +
           R"(, "status": {"address": 10}, "alarm_code": {"address": 11}},
        "status_bits": {"in_position": 1},
        "actions": {"move": {"block": {"address": 0, "slots": [{"quantity": "target"}]}},
                    "stop": {"trigger": {"kind": "write_value", "address": 20, "value": 1}}}})";
}

TEST(AxisProfile, MinimalProfileParses) {
    auto p = parse_axis_profile(minimal(R"({"address": 12, "width": 32})"), "t.json");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->position.width, 32);
    EXPECT_EQ(p->move.block.register_count(), 2);
}

TEST(AxisProfile, ErrorsNameTheKeyPath) {
    auto w = parse_axis_profile(minimal(R"({"address": 12, "width": 24})"), "t.json");
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("t.json: registers.position.width: 24 not in {16, 32}"),
              std::string::npos)
        << w.error().message;
    auto a = parse_axis_profile(minimal(R"({"address": "0xZZ"})"), "t.json");
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("registers.position.address"), std::string::npos)
        << a.error().message;
    auto j = parse_axis_profile("{\"name\": ", "t.json");
    ASSERT_FALSE(j);
    EXPECT_NE(j.error().message.find("t.json: JSON parse error"), std::string::npos);
}

TEST(AxisProfile, AddressBelowTheBaseIsRejected) {
    std::string text = minimal(R"({"address": 12})");
    text.insert(1, R"("address_base": 40001, )");
    auto p = parse_axis_profile(text, "t.json");
    ASSERT_FALSE(p);
    EXPECT_NE(p.error().message.find("address_base"), std::string::npos) << p.error().message;
}

TEST(AxisAddress, TcpAndRtuForms) {
    auto t = parse_bus_address("tcp://127.0.0.1:1502");
    ASSERT_TRUE(t);
    EXPECT_EQ(t->kind, BusKind::kTcp);
    EXPECT_EQ(t->host, "127.0.0.1");
    EXPECT_EQ(t->port, 1502);
    auto r = parse_bus_address("rtu:/dev/ttyUSB0?baud=19200&parity=E&stop_bits=2");
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(r->kind, BusKind::kRtu);
    EXPECT_EQ(r->device, "/dev/ttyUSB0");
    EXPECT_EQ(r->baud, 19200);
    EXPECT_EQ(r->parity, 'E');
    EXPECT_EQ(r->stop_bits, 2);
    // Canonical strings parse back to the same address.
    auto r2 = parse_bus_address(gonio::devices::to_string(*r));
    ASSERT_TRUE(r2);
    EXPECT_EQ(r2->baud, 19200);
    EXPECT_EQ(r2->parity, 'E');
    EXPECT_EQ(gonio::devices::to_string(*r2), gonio::devices::to_string(*r));
}

TEST(AxisAddress, BadAddressesSayWhy) {
    for (const char* bad : {"tcp://127.0.0.1:0",
                            "tcp://127.0.0.1:x",
                            "tcp://:502",
                            "rtu:?baud=9600",
                            "rtu:/dev/x?parity=Q",
                            "rtu:/dev/x?speed=1",
                            "udp://1.2.3.4"}) {
        auto a = parse_bus_address(bad);
        ASSERT_FALSE(a) << bad;
        EXPECT_NE(a.error().message.find(bad), std::string::npos) << a.error().message;
    }
}

TEST(AxisState, NamesForMessages) {
    EXPECT_STREQ(gonio::devices::to_string(gonio::devices::AxisState::kAlarm), "alarm");
    EXPECT_STREQ(gonio::devices::to_string(gonio::devices::AxisState::kIdle), "idle");
}

}  // namespace

namespace {

TEST(BusAddress, SchedulerAndOutageKeysParseAndRoundTrip) {
    auto a = parse_bus_address("tcp://127.0.0.1:1502?poll_rate=25&outage_ms=3000");
    ASSERT_TRUE(a) << a.error().message;
    EXPECT_EQ(a->port, 1502);
    EXPECT_DOUBLE_EQ(a->poll_rate, 25);
    EXPECT_EQ(a->outage_ms, 3000);
    EXPECT_DOUBLE_EQ(gonio::devices::poll_budget_per_s(*a), 25);
    auto b = parse_bus_address(gonio::devices::to_string(*a));
    ASSERT_TRUE(b) << b.error().message;
    EXPECT_EQ(gonio::devices::to_string(*b), gonio::devices::to_string(*a));
    auto r = parse_bus_address("rtu:/dev/ttyUSB0?baud=19200&line_share=0.25");
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_DOUBLE_EQ(r->line_share, 0.25);
    EXPECT_EQ(r->outage_ms, 10000);
    for (const char* bad : {"tcp://h:1?line_share=0.5",
                            "tcp://h:1?poll_rate=0",
                            "tcp://h:1?poll_rate=abc",
                            "rtu:/dev/x?line_share=2",
                            "rtu:/dev/x?outage_ms=-1",
                            "tcp://h:1?speed=3"}) {
        auto e = parse_bus_address(bad);
        EXPECT_FALSE(e) << bad;
        if (!e) {
            EXPECT_NE(e.error().message.find(bad), std::string::npos) << e.error().message;
        }
    }
}

TEST(BusAddress, RtuLineCapacityFromBaudRateAndFrameSizes) {
    // 8N1 = 10 bits per character. A 2-register read is an 8-byte request and a 9-byte reply.
    // At 19200 baud: 17 x 10 / 19200 s on the wire plus two 3.5-character silences (2 x 35 bits)
    // = 240 / 19200 s = 12.5 ms; half the line gives 40 polls/s.
    auto slow = parse_bus_address("rtu:/dev/x?baud=19200");
    ASSERT_TRUE(slow);
    EXPECT_NEAR(gonio::devices::rtu_transaction_s(*slow, 8, 9), 0.0125, 1e-12);
    EXPECT_NEAR(gonio::devices::poll_budget_per_s(*slow), 40, 1e-9);
    // 8E1 = 11 bits. Above 19200 baud the silence is a fixed 1.75 ms (2 x 1.75 ms).
    auto fast = parse_bus_address("rtu:/dev/x?baud=115200&parity=E&line_share=1");
    ASSERT_TRUE(fast);
    EXPECT_NEAR(gonio::devices::rtu_transaction_s(*fast, 8, 9), 17 * 11 / 115200.0 + 3.5e-3, 1e-12);
    // TCP without a rate: 200 polls/s.
    EXPECT_DOUBLE_EQ(gonio::devices::poll_budget_per_s(*parse_bus_address("tcp://h:1")), 200);
}

}  // namespace

namespace {

TEST(PollWait, HalfThePredictedTimeToGoClampedToPollAndMaxInterval) {
    auto p = gonio::devices::load_axis_profile("oriental-az");  // poll_ms 5
    ASSERT_TRUE(p);
    // The bus is not used by poll_wait.
    gonio::devices::AxisOptions opt;
    opt.max_poll_interval_ms = 1000;
    gonio::devices::ModbusAxis axis(
        nullptr, 1, *p, "t", gonio::devices::SoftLimits{}, gonio::devices::Motion{20, 40, 0}, opt);
    auto ms = [&](double d, double observed) {
        return std::chrono::duration<double, std::milli>(axis.poll_wait(d, observed)).count();
    };
    // Cruising with room to brake (d > v^2 / 2a = 5 deg): t = d/v + v/(2a).
    EXPECT_NEAR(ms(6, -1), 0.5 * (6.0 / 20 + 20.0 / 80) * 1e3, 1e-3);
    // Far away: capped at max_poll_interval_ms.
    EXPECT_NEAR(ms(100, -1), 1000, 1e-3);
    // Braking (d < 5 deg): t = sqrt(2 d / a).
    EXPECT_NEAR(ms(1, -1), 0.5 * std::sqrt(2.0 / 40) * 1e3, 1e-3);
    EXPECT_NEAR(ms(-1, -1), ms(1, -1), 1e-9);
    // Almost there: poll_ms.
    EXPECT_NEAR(ms(0.001, -1), 5, 1e-3);
    // A stage observed moving faster than its profile (a simulator at 10x): d / observed.
    EXPECT_NEAR(ms(6, 200), 0.5 * 6.0 / 200 * 1e3, 1e-3);
    // Observed slower than the profile: the profile's prediction stands.
    EXPECT_NEAR(ms(6, 1), ms(6, -1), 1e-9);
}

}  // namespace
