// Kinematics over the reachable domain: forward(inverse(target)) returns the target; limits and the
// blind zone are reported with the rule; move times follow the trapezoid's closed form.

#include <gtest/gtest.h>

#include <random>

#include "common/test_units.h"
#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::RigPosed;
using brdf::Vec3d;
using gonio::test_units::kDeg;

Vec3d random_upper(std::mt19937_64& rng, double max_theta) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double theta = std::acos(1 - u(rng) * (1 - std::cos(max_theta)));
    const double phi = 2 * kPi * u(rng) - kPi;
    return brdf::spherical_to_cartesian(theta, phi);
}

TEST(RigGeometry, RestPoseIsTheDocumentedFrame) {
    // Light along W_x hits the sample at normal incidence; the detector at 90 deg looks along W_y,
    // which is the sample's reference direction x (phi = 0) at the horizon.
    const auto [wi, wo] = brdf::rig_forward(RigPosed{0.0, kPi / 2, 0.0, 0.0});
    EXPECT_NEAR((wi - Vec3d(0, 0, 1)).norm(), 0, 1e-15);
    EXPECT_NEAR((wo - Vec3d(1, 0, 0)).norm(), 0, 1e-15);
    // Tilting by t moves the normal out of the arm plane: cos theta_i = cos t cos a_L.
    const double t = 0.4, a = 0.3;
    const auto [wi2, wo2] = brdf::rig_forward(RigPosed{a, 0.0, t, 0.0});
    EXPECT_NEAR(wi2.z(), std::cos(t) * std::cos(a), 1e-15);
    // The world <-> sample maps are inverse rotations.
    const Vec3d w(0.3, -0.5, 0.81);
    EXPECT_NEAR((brdf::sample_to_world(brdf::world_to_sample(w, 0.7, -1.1), 0.7, -1.1) - w).norm(),
                0,
                1e-15);
    EXPECT_NEAR(
        (brdf::sample_normal_world(0.7) - brdf::sample_to_world(Vec3d(0, 0, 1), 0.7, 2.0)).norm(),
        0,
        1e-15);
}

TEST(RigGeometry, InverseRoundTripOverTheHemisphere) {
    const std::uint64_t seed = 20261122;
    std::mt19937_64 rng(seed);
    for (int k = 0; k < 20000; ++k) {
        const Vec3d wi = random_upper(rng, kPi / 2);
        const Vec3d wo = random_upper(rng, kPi / 2);
        for (const RigPosed& p : brdf::rig_inverse(wi, wo)) {
            const auto [fi, fo] = brdf::rig_forward(p);
            ASSERT_LT((fi - wi).norm(), 1e-12) << "seed " << seed << " k " << k;
            ASSERT_LT((fo - wo).norm(), 1e-12) << "seed " << seed << " k " << k;
            ASSERT_LE(std::abs(p.tilt), kPi / 2 + 1e-12);
            // The arms' separation is the angle between the directions.
            ASSERT_NEAR(
                brdf::arm_separation(p.light, p.detector), brdf::angle_between(wi, wo), 1e-9);
        }
    }
}

TEST(Kinematics, SolveRoundTripsOverTheReachableDomain) {
    RigLimits lim;
    lim.range[2] = {-80 * kDeg, 80 * kDeg};
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const std::uint64_t seed = 5;
    std::mt19937_64 rng(seed);
    int solved = 0, blind = 0;
    for (int k = 0; k < 5000; ++k) {
        const Vec3d wi = random_upper(rng, lim.max_theta);
        const Vec3d wo = random_upper(rng, lim.max_theta);
        for (bool iso : {true, false}) {
            auto s = solve(Target{wi, wo, iso, false}, lim, dyn, RigPosed{0.1, 0.9, 0.0, 0.3});
            if (brdf::angle_between(wi, wo) < lim.blind_angle) {
                ASSERT_FALSE(s);
                EXPECT_NE(s.error().message.find("blind zone"), std::string::npos);
                ++blind;
                continue;
            }
            if (!s) {
                // The only other limit that binds here is the tilt: both planes need more of it.
                ASSERT_NE(s.error().message.find("tilt"), std::string::npos) << s.error().message;
                for (const RigPosed& p : brdf::rig_inverse(wi, wo)) {
                    ASSERT_GT(std::abs(p.tilt), lim.range[2].max) << "seed " << seed << " k " << k;
                }
                continue;
            }
            ++solved;
            if (iso) {
                // Same canonical triple; the spin did not move.
                const auto a = brdf::to_canonical(wi, wo, false);
                const auto b = brdf::to_canonical(s->wi, s->wo, false);
                ASSERT_NEAR(a.theta_i, b.theta_i, 1e-9);
                ASSERT_NEAR(a.theta_r, b.theta_r, 1e-9);
                ASSERT_NEAR(a.delta_phi, b.delta_phi, 1e-9);
                ASSERT_EQ(s->pose.spin, 0.3);
            } else {
                ASSERT_LT((s->wi - wi).norm(), 1e-9);
                ASSERT_LT((s->wo - wo).norm(), 1e-9);
            }
            for (int q = 0; q < kNumAxes; ++q) {
                const double v = q == 0   ? s->pose.light
                                 : q == 1 ? s->pose.detector
                                 : q == 2 ? s->pose.tilt
                                          : s->pose.spin;
                ASSERT_GE(v, lim.range[q].min);
                ASSERT_LE(v, lim.range[q].max);
            }
        }
    }
    EXPECT_GT(solved, 9000);
    EXPECT_GT(blind, 0);
}

TEST(Kinematics, PicksTheCheaperOfTheSolutions) {
    const RigLimits lim;
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const Vec3d wi = brdf::spherical_to_cartesian(0.5, 0.0);
    const Vec3d wo = brdf::spherical_to_cartesian(0.7, kPi);
    const RigPosed from{0, 0, 0, 0};
    auto best = solve(Target{wi, wo, false, true}, lim, dyn, from);
    ASSERT_TRUE(best);
    // No candidate is cheaper: check all four (two planes x swap) by hand.
    for (int swap = 0; swap < 2; ++swap) {
        for (RigPosed p : brdf::rig_inverse(swap ? wo : wi, swap ? wi : wo)) {
            EXPECT_GE(move_time(from, p, dyn) + 1e-12, best->cost_s);
        }
    }
}

TEST(Kinematics, LimitsAndPolarAngleAreExplained) {
    RigLimits lim;
    lim.range[2] = {-10 * kDeg, 10 * kDeg};  // almost no tilt: out-of-plane targets unreachable
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const Vec3d wi = brdf::spherical_to_cartesian(60 * kDeg, 0.0);
    const Vec3d wo = brdf::spherical_to_cartesian(60 * kDeg, 90 * kDeg);
    auto s = solve(Target{wi, wo, true, true}, lim, dyn, RigPosed{});
    ASSERT_FALSE(s);
    EXPECT_NE(s.error().message.find("tilt"), std::string::npos) << s.error().message;
    const Vec3d grazing = brdf::spherical_to_cartesian(88 * kDeg, 0.0);
    auto g = solve(Target{grazing, wo, true, true}, RigLimits{}, dyn, RigPosed{});
    ASSERT_FALSE(g);
    EXPECT_NE(g.error().message.find("largest measured polar angle"), std::string::npos);
}

TEST(Kinematics, TrapezoidClosedForms) {
    // Triangular: d = 1, a = 4 -> t = 2 sqrt(1/4) = 1 (peak speed 2 < v = 10).
    EXPECT_DOUBLE_EQ(trapezoid_time(1.0, 10.0, 4.0), 1.0);
    // Trapezoidal: d = 10, v = 2, a = 1 -> ramps of 2 s each covering 2, cruise 6 at 2 -> 3 s; 7 s.
    EXPECT_DOUBLE_EQ(trapezoid_time(10.0, 2.0, 1.0), 7.0);
    // The two forms meet at d = v^2 / a.
    EXPECT_NEAR(trapezoid_time(4.0, 2.0, 1.0), 2 * std::sqrt(4.0), 1e-12);
    EXPECT_EQ(trapezoid_time(0.0, 2.0, 1.0), 0.0);
    std::array<AxisDynamics, kNumAxes> dyn{};
    for (auto& d : dyn) {
        d = AxisDynamics{2.0, 1.0, 0.25};
    }
    dyn[3].settle_s = 1.0;
    // Parallel axes: the slowest decides; settle of the axes that moved.
    EXPECT_DOUBLE_EQ(move_time(RigPosed{0, 0, 0, 0}, RigPosed{10, 1, 0, 0}, dyn), 7.25);
    EXPECT_DOUBLE_EQ(move_time(RigPosed{0, 0, 0, 0}, RigPosed{0, 0, 0, 1}, dyn), 2.0 + 1.0);
    EXPECT_DOUBLE_EQ(move_time(RigPosed{1, 2, 3, 4}, RigPosed{1, 2, 3, 4}, dyn), 0.0);
}

}  // namespace
}  // namespace gonio::acquisition
