// The simulated drive's position compare through libmodbus on 127.0.0.1 (docs/profiles.md,
// "Position compare"): the table written and armed through the generic profile's registers, the
// pulses sent at the instants the profile passes each entry (not when anybody looks), counted in
// the drive's register, and the touch probe's latch of each pulse's exposure read back.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/motor_controller_server.h"

namespace gonio::sim {
namespace {

using namespace std::chrono_literals;

struct CompareRig {
    MotorControllerServer server;
    std::unique_ptr<devices::Axis> axis;
};

/// One drive with the generic profile (1000 steps/deg) at `time_scale`, driven through libmodbus.
std::unique_ptr<CompareRig> compare_rig(double time_scale) {
    auto rig = std::make_unique<CompareRig>();
    auto p = devices::load_axis_profile("generic");
    EXPECT_TRUE(p) << p.error().message;
    MotorSimConfig cfg;
    cfg.time_scale = time_scale;
    cfg.start_homed = true;
    EXPECT_TRUE(rig->server.add_unit(2, *p, cfg));
    EXPECT_TRUE(rig->server.start());
    auto axis = devices::open_axis("detector",
                                   rig->server.address(),
                                   2,
                                   "generic",
                                   devices::SoftLimits{-170, 170},
                                   devices::Motion{30, 60, 5});
    EXPECT_TRUE(axis) << axis.error().message;
    if (axis) {
        rig->axis = std::move(*axis);
    }
    return rig;
}

TEST(PositionCompare, PulsesAtTheInstantsTheProfilePassesEachEntry) {
    auto rig = compare_rig(1);
    ASSERT_TRUE(rig->axis);
    devices::Axis& axis = *rig->axis;
    ASSERT_TRUE(axis.has_position_compare());
    // Within the cruise (the ramps take 7.5 deg at each end).
    const std::vector<double> table = {10.0, 14.0, 18.25, 22.0, 26.5};
    ASSERT_TRUE(axis.arm_position_compare(table));
    auto none = axis.compare_pulses();
    ASSERT_TRUE(none) << none.error().message;
    EXPECT_EQ(*none, 0u);
    ASSERT_TRUE(axis.start_move(40.0));
    // Nobody asks the drive anything during the move (a host stalled for its whole duration).
    std::this_thread::sleep_for(1500ms);
    ASSERT_TRUE(axis.wait_done(10s));
    auto fired = axis.compare_pulses();
    ASSERT_TRUE(fired) << fired.error().message;
    EXPECT_EQ(*fired, table.size());
    const std::vector<ComparePulse> pulses = rig->server.take_pulses();
    ASSERT_EQ(pulses.size(), table.size());
    for (std::size_t k = 0; k < pulses.size(); ++k) {
        EXPECT_EQ(pulses[k].unit, 2);
        EXPECT_EQ(pulses[k].index, k + 1);
        // The stage was at the entry the instant of its pulse, to a millionth of a degree.
        const double at = rig->server.path_deg_at(2, pulses[k].at, {0.0})[0];
        EXPECT_NEAR(at, table[k], 1e-6) << k;
        if (k > 0) {
            EXPECT_GT(pulses[k].at, pulses[k - 1].at);
        }
        // The exposure it starts: 20 ms at the cruise's 30 deg/s span 0.6 deg. The latch table
        // holds it, read through libmodbus (to a step, 0.001 deg).
        rig->server.latch_pulse(2, k + 1, pulses[k].at, 0.020);
    }
    for (std::size_t k = 0; k < table.size(); ++k) {
        auto latch = axis.compare_latch_deg(k + 1);
        ASSERT_TRUE(latch) << latch.error().message;
        EXPECT_NEAR((*latch)[0], table[k], 0.001) << k;
        EXPECT_NEAR((*latch)[1] - (*latch)[0], 30 * 0.020, 0.002) << k;
    }
    EXPECT_TRUE(rig->server.take_pulses().empty()) << "each pulse is delivered once";
    // Disarmed: a move back across the table sends nothing.
    ASSERT_TRUE(axis.disarm_position_compare());
    ASSERT_TRUE(axis.move_to(0.0, 10s));
    EXPECT_TRUE(rig->server.take_pulses().empty());
}

TEST(PositionCompare, EntriesPassedInTurnInEitherDirection) {
    auto rig = compare_rig(20);
    ASSERT_TRUE(rig->axis);
    devices::Axis& axis = *rig->axis;
    // A sweep down: the table in the order the arm passes it; the move ends before the last
    // entry.
    ASSERT_TRUE(axis.move_to(40.0, 10s));
    ASSERT_TRUE(axis.arm_position_compare({30.0, 20.0, 10.0}));
    ASSERT_TRUE(axis.move_to(15.0, 10s));
    auto fired = axis.compare_pulses();
    ASSERT_TRUE(fired);
    EXPECT_EQ(*fired, 2u);
    const std::vector<ComparePulse> pulses = rig->server.take_pulses();
    ASSERT_EQ(pulses.size(), 2u);
    EXPECT_NEAR(rig->server.path_deg_at(2, pulses[0].at, {0.0})[0], 30.0, 1e-6);
    EXPECT_NEAR(rig->server.path_deg_at(2, pulses[1].at, {0.0})[0], 20.0, 1e-6);
    // Re-armed, the count starts again.
    ASSERT_TRUE(axis.arm_position_compare({12.0}));
    ASSERT_TRUE(axis.move_to(5.0, 10s));
    fired = axis.compare_pulses();
    ASSERT_TRUE(fired);
    EXPECT_EQ(*fired, 1u);
}

TEST(PositionCompare, RefusesWhatTheTableCannotHold) {
    auto rig = compare_rig(20);
    ASSERT_TRUE(rig->axis);
    devices::Axis& axis = *rig->axis;
    auto r = axis.arm_position_compare(std::vector<double>(257, 1.0));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("1 to 256"), std::string::npos) << r.error().message;
    r = axis.arm_position_compare({});
    EXPECT_FALSE(r);
    r = axis.arm_position_compare({1.0, std::nan("")});
    EXPECT_FALSE(r);
    auto latch = axis.compare_latch_deg(0);
    EXPECT_FALSE(latch);
    // The pulse count is the drive's own: a client's write is exception 2.
    auto bus = devices::ModbusBus::shared(rig->server.address());
    ASSERT_TRUE(bus);
    devices::RequestPolicy policy;
    auto w = (*bus)->write_registers(2, 40021 - 40001, {7}, policy, "fired");
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("xception"), std::string::npos) << w.error().message;
}

}  // namespace
}  // namespace gonio::sim
