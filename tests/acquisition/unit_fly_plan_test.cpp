// Fly scans' planning (fly_plan.h): which poses one arm sweeps through, at what speed, from where
// to where; the speed rule against its closed form.

#include <gtest/gtest.h>

#include <cmath>

#include "gonio/acquisition/point/fly_plan.h"

namespace gonio::acquisition {
namespace {

constexpr double kDeg = brdf::kPi / 180;

FlyLimits sim4_limits() {
    FlyLimits l;
    for (int k = 0; k < kNumAxes; ++k) {
        l.dyn[k] = AxisDynamics{30 * kDeg, 60 * kDeg, 0.005};
        l.range[k] = AxisRange{-170 * kDeg, 170 * kDeg};
    }
    l.readout_s = 0.0052;
    l.min_exposure_s = 20e-6;
    l.max_exposure_s = 0.2;
    return l;
}

brdf::RigPosed pose(double light_deg, double detector_deg, double tilt_deg, double spin_deg) {
    return {light_deg * kDeg, detector_deg * kDeg, tilt_deg * kDeg, spin_deg * kDeg};
}

TEST(FlyPlan, SpeedKeepsTheSmearAndLeavesHalfTheGapToTheTrigger) {
    const FlyLimits lim = sim4_limits();
    FlySpec spec;
    spec.max_smear_deg = 1;
    // Wide gaps: the arm's own speed; the exposure is the smear's time at that speed.
    SweepSpeed v = sweep_speed(10 * kDeg, 1, spec, lim);
    EXPECT_DOUBLE_EQ(v.speed, 30 * kDeg);
    EXPECT_NEAR(v.max_exposure_s, 1.0 / 30, 1e-12);
    // A gap of 2 deg: the smear is cut to a quarter of it (0.5 deg); (g / 2 - smear) / readout =
    // 96 deg/s bounds nothing: the arm's speed, with an exposure of 0.5 deg / 30 deg/s.
    v = sweep_speed(2 * kDeg, 1, spec, lim);
    EXPECT_DOUBLE_EQ(v.speed, 30 * kDeg);
    EXPECT_NEAR(v.max_exposure_s, 0.5 / 30, 1e-12);
    // A slow camera (0.1 s readout) at a gap of 3 deg (smear 0.75 deg): v = (1.5 - 0.75) deg /
    // 0.1 s = 7.5 deg/s, an exposure of 0.1 s, and a frame (exposure + readout) takes half the
    // time between configurations.
    FlyLimits slow = lim;
    slow.readout_s = 0.1;
    v = sweep_speed(3 * kDeg, 1, spec, slow);
    EXPECT_NEAR(v.speed, 7.5 * kDeg, 1e-12);
    EXPECT_NEAR(v.max_exposure_s, 0.1, 1e-12);
    EXPECT_NEAR(v.speed * (v.max_exposure_s + slow.readout_s), 0.5 * 3 * kDeg, 1e-12);
    // A user bound below the arm's.
    spec.speed_deg_per_s = 12;
    v = sweep_speed(10 * kDeg, 1, spec, lim);
    EXPECT_NEAR(v.speed, 12 * kDeg, 1e-12);
    EXPECT_NEAR(v.max_exposure_s, 1.0 / 12, 1e-12);
}

TEST(FlyPlan, RunOfOneArmBecomesOneSweepWithLeadInAndOut) {
    const FlyLimits lim = sim4_limits();
    FlySpec spec;
    spec.enabled = true;
    // Five detector angles at one (light, tilt, spin), given out of order, and two poses that
    // share no axis run with anything.
    const std::vector<brdf::RigPosed> poses = {pose(-30, 40, 0, 0),
                                               pose(-30, 10, 0, 0),
                                               pose(10, 70, 20, 5),
                                               pose(-30, 30, 0, 0),
                                               pose(-30, 20, 0, 0),
                                               pose(50, -20, -10, 40),
                                               pose(-30, 50, 0, 0)};
    const std::vector<FlyUnit> units = plan_fly_units(poses, pose(-30, 0, 0, 0), spec, lim);
    ASSERT_EQ(units.size(), 3u);
    // From a detector at 0 the sweep upwards is entered first.
    const FlyUnit& u = units[0];
    ASSERT_FALSE(u.standing);
    EXPECT_EQ(u.sweep.axis, 1);
    EXPECT_EQ(u.sweep.members, (std::vector<std::size_t>{1, 4, 3, 0, 6}));
    // Ramp v^2 / 2a = 7.5 deg, half the smear 0.5 deg, the cruise margin 0.2 deg.
    EXPECT_NEAR(u.sweep.from / kDeg, 10 - 8.2, 1e-9);
    EXPECT_NEAR(u.sweep.to / kDeg, 50 + 8.2, 1e-9);
    EXPECT_NEAR(u.sweep.stand.light / kDeg, -30, 1e-12);
    EXPECT_NEAR(u.sweep.stand.detector, u.sweep.from, 1e-12);
    EXPECT_TRUE(units[1].standing);
    EXPECT_TRUE(units[2].standing);
    EXPECT_EQ(units[1].sweep.members.size() + units[2].sweep.members.size(), 2u);
}

TEST(FlyPlan, SweepEnteredAtItsNearerEndRunsBackwards) {
    const FlyLimits lim = sim4_limits();
    FlySpec spec;
    const std::vector<brdf::RigPosed> poses = {
        pose(20, -40, 0, 0), pose(20, -60, 0, 0), pose(20, -50, 0, 0)};
    const std::vector<FlyUnit> units = plan_fly_units(poses, pose(20, -90, 0, 0), spec, lim);
    ASSERT_EQ(units.size(), 1u);
    EXPECT_EQ(units[0].sweep.members, (std::vector<std::size_t>{1, 2, 0}));
    // From -90 the arm enters below -60 and goes up; from 0 it enters above -40 and goes down.
    EXPECT_LT(units[0].sweep.from, units[0].sweep.to);
    const std::vector<FlyUnit> back = plan_fly_units(poses, pose(20, 0, 0, 0), spec, lim);
    ASSERT_EQ(back.size(), 1u);
    EXPECT_EQ(back[0].sweep.members, (std::vector<std::size_t>{0, 2, 1}));
    EXPECT_GT(back[0].sweep.from, back[0].sweep.to);
    EXPECT_NEAR(back[0].sweep.stand.detector, back[0].sweep.from, 1e-12);
}

TEST(FlyPlan, SweepBeyondTheArmsRangeStands) {
    const FlyLimits lim = sim4_limits();
    FlySpec spec;
    // The lead-out of a sweep ending at 165 deg would pass the 170 deg limit.
    const std::vector<brdf::RigPosed> poses = {pose(0, 150, 0, 0), pose(0, 165, 0, 0)};
    const std::vector<FlyUnit> units = plan_fly_units(poses, pose(0, 0, 0, 0), spec, lim);
    ASSERT_EQ(units.size(), 2u);
    EXPECT_TRUE(units[0].standing);
    EXPECT_TRUE(units[1].standing);
}

TEST(FlyPlan, TiltOrSpinRunsAreNeverSwept) {
    const FlyLimits lim = sim4_limits();
    FlySpec spec;
    // Same arms, tilt varying: the directions would turn along small circles.
    const std::vector<brdf::RigPosed> poses = {
        pose(0, 60, 0, 0), pose(0, 60, 10, 0), pose(0, 60, 20, 0)};
    const std::vector<FlyUnit> units = plan_fly_units(poses, pose(0, 0, 0, 0), spec, lim);
    ASSERT_EQ(units.size(), 3u);
    for (const FlyUnit& u : units) {
        EXPECT_TRUE(u.standing);
    }
}

TEST(FlyPlan, SpecProblemsNameTheField) {
    FlySpec s;
    s.max_smear_deg = 0;
    EXPECT_NE(fly_spec_problem(s).find("fly.max_smear_deg"), std::string::npos);
    s.max_smear_deg = 1;
    s.speed_deg_per_s = -1;
    EXPECT_NE(fly_spec_problem(s).find("fly.speed_deg_per_s"), std::string::npos);
    s.speed_deg_per_s = 0;
    EXPECT_TRUE(fly_spec_problem(s).empty());
}

}  // namespace
}  // namespace gonio::acquisition
