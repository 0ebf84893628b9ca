// Anisotropic point plans (plan.h, plan_anisotropic): every configuration of the full grid over
// (theta_i, phi_i, theta_o, phi_o) is represented exactly once up to reciprocity and the declared
// symmetry; the counts against Burnside's orbit count; directions kept in the sample's frame.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/shared/kinematics.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::Vec3d;

/// The images of a configuration under the group of reciprocity and the symmetry, by hand.
std::vector<std::pair<Vec3d, Vec3d>> images(const Vec3d& wi, const Vec3d& wo, SampleSymmetry s) {
    auto mirror = [](const Vec3d& w) { return Vec3d(w.x(), -w.y(), w.z()); };
    auto half = [](const Vec3d& w) { return Vec3d(-w.x(), -w.y(), w.z()); };
    std::vector<std::pair<Vec3d, Vec3d>> out = {{wi, wo}, {wo, wi}};
    if (s == SampleSymmetry::kMirror) {
        out.push_back({mirror(wi), mirror(wo)});
        out.push_back({mirror(wo), mirror(wi)});
    } else if (s == SampleSymmetry::kTwoFold) {
        out.push_back({half(wi), half(wo)});
        out.push_back({half(wo), half(wi)});
    }
    return out;
}

bool same(const std::pair<Vec3d, Vec3d>& a, const std::pair<Vec3d, Vec3d>& b) {
    return (a.first - b.first).norm() < 1e-9 && (a.second - b.second).norm() < 1e-9;
}

/// Every direction of the grid: the normal and rings at theta_max a / (n_theta - 1).
std::vector<Vec3d> grid_dirs(const AnisotropicGridSpec& s) {
    std::vector<Vec3d> d = {Vec3d(0, 0, 1)};
    const int n_phi = 2 * (s.n_dphi - 1);
    for (int a = 1; a < s.n_theta; ++a) {
        for (int k = 0; k < n_phi; ++k) {
            d.push_back(brdf::spherical_to_cartesian(s.theta_max * a / (s.n_theta - 1),
                                                     2 * kPi * k / n_phi));
        }
    }
    return d;
}

TEST(AnisotropicPlan, EveryConfigurationRepresentedExactlyOnceUpToTheGroup) {
    for (SampleSymmetry sym :
         {SampleSymmetry::kNone, SampleSymmetry::kMirror, SampleSymmetry::kTwoFold}) {
        SCOPED_TRACE(to_string(sym));
        AnisotropicGridSpec s;
        s.n_theta = 4;
        s.n_dphi = 4;  // azimuth step 60 degrees: 6 per ring
        s.theta_max = 60 * kPi / 180;
        s.symmetry = sym;
        const Expected<Plan> p = plan_anisotropic(s);
        ASSERT_TRUE(p) << p.error().message;
        EXPECT_EQ(p->kind, "anisotropic");
        const std::vector<Vec3d> dirs = grid_dirs(s);
        // Burnside: orbits = (1 / |G|) sum over g of the pairs g fixes. Pairs: N^2 with N = 19
        // directions. Reciprocity fixes the N pairs wi = wo. The mirror across x fixes the
        // directions with phi = 0 or 180 (the normal and 2 per ring): M = 1 + 2 * 3 = 7, so it
        // fixes M^2 pairs, and mirror with exchange fixes the N pairs wo = mirror(wi). The half
        // turn fixes only the normal (1 pair), and half turn with exchange fixes the N pairs wo =
        // half(wi).
        const int n = static_cast<int>(dirs.size());
        ASSERT_EQ(n, 19);
        int expected = 0;
        switch (sym) {
            case SampleSymmetry::kNone:
                expected = (n * n + n) / 2;
                break;
            case SampleSymmetry::kMirror:
                expected = (n * n + n + 7 * 7 + n) / 4;
                break;
            case SampleSymmetry::kTwoFold:
                expected = (n * n + n + 1 + n) / 4;
                break;
        }
        EXPECT_EQ(static_cast<int>(p->configs.size()), expected);
        // No two planned configurations are images of each other.
        for (std::size_t a = 0; a < p->configs.size(); ++a) {
            EXPECT_FALSE(p->configs[a].isotropic);
            EXPECT_EQ(p->configs[a].index, a);
            const auto imgs = images(p->configs[a].wi, p->configs[a].wo, sym);
            for (std::size_t b = a + 1; b < p->configs.size(); ++b) {
                for (const auto& im : imgs) {
                    ASSERT_FALSE(same(im, {p->configs[b].wi, p->configs[b].wo}))
                        << "configurations " << a << " and " << b;
                }
            }
        }
        // Every pair of the grid has an image in the plan.
        for (const Vec3d& wi : dirs) {
            for (const Vec3d& wo : dirs) {
                bool found = false;
                for (const auto& im : images(wi, wo, sym)) {
                    for (const PlannedConfig& c : p->configs) {
                        found = found || same(im, {c.wi, c.wo});
                    }
                }
                ASSERT_TRUE(found);
            }
        }
    }
}

TEST(AnisotropicPlan, RefusesDegenerateAndOversizedGrids) {
    AnisotropicGridSpec s;
    s.n_theta = 1;
    const Expected<Plan> a = plan_anisotropic(s);
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("n_theta = 1"), std::string::npos) << a.error().message;
    s.n_theta = 200;
    s.n_dphi = 100;
    const Expected<Plan> b = plan_anisotropic(s);
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("at most"), std::string::npos) << b.error().message;
}

TEST(AnisotropicPlan, SymmetryNamesRoundTrip) {
    for (SampleSymmetry s :
         {SampleSymmetry::kNone, SampleSymmetry::kMirror, SampleSymmetry::kTwoFold}) {
        const Expected<SampleSymmetry> back = parse_symmetry(to_string(s));
        ASSERT_TRUE(back);
        EXPECT_EQ(*back, s);
    }
    const Expected<SampleSymmetry> bad = parse_symmetry("4-fold");
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().message, "symmetry \"4-fold\": expected none, mirror or 2-fold");
}

// The kinematics reach an anisotropic target with the spin axis: the pose measures the asked
// directions in the sample's frame, not a rotated copy.
TEST(AnisotropicPlan, KinematicsMeetTheTargetInTheSampleFrame) {
    RigLimits lim;
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const Vec3d wi = brdf::spherical_to_cartesian(40 * kPi / 180, 70 * kPi / 180);
    const Vec3d wo = brdf::spherical_to_cartesian(25 * kPi / 180, 200 * kPi / 180);
    const Expected<Solution> sol = solve(Target{wi, wo, false, false}, lim, dyn, brdf::RigPosed{});
    ASSERT_TRUE(sol) << sol.error().message;
    EXPECT_LT((sol->wi - wi).norm(), 1e-9);
    EXPECT_LT((sol->wo - wo).norm(), 1e-9);
}

}  // namespace
}  // namespace gonio::acquisition
