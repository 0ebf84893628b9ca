// Sampling plans and scheduling: counts from the grid's closed form, no redundant configuration,
// ROI selection, refinement placed where the values change, schedules that are permutations and
// never worse than raster on a structured plan, lower bounds that bound.

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "common/test_units.h"
#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/plans/schedule.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::RigPosed;
using brdf::Vec3d;
using gonio::test_units::kDeg;

std::set<std::tuple<long, long, long>> keys(const Plan& p) {
    std::set<std::tuple<long, long, long>> s;
    for (const PlannedConfig& c : p.configs) {
        auto k = canonical_of(c);
        const double dphi = k.theta_i < 1e-9 ? 0 : k.delta_phi;
        s.insert(
            {std::lround(k.theta_i * 1e6), std::lround(k.theta_r * 1e6), std::lround(dphi * 1e6)});
    }
    return s;
}

TEST(Plan, UniformCountsAndReduction) {
    UniformGridSpec s;
    s.n_theta = 7;
    s.n_dphi = 5;
    s.theta_max = 75 * kDeg;
    auto p = plan_uniform(s);
    ASSERT_TRUE(p);
    // theta_i = 0: 7 values of theta_r, one azimuth; theta_i > 0: (7 - a) values of theta_r >= it,
    // times 5 azimuths: 5 * (6 + 5 + 4 + 3 + 2 + 1) = 105.
    EXPECT_EQ(p->configs.size(), 7u + 105u);
    EXPECT_EQ(p->naive_count, 7u * 7u * 8u * 8u);
    // No two configurations are the same under isotropy and reciprocity.
    EXPECT_EQ(keys(*p).size(), p->configs.size());
    for (const PlannedConfig& c : p->configs) {
        const auto k = canonical_of(c);
        EXPECT_LE(k.theta_i, k.theta_r + 1e-12);
        EXPECT_GE(k.delta_phi, 0);
        EXPECT_LE(k.delta_phi, kPi + 1e-12);
    }
    EXPECT_FALSE(plan_uniform(UniformGridSpec{1, 1.0, 5}));
}

TEST(Plan, HalfDiffIsDenseNearTheSpecularPeakAndNotRedundant) {
    HalfDiffSpec s;
    auto p = plan_half_diff(s);
    ASSERT_TRUE(p);
    EXPECT_EQ(keys(*p).size(), p->configs.size());
    int near = 0, far = 0;
    for (const PlannedConfig& c : p->configs) {
        const auto hd = brdf::to_half_diff(c.wi, c.wo);
        (hd.theta_h < 20 * kDeg ? near : far)++;
        EXPECT_LE(std::acos(c.wi.z()), s.theta_max + 1e-9);
        EXPECT_LE(std::acos(c.wo.z()), s.theta_max + 1e-9);
    }
    // theta_h = (i/8)^2 90 deg: i = 0..3 lie below 20 deg (0, 1.4, 5.6, 12.7), 4 of 8 rows.
    EXPECT_GT(near, 0);
    EXPECT_GT(far, 0);
}

TEST(Plan, SceneRoiKeepsOnlyWhatTheSceneNeeds) {
    const std::string path = std::string(GONIO_BINARY_DIR) + "/test_scene_roi.json";
    {
        std::ofstream f(path);
        f << R"({"name": "t", "margin_deg": 6,
                 "pairs": [{"light": {"theta_deg": 30, "phi_deg": 10},
                            "view": {"theta_deg": 45, "phi_deg": 190}}]})";
    }
    auto scene = read_scene(path);
    ASSERT_TRUE(scene) << scene.error().message;
    const UniformGridSpec s{18, 85 * kDeg, 13};  // 5 deg polar, 15 deg azimuth steps
    auto p = plan_uniform(s);
    ASSERT_TRUE(p);
    const std::size_t all = p->configs.size();
    apply_roi(*scene, &*p);
    EXPECT_GT(p->configs.size(), 0u);
    EXPECT_LT(p->configs.size(), all / 20);
    EXPECT_EQ(p->configs.size() + p->outside_roi, all);
    const auto target = brdf::to_canonical(brdf::spherical_to_cartesian(30 * kDeg, 10 * kDeg),
                                           brdf::spherical_to_cartesian(45 * kDeg, 190 * kDeg));
    for (const PlannedConfig& c : p->configs) {
        EXPECT_TRUE(c.flags & brdf::kFlagRoi);
        const auto k = canonical_of(c);
        // Within the margin in both polar angles (a necessary condition of the direction test).
        EXPECT_LE(std::abs(k.theta_i - target.theta_i), 6 * kDeg + 1e-9);
        EXPECT_LE(std::abs(k.theta_r - target.theta_r), 6 * kDeg + 1e-9);
    }
    // The exact scene configuration (30, 45, 180) lies on the grid and is kept.
    bool found = false;
    for (const PlannedConfig& c : p->configs) {
        const auto k = canonical_of(c);
        found |= std::abs(k.theta_i - 30 * kDeg) < 1e-9 && std::abs(k.theta_r - 45 * kDeg) < 1e-9 &&
                 std::abs(k.delta_phi - kPi) < 1e-9;
    }
    EXPECT_TRUE(found);
    std::remove(path.c_str());
    EXPECT_FALSE(read_scene(path));
}

TEST(Plan, UnreachableAreListedWithTheirReason) {
    auto p = plan_uniform(UniformGridSpec{7, 75 * kDeg, 5});
    ASSERT_TRUE(p);
    const std::size_t all = p->configs.size();
    remove_unreachable(RigLimits{}, &*p);
    // theta_i = theta_r with delta_phi = 0 is retro-reflection: 6 such (theta_i > 0) plus (0, 0).
    EXPECT_EQ(p->unreachable.size(), 7u);
    EXPECT_EQ(p->configs.size() + p->unreachable.size(), all);
    for (const auto& u : p->unreachable) {
        EXPECT_NE(u.reason.find("blind zone"), std::string::npos);
    }
}

TEST(Plan, RefinementGoesWhereTheValuesChange) {
    // A sharp peak around theta_i = theta_r, delta_phi = pi (a specular lobe), flat elsewhere.
    auto p = plan_uniform(UniformGridSpec{7, 75 * kDeg, 5});
    ASSERT_TRUE(p);
    std::vector<MeasuredPoint> pts;
    for (const PlannedConfig& c : p->configs) {
        const auto k = canonical_of(c);
        const auto hd = brdf::to_half_diff(c.wi, c.wo);
        pts.push_back({k, 0.1 + 50 * std::exp(-hd.theta_h * hd.theta_h / (2 * 0.05 * 0.05))});
    }
    RefineSpec rs;
    rs.budget = 20;
    Plan r = plan_refine(pts, rs);
    ASSERT_EQ(r.configs.size(), 20u);
    for (const PlannedConfig& c : r.configs) {
        // Every refinement lies between the peak and its neighbours: theta_h below ~ one grid step.
        EXPECT_LT(brdf::to_half_diff(c.wi, c.wo).theta_h, 20 * kDeg);
    }
    // Flat values: nothing to refine (the error estimate is met).
    for (auto& m : pts) {
        m.value = 0.3;
    }
    EXPECT_TRUE(plan_refine(pts, rs).configs.empty());
}

std::vector<RigPosed> grid_poses(int n_light, int n_det, int n_tilt) {
    std::vector<RigPosed> poses;
    for (int a = 0; a < n_light; ++a) {
        for (int b = 0; b < n_det; ++b) {
            for (int t = 0; t < n_tilt; ++t) {
                poses.push_back(RigPosed{a * 10 * kDeg, (b * 10 + 15) * kDeg, t * 10 * kDeg, 0});
            }
        }
    }
    return poses;
}

TEST(Schedule, IsAPermutationAndBeatsRasterOnAGrid) {
    // Raster with the slow tilt axis innermost is the worst natural order.
    std::vector<RigPosed> poses = grid_poses(6, 6, 5);
    std::array<AxisDynamics, kNumAxes> dyn{};
    dyn[2].speed = 0.1;
    const Schedule s = schedule(poses, RigPosed{}, dyn);
    std::vector<std::size_t> sorted = s.order;
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::size_t> id(poses.size());
    std::iota(id.begin(), id.end(), 0);
    EXPECT_EQ(sorted, id);
    EXPECT_NEAR(s.planned_s, path_time(poses, s.order, RigPosed{}, dyn), 1e-9);
    EXPECT_LE(s.planned_s, 0.6 * s.raster_s);
    EXPECT_LE(s.lower_bound_s, s.planned_s + 1e-9);
    EXPECT_GT(s.lower_bound_s, 0);
}

TEST(Schedule, LowerBoundNeverExceedsAnyOrder) {
    const std::uint64_t seed = 99;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<RigPosed> poses;
    for (int k = 0; k < 300; ++k) {
        poses.push_back(RigPosed{u(rng), u(rng), 0.5 * u(rng), u(rng)});
    }
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const Schedule s = schedule(poses, RigPosed{}, dyn);
    std::vector<std::size_t> order(poses.size());
    std::iota(order.begin(), order.end(), 0);
    for (int trial = 0; trial < 20; ++trial) {
        std::shuffle(order.begin(), order.end(), rng);
        ASSERT_LE(s.lower_bound_s, path_time(poses, order, RigPosed{}, dyn) + 1e-9)
            << "seed " << seed;
    }
    EXPECT_LE(s.lower_bound_s, s.planned_s + 1e-9);
    EXPECT_LT(s.planned_s, s.raster_s);
}

}  // namespace
}  // namespace gonio::acquisition
