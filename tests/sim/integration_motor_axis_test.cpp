// Modbus axes against the simulated controllers, through libmodbus on 127.0.0.1 (TCP) and on a
// pseudo-terminal pair (RTU), for every shipped profile.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <tuple>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_light.h"
#include "gonio/sim/motor_controller_server.h"

namespace {

using gonio::devices::Axis;
using gonio::devices::AxisState;
using gonio::devices::Motion;
using gonio::devices::SoftLimits;
using gonio::sim::MotorControllerServer;
using gonio::sim::MotorSimConfig;
using gonio::sim::Transport;
using namespace std::chrono_literals;

constexpr auto kTimeout = 10000ms;

struct Rig {
    gonio::devices::AxisProfile profile;
    MotorControllerServer server;
    std::unique_ptr<Axis> axis;
};

std::unique_ptr<Rig> make_rig(const std::string& profile_name,
                              Transport transport,
                              MotorSimConfig cfg = {},
                              gonio::devices::AxisOptions options = {}) {
    auto rig = std::make_unique<Rig>();
    auto p = gonio::devices::load_axis_profile(profile_name);
    EXPECT_TRUE(p) << p.error().message;
    if (!p) {
        return nullptr;
    }
    rig->profile = *p;
    if (cfg.time_scale == 1) {
        cfg.time_scale = 40;
    }
    EXPECT_TRUE(rig->server.add_unit(1, *p, cfg));
    gonio::sim::ServerOptions so;
    so.transport = transport;
    auto st = rig->server.start(so);
    EXPECT_TRUE(st) << st.error().message;
    Motion m;
    m.speed_deg_per_s = 30;
    m.accel_deg_per_s2 = 60;
    auto axis = gonio::devices::open_axis(
        "detector", rig->server.address(), 1, profile_name, SoftLimits{-170, 170}, m, options);
    EXPECT_TRUE(axis) << axis.error().message;
    if (!axis) {
        return nullptr;
    }
    rig->axis = std::move(*axis);
    return rig;
}

double step_deg(const gonio::devices::AxisProfile& p) {
    return 1.0 / p.steps_per_degree;
}

class ProfileOverTransport : public ::testing::TestWithParam<std::tuple<std::string, Transport>> {};

TEST_P(ProfileOverTransport, HomesMovesAndReadsBack) {
    const auto& [name, transport] = GetParam();
    MotorSimConfig cfg;
    cfg.initial_deg = 17.3;  // Unreferenced at power-up.
    auto rig = make_rig(name, transport, cfg);
    ASSERT_TRUE(rig);
    Axis& axis = *rig->axis;
    auto st0 = axis.status();
    ASSERT_TRUE(st0) << st0.error().message;
    EXPECT_FALSE(st0->homed);
    EXPECT_EQ(st0->state, AxisState::kIdle);

    auto h = axis.home(kTimeout);
    ASSERT_TRUE(h) << h.error().message;
    auto st1 = axis.status();
    ASSERT_TRUE(st1);
    EXPECT_TRUE(st1->homed);
    EXPECT_NEAR(st1->position_deg, 0.0, 1e-12);
    EXPECT_NEAR(rig->server.position_deg(1), 0.0, 1e-9);

    for (double target : {42.5, -12.345, 0.01, 160.0}) {
        auto r = axis.move_to(target, kTimeout);
        ASSERT_TRUE(r) << r.error().message;
        auto pos = axis.position_deg();
        ASSERT_TRUE(pos);
        // The drive reaches the nearest step; the read-back is that step.
        const double q =
            std::round(target * rig->profile.steps_per_degree) * step_deg(rig->profile);
        EXPECT_NEAR(*pos, q, 1e-9) << "target " << target;
        EXPECT_NEAR(rig->server.position_deg(1), q, 1e-9);
        auto st = axis.status();
        ASSERT_TRUE(st);
        EXPECT_EQ(st->state, AxisState::kIdle);
    }
}

TEST_P(ProfileOverTransport, SoftLimitsRefusedBeforeAnyByteIsSent) {
    const auto& [name, transport] = GetParam();
    auto rig = make_rig(name, transport);
    ASSERT_TRUE(rig);
    const auto before = rig->server.request_count();
    for (double bad : {170.5, -171.0, 1e9, std::nan("")}) {
        auto r = rig->axis->start_move(bad);
        ASSERT_FALSE(r) << bad;
        EXPECT_NE(r.error().message.find("axis \"detector\""), std::string::npos)
            << r.error().message;
    }
    EXPECT_EQ(rig->server.request_count(), before);
}

TEST_P(ProfileOverTransport, AlarmMidMoveSurfacesAxisAndCode) {
    const auto& [name, transport] = GetParam();
    MotorSimConfig cfg;
    cfg.start_homed = true;
    auto rig = make_rig(name, transport, cfg);
    ASSERT_TRUE(rig);
    gonio::sim::Fault f;
    f.kind = gonio::sim::FaultKind::kAlarmMidMove;
    f.unit = 1;
    f.alarm_code = 0x30;
    f.fraction = 0.4;
    rig->server.inject(f);
    auto r = rig->axis->move_to(50, kTimeout);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("axis \"detector\""), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("alarm code 48"), std::string::npos) << r.error().message;
    auto st = rig->axis->status();
    ASSERT_TRUE(st);
    EXPECT_EQ(st->state, AxisState::kAlarm);
    EXPECT_EQ(st->alarm_code, 48);
    EXPECT_NEAR(st->position_deg, 20.0, 2 * step_deg(rig->profile));
    // Moves are refused while in alarm; a reset clears it.
    EXPECT_FALSE(rig->axis->start_move(10));
    ASSERT_TRUE(rig->axis->reset_alarm());
    auto r2 = rig->axis->move_to(10, kTimeout);
    ASSERT_TRUE(r2) << r2.error().message;
    EXPECT_NEAR(rig->server.position_deg(1), 10.0, step_deg(rig->profile));
}

TEST_P(ProfileOverTransport, StopMidMoveComesToRestShortOfTarget) {
    const auto& [name, transport] = GetParam();
    MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.time_scale = 5;
    auto rig = make_rig(name, transport, cfg);
    ASSERT_TRUE(rig);
    ASSERT_TRUE(rig->axis->start_move(150));
    // Poll (bounded) until the stage has left, then stop.
    const auto deadline = std::chrono::steady_clock::now() + kTimeout;
    while (rig->server.position_deg(1) < 5 && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::yield();
    }
    ASSERT_TRUE(rig->axis->stop());
    AxisState state = AxisState::kMoving;
    while (state != AxisState::kIdle && std::chrono::steady_clock::now() < deadline) {
        auto st = rig->axis->status();
        ASSERT_TRUE(st) << st.error().message;
        state = st->state;
    }
    EXPECT_EQ(state, AxisState::kIdle);
    const double at = rig->server.position_deg(1);
    EXPECT_GT(at, 5.0);
    EXPECT_LT(at, 150.0);
    auto pos = rig->axis->position_deg();
    ASSERT_TRUE(pos);
    EXPECT_NEAR(*pos, at, step_deg(rig->profile));
}

TEST_P(ProfileOverTransport, PositionNeverTornWhileCrossingWordBoundaries) {
    const auto& [name, transport] = GetParam();
    const auto p = gonio::devices::load_axis_profile(name);
    ASSERT_TRUE(p);
    // 0 steps: every bit of both words flips between +1 and -1 step. 65536 steps: the low word
    // wraps. Reachable ones within the limits for this profile's scale:
    std::vector<std::pair<double, double>> legs = {{3, -3}};
    const double wrap_deg = 65536.0 / p->steps_per_degree;
    if (wrap_deg + 3 < 170) {
        legs.push_back({wrap_deg - 3, wrap_deg + 3});
    }
    for (const auto& [from, to] : legs) {
        MotorSimConfig cfg;
        cfg.start_homed = true;
        cfg.initial_deg = from;  // The stage starts at the beginning of the leg.
        cfg.time_scale = 2;
        auto rig = make_rig(name, transport, cfg);
        ASSERT_TRUE(rig);
        ASSERT_TRUE(rig->axis->start_move(to));
        double last = from;
        int reads = 0;
        const double lo = std::min(from, to) - 1e-9;
        const double hi = std::max(from, to) + 1e-9;
        for (;;) {
            auto pos = rig->axis->position_deg();
            ASSERT_TRUE(pos) << pos.error().message;
            ++reads;
            ASSERT_GE(*pos, lo) << "torn or wrong read after " << reads << " reads";
            ASSERT_LE(*pos, hi) << "torn or wrong read after " << reads << " reads";
            // Monotonic along the move.
            if (to > from) {
                ASSERT_GE(*pos, last);
            } else {
                ASSERT_LE(*pos, last);
            }
            last = *pos;
            auto st = rig->axis->status();
            ASSERT_TRUE(st);
            if (st->state == AxisState::kIdle) {
                break;
            }
        }
        // How many reads land inside the move depends on the machine; every one of them is checked.
        RecordProperty("reads_" + std::to_string(static_cast<int>(from)), reads);
        ASSERT_TRUE(rig->axis->wait_done(kTimeout));
    }
}

INSTANTIATE_TEST_SUITE_P(
    AllProfiles,
    ProfileOverTransport,
    ::testing::Combine(::testing::Values("generic", "oriental-az", "leadshine"),
                       ::testing::Values(Transport::kTcp, Transport::kRtu)),
    [](const auto& info) {
        std::string n = std::get<0>(info.param) +
                        (std::get<1>(info.param) == Transport::kTcp ? "_tcp" : "_rtu");
        for (char& c : n) {
            if (c == '-') {
                c = '_';
            }
        }
        return n;
    });

}  // namespace
