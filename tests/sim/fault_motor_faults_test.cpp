// Injected faults on the simulated controllers: each ends in recovery or a clear error within a
// bounded time, and a late reply is never taken as the answer to the next request.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/devices/modbus_light.h"
#include "gonio/sim/motor_controller_server.h"

namespace {

using gonio::devices::AxisOptions;
using gonio::devices::AxisProfile;
using gonio::devices::BacklashApproach;
using gonio::devices::ModbusAxis;
using gonio::devices::ModbusBus;
using gonio::devices::Motion;
using gonio::devices::RequestPolicy;
using gonio::devices::SoftLimits;
using gonio::sim::Fault;
using gonio::sim::FaultKind;
using gonio::sim::MotorControllerServer;
using gonio::sim::MotorSimConfig;
using gonio::sim::ServerOptions;
using gonio::sim::Transport;
using namespace std::chrono_literals;

AxisProfile profile(const char* name) {
    auto p = gonio::devices::load_axis_profile(name);
    EXPECT_TRUE(p) << p.error().message;
    return p ? *p : AxisProfile{};
}

MotorSimConfig fast() {
    MotorSimConfig c;
    c.time_scale = 40;
    c.start_homed = true;
    return c;
}

struct Stage {
    AxisProfile p;
    MotorControllerServer server;
    std::shared_ptr<ModbusBus> bus;
    std::unique_ptr<ModbusAxis> axis;

    Stage(const char* name, Transport t, MotorSimConfig cfg = fast(), AxisOptions opt = {}) {
        p = profile(name);
        EXPECT_TRUE(server.add_unit(1, p, cfg));
        EXPECT_TRUE(server.add_unit(2, p, cfg));
        EXPECT_TRUE(server.add_shutter(3, 0));
        ServerOptions so;
        so.transport = t;
        auto st = server.start(so);
        EXPECT_TRUE(st) << st.error().message;
        auto b = ModbusBus::open(*gonio::devices::parse_bus_address(server.address()));
        EXPECT_TRUE(b) << b.error().message;
        bus = *b;
        axis = std::make_unique<ModbusAxis>(
            bus, 1, p, "tilt", SoftLimits{-170, 170}, Motion{30, 60, 0}, opt);
    }
};

/// Reads 2 registers at a profile field.
gonio::Expected<std::int64_t> read32(Stage& s,
                                     const gonio::devices::RegisterField& f,
                                     const RequestPolicy& pol) {
    auto w = s.bus->read_registers(
        1, *gonio::devices::wire_address(s.p, f.address), f.count(), pol, "test read");
    if (!w) {
        return tl::unexpected(w.error());
    }
    return gonio::devices::decode_value(w->data(), f.width, false, s.p.word_order);
}

class LateReply : public ::testing::TestWithParam<Transport> {};

TEST_P(LateReply, IsNeverTakenAsTheNextAnswer) {
    // oriental-az: status and position are both two registers, so a late position reply has the
    // shape of a status reply.
    Stage s("oriental-az", GetParam());
    ASSERT_TRUE(s.axis->move_to(12.34, 10s));
    RequestPolicy one_shot;
    one_shot.response_timeout = 100ms;
    one_shot.retries = 0;
    one_shot.quiet = 400ms;
    auto pos = read32(s, s.p.position, one_shot);
    ASSERT_TRUE(pos);
    auto status = read32(s, s.p.status.reg, one_shot);
    ASSERT_TRUE(status);
    ASSERT_NE(*pos, *status);

    Fault f;
    f.kind = FaultKind::kDelayReply;
    f.unit = 1;
    f.delay = 250ms;  // Longer than the response timeout, shorter than timeout + quiet window.
    s.server.inject(f);
    auto late = read32(s, s.p.position, one_shot);
    ASSERT_FALSE(late);
    EXPECT_NE(late.error().message.find("timeout"), std::string::npos) << late.error().message;
    // The next request asks for something else and must get exactly that. (Retries allowed: the
    // simulated drive serves one request at a time, so it may still be busy with the late one.)
    RequestPolicy patient = one_shot;
    patient.retries = 4;
    for (int i = 0; i < 3; ++i) {
        auto next = read32(s, s.p.status.reg, patient);
        ASSERT_TRUE(next) << next.error().message;
        EXPECT_EQ(*next, *status);
    }
    EXPECT_GE(s.bus->stats().timeouts, 1u);
    auto again = read32(s, s.p.position, one_shot);
    ASSERT_TRUE(again);
    EXPECT_EQ(*again, *pos);
}

TEST_P(LateReply, DelayedReplyRecoversWithRetry) {
    Stage s("generic", GetParam());
    ASSERT_TRUE(s.axis->move_to(-33.3, 10s));
    Fault f;
    f.kind = FaultKind::kDelayReply;
    f.unit = 1;
    f.delay = 500ms;  // generic answers within 300 ms
    s.server.inject(f);
    const auto t0 = std::chrono::steady_clock::now();
    auto pos = s.axis->position_deg();
    ASSERT_TRUE(pos) << pos.error().message;
    EXPECT_NEAR(*pos, -33.3, 1e-9);
    EXPECT_GE(s.bus->stats().retries, 1u);
    // Bounded: the profile's retries and backoff put an upper limit far below this.
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 20s);
}

INSTANTIATE_TEST_SUITE_P(Transports,
                         LateReply,
                         ::testing::Values(Transport::kTcp, Transport::kRtu),
                         [](const auto& info) {
                             return info.param == Transport::kTcp ? "tcp" : "rtu";
                         });

TEST(MotorFaults, DroppedConnectionIsReopened) {
    Stage s("oriental-az", Transport::kTcp);
    ASSERT_TRUE(s.axis->move_to(5, 10s));
    Fault f;
    f.kind = FaultKind::kDropConnection;
    f.unit = 1;
    f.count = 2;
    s.server.inject(f);
    auto r = s.axis->move_to(25, 10s);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_NEAR(s.server.position_deg(1), 25, 1e-9);
    EXPECT_GE(s.bus->stats().reconnects, 1u);
}

TEST(MotorFaults, PeerRestartIsReconnected) {
    auto p = profile("generic");
    auto server = std::make_unique<MotorControllerServer>();
    ASSERT_TRUE(server->add_unit(1, p, fast()));
    ASSERT_TRUE(server->start());
    const int port = server->port();
    auto axis = gonio::devices::open_axis(
        "light", server->address(), 1, "generic", SoftLimits{-90, 90}, Motion{30, 60, 0});
    ASSERT_TRUE(axis) << axis.error().message;
    ASSERT_TRUE((*axis)->move_to(10, 10s));
    server->stop();
    // While the peer is down: a clear error, not a hang.
    auto down = (*axis)->position_deg();
    ASSERT_FALSE(down);
    EXPECT_NE(down.error().message.find("axis \"light\""), std::string::npos)
        << down.error().message;
    // The controller comes back on the same port (power cycle: it is referenced at 0 again).
    server = std::make_unique<MotorControllerServer>();
    ASSERT_TRUE(server->add_unit(1, p, fast()));
    ServerOptions so;
    so.port = port;
    ASSERT_TRUE(server->start(so));
    auto up = (*axis)->position_deg();
    ASSERT_TRUE(up) << up.error().message;
    EXPECT_NEAR(*up, 0, 1e-9);
    ASSERT_TRUE((*axis)->move_to(-20, 10s));
    EXPECT_NEAR(server->position_deg(1), -20, 1e-9);
}

TEST(MotorFaults, SlaveBusyIsRetriedThenReported) {
    Stage s("leadshine", Transport::kRtu);
    Fault f;
    f.kind = FaultKind::kException;
    f.unit = 1;
    f.exception_code = 6;
    f.count = 2;
    s.server.inject(f);
    auto ok = s.axis->position_deg();
    ASSERT_TRUE(ok) << ok.error().message;
    EXPECT_GE(s.bus->stats().retries, 2u);

    f.count = 100;
    s.server.inject(f);
    auto bad = s.axis->position_deg();
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("axis \"tilt\" reg 0x602C"), std::string::npos)
        << bad.error().message;
    EXPECT_NE(bad.error().message.find("Modbus exception 6 (slave busy)"), std::string::npos)
        << bad.error().message;
    s.server.clear_faults();
    EXPECT_TRUE(s.axis->position_deg());
}

TEST(MotorFaults, IllegalAddressIsNotRetried) {
    Stage s("oriental-az", Transport::kTcp);
    const auto retries_before = s.bus->stats().retries;
    Fault f;
    f.kind = FaultKind::kException;
    f.unit = 1;
    f.exception_code = 2;
    s.server.inject(f);
    auto r = s.axis->status();
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("Modbus exception 2 (illegal data address)"),
              std::string::npos)
        << r.error().message;
    EXPECT_EQ(s.bus->stats().retries, retries_before);
    // A register the drive does not have is refused by the drive itself.
    RequestPolicy pol;
    auto w = s.bus->read_registers(1, 0x0001, 1, pol, "reg 0x0001");
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("exception 2"), std::string::npos) << w.error().message;
}

TEST(MotorFaults, StallEndsInAClearErrorAndAStop) {
    Stage s("generic", Transport::kTcp);
    Fault f;
    f.kind = FaultKind::kStall;
    f.unit = 1;
    f.fraction = 0.3;
    s.server.inject(f);
    const auto t0 = std::chrono::steady_clock::now();
    auto r = s.axis->move_to(60, 20s);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("stalled"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("axis \"tilt\""), std::string::npos);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 20s);
    auto snap = s.server.snapshot(1);
    ASSERT_TRUE(snap);
    EXPECT_FALSE(snap->moving);  // the driver sent a stop
    EXPECT_NEAR(snap->position_deg, 18, 0.01);
    ASSERT_TRUE(s.axis->move_to(30, 10s));
}

TEST(MotorFaults, OvertravelOnTheLimitSwitchIsAnAlarm) {
    MotorSimConfig cfg = fast();
    cfg.limit_max_deg = 40;  // The switch sits inside the soft limits (a misconfigured rig).
    Stage s("oriental-az", Transport::kTcp, cfg);
    auto r = s.axis->move_to(60, 10s);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("alarm code 102"), std::string::npos) << r.error().message;
    EXPECT_NEAR(s.server.position_deg(1), 40, 1e-9);
}

TEST(MotorFaults, FaultRegistersInjectOverModbus) {
    Stage s("generic", Transport::kTcp);
    RequestPolicy pol;
    pol.retries = 0;
    // kind = 1 + kException, count 1, delay 0, code 6, fraction 0.
    ASSERT_TRUE(s.bus->write_registers(
        1, gonio::sim::kFaultRegister, {0, 1, 0, 6, 0}, pol, "fault registers"));
    ASSERT_TRUE(s.bus->write_register(
        1, gonio::sim::kFaultRegister, 1 + static_cast<int>(FaultKind::kException), pol, "kind"));
    auto w = s.bus->read_registers(1, 12, 2, pol, "position");
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("slave busy"), std::string::npos) << w.error().message;
    EXPECT_TRUE(s.bus->read_registers(1, 12, 2, pol, "position"));
}

TEST(MotorBacklash, FinalApproachFromOneSideRemovesThePlay) {
    MotorSimConfig cfg = fast();
    cfg.backlash_deg = 0.2;
    // Without take-up the load ends on either side of the play depending on the direction.
    {
        Stage s("oriental-az", Transport::kTcp, cfg);
        ASSERT_TRUE(s.axis->move_to(10, 10s));
        EXPECT_NEAR(s.server.position_deg(1), 9.8, 1e-9);
        ASSERT_TRUE(s.axis->move_to(20, 10s));
        ASSERT_TRUE(s.axis->move_to(10, 10s));
        EXPECT_NEAR(s.server.position_deg(1), 10.0, 1e-9);
    }
    // With the final approach from above the load lands on the target from both sides.
    AxisOptions opt;
    opt.approach = BacklashApproach::kFromAbove;
    opt.approach_overshoot_deg = 0.5;
    Stage s("oriental-az", Transport::kTcp, cfg, opt);
    ASSERT_TRUE(s.axis->move_to(10, 10s));
    EXPECT_NEAR(s.server.position_deg(1), 10.0, 1e-9);
    ASSERT_TRUE(s.axis->move_to(20, 10s));
    ASSERT_TRUE(s.axis->move_to(15, 10s));
    EXPECT_NEAR(s.server.position_deg(1), 15.0, 1e-9);
    ASSERT_TRUE(s.axis->move_to(-5, 10s));
    ASSERT_TRUE(s.axis->move_to(15, 10s));
    EXPECT_NEAR(s.server.position_deg(1), 15.0, 1e-9);
    auto pos = s.axis->position_deg();
    ASSERT_TRUE(pos);
    EXPECT_NEAR(*pos, 15.0, 1e-9);
}

TEST(MotorBus, TwoDrivesAndAShutterShareOneRtuLine) {
    Stage s("oriental-az", Transport::kRtu);
    ModbusAxis second(s.bus, 2, s.p, "spin", SoftLimits{-170, 170}, Motion{30, 60, 0});
    ASSERT_TRUE(s.axis->start_move(30));
    ASSERT_TRUE(second.start_move(-45));
    ASSERT_TRUE(s.axis->wait_done(10s));
    ASSERT_TRUE(second.wait_done(10s));
    EXPECT_NEAR(s.server.position_deg(1), 30, 1e-9);
    EXPECT_NEAR(s.server.position_deg(2), -45, 1e-9);
    const auto positions = s.server.positions_deg();
    EXPECT_EQ(positions.size(), 2u);

    gonio::devices::ModbusLight light(s.bus, 3, 0);
    ASSERT_TRUE(light.set_shutter_open(true));
    EXPECT_TRUE(s.server.shutter_open(3));
    auto open = light.shutter_open();
    ASSERT_TRUE(open);
    EXPECT_TRUE(*open);
    ASSERT_TRUE(light.set_shutter_open(false));
    EXPECT_FALSE(s.server.shutter_open(3));
}

TEST(MotorBus, AbsentUnitIsATimeoutOnRtu) {
    Stage s("generic", Transport::kRtu);
    RequestPolicy pol;
    pol.response_timeout = 50ms;
    pol.retries = 1;
    auto r = s.bus->read_registers(9, 12, 2, pol, "unit 9 position");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("after 2 attempts"), std::string::npos) << r.error().message;
}

TEST(MotorBus, RangesPastTheAddressSpaceAreRefusedBeforeAnythingIsSent) {
    Stage s("generic", Transport::kTcp);
    RequestPolicy pol;
    const std::uint64_t before = s.server.request_count();
    // 0xFFFF + 2 registers would wrap to address 0 in 16 bits.
    auto r = s.bus->read_registers(1, 0xFFFF, 2, pol, "top read");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("not a Modbus range"), std::string::npos) << r.error().message;
    EXPECT_FALSE(s.bus->read_registers(1, 0, 126, pol, "too many"));
    EXPECT_FALSE(s.bus->write_registers(1, 0xFFFF, {1, 2}, pol, "top write"));
    EXPECT_FALSE(s.bus->write_register(1, 0x10000, 1, pol, "past the top"));
    EXPECT_FALSE(s.bus->read_coil(3, -1, pol, "negative"));
    EXPECT_EQ(s.server.request_count(), before);  // nothing reached the wire
    // The last register alone is a range: it goes out and the drive refuses it (absent register).
    auto last = s.bus->read_registers(1, 0xFFFF, 1, pol, "last register");
    ASSERT_FALSE(last);
    EXPECT_NE(last.error().message.find("Modbus exception 2"), std::string::npos)
        << last.error().message;
    EXPECT_EQ(s.server.request_count(), before + 1);
}

}  // namespace
