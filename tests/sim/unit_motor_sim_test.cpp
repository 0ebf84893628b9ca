// Kinematics of the simulated stage against closed forms of constant-acceleration motion.

#include <gtest/gtest.h>

#include <cmath>

#include "gonio/sim/motor_sim.h"

namespace {

using gonio::sim::MotorSim;
using gonio::sim::MotorSimConfig;
using gonio::sim::plan_trapezoid;

double total_time(const std::vector<gonio::sim::MotionPhase>& ph) {
    return ph.back().t0 + ph.back().duration - ph.front().t0;
}

TEST(MotorSimTrapezoid, DurationMatchesClosedForm) {
    // Symmetric trapezoid: T = D/v + v/a. D = 1000, v = 100, a = 50: T = 10 + 2 = 12.
    auto ph = plan_trapezoid(0, 0, 1000, 100, 50, 50);
    ASSERT_EQ(ph.size(), 3u);
    EXPECT_NEAR(total_time(ph), 12.0, 1e-12);
    // Triangular when v_max is never reached: T = 2 sqrt(D/a). D = 100, a = 25: T = 4.
    auto tri = plan_trapezoid(0, 0, -100, 1e6, 25, 25);
    ASSERT_EQ(tri.size(), 2u);
    EXPECT_NEAR(total_time(tri), 4.0, 1e-12);
    // Asymmetric ramps: T = D/v + v/(2a) + v/(2d). D = 1000, v = 100, a = 50, d = 100: 10 + 1 + 0.5.
    auto asym = plan_trapezoid(0, 0, 1000, 100, 50, 100);
    EXPECT_NEAR(total_time(asym), 11.5, 1e-12);
    EXPECT_TRUE(plan_trapezoid(0, 5, 5, 100, 50, 50).empty());
}

TEST(MotorSimTrapezoid, PositionIsContinuousAndEndsOnTarget) {
    MotorSimConfig cfg;
    cfg.start_homed = true;
    MotorSim m(cfg, 100);
    ASSERT_TRUE(m.start_move(0, 12345, 2000, 4000, 4000));
    double last = 0;
    for (double t = 0; t <= 10; t += 0.01) {
        m.update(t);
        const double p = m.motor_steps();
        ASSERT_GE(p, last - 1e-9) << "t " << t;
        // Speed never exceeds v_max: per 10 ms at most 20 steps.
        ASSERT_LE(p - last, 20 + 1e-9) << "t " << t;
        last = p;
    }
    EXPECT_FALSE(m.moving());
    EXPECT_EQ(m.counter_steps(), 12345);
    // At the middle of the acceleration ramp, x = a t^2 / 2: t = 0.25 s gives 125 steps.
    MotorSim m2(cfg, 100);
    m2.start_move(0, 12345, 2000, 4000, 4000);
    m2.update(0.25);
    EXPECT_NEAR(m2.motor_steps(), 125, 1e-9);
}

TEST(MotorSimBacklash, LoadTrailsByThePlayWhenPushedUp) {
    MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.backlash_deg = 0.5;
    MotorSim m(cfg, 100);  // play = 50 steps
    m.start_move(0, 1000, 1e4, 1e5, 1e5);
    m.update(100);
    EXPECT_NEAR(m.load_steps(), 950, 1e-9);
    m.start_move(100, 990, 1e4, 1e5, 1e5);  // within the play: the load stays
    m.update(200);
    EXPECT_NEAR(m.load_steps(), 950, 1e-9);
    m.start_move(200, 900, 1e4, 1e5, 1e5);  // pushes it down
    m.update(300);
    EXPECT_NEAR(m.load_steps(), 900, 1e-9);
}

TEST(MotorSimHoming, ReferencesTheCounterOnTheSwitch) {
    MotorSimConfig cfg;
    cfg.initial_deg = 12;
    MotorSim m(cfg, 100);
    EXPECT_FALSE(m.homed());
    EXPECT_EQ(m.counter_steps(), 0);  // counter starts at 0 wherever the stage is
    ASSERT_TRUE(m.start_home(0, 1000, 4000));
    m.update(0.01);
    EXPECT_TRUE(m.homing());
    m.update(100);
    EXPECT_TRUE(m.homed());
    EXPECT_NEAR(m.motor_steps(), 0, 1e-9);
    EXPECT_EQ(m.counter_steps(), 0);
    m.start_move(100, 500, 1000, 4000, 4000);
    m.update(200);
    EXPECT_NEAR(m.motor_steps(), 500, 1e-9);
}

TEST(MotorSimLimits, SwitchStopsTheStageWithAnAlarm) {
    MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.limit_max_deg = 10;
    MotorSim m(cfg, 100);
    m.set_overtravel_code(0x66);
    m.start_move(0, 5000, 1000, 4000, 4000);
    m.update(100);
    EXPECT_EQ(m.alarm_code(), 0x66);
    EXPECT_FALSE(m.moving());
    EXPECT_NEAR(m.motor_steps(), 1000, 1e-9);
    EXPECT_FALSE(m.start_move(100, 0, 1000, 4000, 4000));  // refused in alarm
    m.reset_alarm();
    EXPECT_TRUE(m.start_move(100, 0, 1000, 4000, 4000));
}

TEST(MotorSimNoise, EncoderNoiseHasTheConfiguredSpread) {
    MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.encoder_noise_steps = 2.0;
    cfg.seed = 7;
    MotorSim m(cfg, 100);
    double sum = 0;
    double sum2 = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        const double v = static_cast<double>(m.read_counter_steps());
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n;
    const double var = sum2 / n - mean * mean;
    // Rounding a N(0, 2^2) value adds about 1/12 to the variance.
    EXPECT_NEAR(mean, 0, 0.1) << "seed 7";
    EXPECT_NEAR(var, 4 + 1.0 / 12, 0.25) << "seed 7";
    EXPECT_EQ(m.counter_steps(), 0);
}

}  // namespace
