// The 4-D table of anisotropic image mode (image_aniso.h): bins of the full half/difference
// coordinates folded by reciprocity only, per-frame summaries that merge into the table a sample
// fed one by one would give, the representative pixel that stands for a curved bin where its mean
// directions do not, the coverage of the valid bins, and the poses a turned sphere's frames offer.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gonio/acquisition/image/bin_uncertainty.h"
#include "gonio/acquisition/image/image_aniso.h"
#include "gonio/acquisition/point/stated_uncertainty.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::Vec3d;

Vec3d dir(double theta, double phi) {
    return brdf::spherical_to_cartesian(theta, phi);
}

TEST(AnisoTable, ReciprocityFoldsAndATurnAboutTheNormalMovesPhiH) {
    const AnisoLayout layout{12, 24, 8, 12};
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 2000; ++k) {
        const Vec3d wi = dir(1.4 * u(rng), 2 * kPi * u(rng));
        const Vec3d wo = dir(1.4 * u(rng), 2 * kPi * u(rng));
        bool s1 = false;
        bool s2 = false;
        const std::size_t a = aniso_bin(layout, wi, wo, &s1);
        const std::size_t b = aniso_bin(layout, wo, wi, &s2);
        ASSERT_EQ(a, b) << "sample " << k;
        // Exactly one order is the folded one (away from phi_d = 0 and pi, where both agree).
        const double phi_d = brdf::to_half_diff(wi, wo).phi_d;
        if (std::abs(std::sin(phi_d)) > 1e-6) {
            EXPECT_NE(s1, s2) << "sample " << k;
        }
    }
    // Turning both directions about the normal by one phi_h bin keeps the isotropic bin and moves
    // the phi_h bin by one (pairs placed at the middle of their phi_h bin).
    const double step = 2 * kPi / layout.n_phi_h;
    for (int p = 0; p < layout.n_phi_h; ++p) {
        const brdf::HalfDiff<double> hd{0.3, (p + 0.5) * step, 0.4, 1.0};
        const auto [wi, wo] = brdf::from_half_diff(hd);
        const std::size_t a = aniso_bin(layout, wi, wo);
        const std::size_t b = aniso_bin(layout, brdf::rotate_z(wi, step), brdf::rotate_z(wo, step));
        EXPECT_EQ(layout.iso_bin(a), layout.iso_bin(b));
        EXPECT_EQ(static_cast<int>(a % layout.n_phi_h), p);
        EXPECT_EQ(static_cast<int>(b % layout.n_phi_h), (p + 1) % layout.n_phi_h);
    }
}

TEST(AnisoTable, MergedFrameSummariesEqualSamplesMergedOneByOne) {
    const AnisoLayout layout{6, 8, 4, 6};
    AnisoTable merged(layout);
    AnisoTable single(layout);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    for (int frame = 0; frame < 4; ++frame) {
        AnisoFrameBins fb(layout);
        for (int i = 0; i < 3000; ++i) {
            const Vec3d wi = dir(0.2 + 0.4 * u(rng), 0.3 * u(rng));
            const Vec3d wo = dir(0.2 + 0.4 * u(rng), 2.5 + 0.3 * u(rng));
            const brdf::Rgbd v(0.5 + u(rng), 1 + u(rng), 2 * u(rng));
            const brdf::Rgbd var(1e-3, 2e-3, 3e-3);
            fb.add(wi, wo, v, var);
            AnisoFrameBins one(layout);
            one.add(wi, wo, v, var);
            for (const AnisoBinAggregate& a : one.aggregates()) {
                single.merge(a);
            }
        }
        for (const AnisoBinAggregate& a : fb.aggregates()) {
            merged.merge(a);
        }
    }
    EXPECT_EQ(merged.total_samples(), 12000u);
    std::size_t compared = 0;
    for (std::size_t b = 0; b < layout.size(); ++b) {
        ASSERT_EQ(merged.count(b), single.count(b));
        if (merged.count(b) < 2) {
            continue;
        }
        ++compared;
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(merged.mean(b)[c], single.mean(b)[c], 1e-5 * single.mean(b)[c]);
            EXPECT_NEAR(merged.sample_variance(b)[c],
                        single.sample_variance(b)[c],
                        1e-3 * single.sample_variance(b)[c] + 1e-12);
        }
        const auto [mi, mo] = merged.mean_directions(b);
        const auto [si, so] = single.mean_directions(b);
        EXPECT_LT((mi - si).norm(), 1e-5);
        EXPECT_LT((mo - so).norm(), 1e-5);
        // Both representatives are samples of the bin, in the bin.
        const auto [ri, ro] = merged.representative_directions(b);
        EXPECT_EQ(aniso_bin(layout, ri, ro), b);
    }
    EXPECT_GT(compared, 20u);
}

TEST(AnisoTable, RepresentativeStandsForACurvedBinWhereTheMeanDirectionsDoNot) {
    // A peaked BRDF (a GGX-like lobe of width 0.05 around the mirror direction) sampled densely in
    // one wide bin near its peak: the bin's mean value is well below the value at the samples'
    // mean directions, and the representative pixel's directions give the mean back within the
    // dataset sigma.
    const AnisoLayout layout{4, 4, 4, 4};
    const auto f = [](const Vec3d& wi, const Vec3d& wo) {
        const Vec3d h = (wi + wo).normalized();
        const double t2 = (1 - h.z() * h.z()) / (h.z() * h.z());
        const double a2 = 0.0025;
        return 1.0 / ((1 + t2 / a2) * (1 + t2 / a2));
    };
    AnisoFrameBins fb(layout);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> noise(0, 1);
    const double sigma_pixel = 0.002;
    for (int i = 0; i < 4000; ++i) {
        const brdf::HalfDiff<double> hd{0.001 + 0.09 * u(rng), 0.1 + 0.2 * u(rng), 0.3, 1.0};
        const auto [wi, wo] = brdf::from_half_diff(hd);
        const double v = f(wi, wo) + sigma_pixel * noise(rng);
        fb.add(wi, wo, brdf::Rgbd::Constant(v), brdf::Rgbd::Constant(sigma_pixel * sigma_pixel));
    }
    AnisoTable table(layout);
    for (const AnisoBinAggregate& a : fb.aggregates()) {
        table.merge(a);
    }
    ASSERT_EQ(table.filled_bins(), 1u);
    std::size_t b = 0;
    while (table.count(b) == 0) {
        ++b;
    }
    const double mean = table.mean(b)[0];
    const auto [mi, mo] = table.mean_directions(b);
    const auto [ri, ro] = table.representative_directions(b);
    const double sigma = table.dataset_sigma(b)[0];
    SCOPED_TRACE("mean " + std::to_string(mean) + ", representative " +
                 std::to_string(table.representative_value(b)[0]) + ", standard error " +
                 std::to_string(table.standard_error(b)[0]));
    // The mean directions are far off: the curvature bias is many sigmas.
    EXPECT_GT(std::abs(f(mi, mo) - mean), 10 * sigma);
    EXPECT_LT(std::abs(f(ri, ro) - mean), 3 * sigma);
    EXPECT_GE(sigma, sigma_pixel);
    // The dataset row is the representative's.
    const brdf::Dataset d = table.to_dataset("synthetic", 1, false);
    ASSERT_EQ(d.samples.size(), 1u);
    EXPECT_LT((d.samples[0].wi() - ri).norm(), 1e-12);
    EXPECT_LT((d.samples[0].wo() - ro).norm(), 1e-12);
    EXPECT_DOUBLE_EQ(d.samples[0].value[0], mean);
}

TEST(AnisoCoverage, ValidBinsAreTheIsotropicOnesAtEveryPhiH) {
    const AnisoLayout layout{6, 8, 4, 6};
    const AnisoCoverage c(layout);
    const CoverageMap iso(layout.iso());
    EXPECT_EQ(c.valid_bins(), iso.valid_bins() * 8);
    EXPECT_GT(c.valid_bins(), 0u);
    AnisoCoverage d(layout);
    std::size_t first_valid = 0;
    while (!d.valid(first_valid)) {
        ++first_valid;
    }
    d.cover(first_valid);
    d.cover(first_valid);
    EXPECT_EQ(d.covered_bins(), 1u);
    EXPECT_DOUBLE_EQ(d.fraction(), 1.0 / static_cast<double>(c.valid_bins()));
    EXPECT_EQ(d.isotropic().covered_bins(), 1u);
    EXPECT_EQ(d.gain({static_cast<std::uint32_t>(first_valid),
                      static_cast<std::uint32_t>(first_valid + 1)}),
              d.valid(first_valid + 1) ? 1u : 0u);
}

TEST(AnisoPlan, SpinPositionsCountAFullTurnOnce) {
    SpinRange full;
    full.step_rad = kPi / 12;
    const std::vector<double> s = spin_positions(full);
    ASSERT_EQ(s.size(), 24u);
    EXPECT_DOUBLE_EQ(s.front(), -kPi);
    EXPECT_NEAR(s.back(), kPi - kPi / 12, 1e-12);
    SpinRange part{0, kPi / 2, kPi / 8};
    EXPECT_EQ(spin_positions(part).size(), 5u);
}

TEST(AnisoPlan, SpinAddsBinsThatNoLightPositionReaches) {
    // A turned sphere seen by a telecentric camera: one spin reaches a share of the 4-D table, all
    // spins together several times as much; the chosen pose is the nearest of the best ones.
    const CameraModel cam = default_image_camera(48, false, 0.02);
    SphereGeometry g;
    g.radius_m = 0.02;
    const Eigen::Vector2d c = cam.project(g.centre);
    g.silhouette = {c.x(), c.y(), g.radius_m * cam.intrinsics.fx};
    const AnisoLayout layout{8, 12, 6, 8};
    LightRange lights;
    lights.step_rad = 10 * kPi / 180;
    SpinRange one{0, 0, kPi / 12};
    SpinRange all;
    all.step_rad = kPi / 12;
    const ExclusionRules rules;
    const auto reach = [&](const std::vector<PoseCandidate>& cands) {
        AnisoCoverage r(layout);
        for (const PoseCandidate& p : cands) {
            for (std::uint32_t b : p.bins) {
                r.cover(b);
            }
        }
        return r.covered_bins();
    };
    const auto single = pose_candidates(cam, g, rules, layout, 0, lights, one, 10 * kPi / 180, 1);
    const auto turned = pose_candidates(cam, g, rules, layout, 0, lights, all, 10 * kPi / 180, 1);
    ASSERT_FALSE(single.empty());
    EXPECT_GT(reach(turned), 3 * reach(single));
    std::vector<std::size_t> gains(turned.size());
    const AnisoCoverage empty(layout);
    for (std::size_t k = 0; k < turned.size(); ++k) {
        gains[k] = empty.gain(turned[k].bins);
    }
    const int best = next_pose(turned, gains, 0.5, 0.0, 1.0);
    ASSERT_GE(best, 0);
    EXPECT_EQ(gains[static_cast<std::size_t>(best)], *std::max_element(gains.begin(), gains.end()));
    // With a looser share the nearest pose at least half as good wins.
    const int near = next_pose(turned, gains, 0.5, 0.0, 0.5);
    ASSERT_GE(near, 0);
    EXPECT_GE(2 * gains[static_cast<std::size_t>(near)], gains[static_cast<std::size_t>(best)]);
    const auto move = [&](int k) {
        return std::abs(turned[static_cast<std::size_t>(k)].light_arm_rad - 0.5) +
               std::abs(turned[static_cast<std::size_t>(k)].spin_rad);
    };
    EXPECT_LE(move(near), move(best));
}

// The 4-D table's rows state the arms' terms through the slope to the rows of the bins one step
// away along each of its four axes (bin_uncertainty.h): P and its phi_h neighbour Q see each
// other; R, next to P in flat index order (the last phi_h bin of the previous phi_d bin) but a
// diagonal step away in the table, sees neither.
TEST(AnisoBudget, ArmTermsReachARowThroughItsGridNeighboursOnly) {
    const AnisoLayout layout{6, 8, 4, 6};
    constexpr double kD = kPi / 180;
    AnisoTable table(layout);
    std::array<std::size_t, 3> bins{};
    const double phi_h[3] = {10 * kD, 55 * kD, 350 * kD};
    const double phi_d[3] = {45 * kD, 45 * kD, 15 * kD};
    const double value[3] = {1.0, 1.5, 0.2};
    for (int k = 0; k < 3; ++k) {
        brdf::HalfDiff<double> hd;
        hd.theta_h = 30 * kD;
        hd.phi_h = phi_h[k];
        hd.theta_d = 30 * kD;
        hd.phi_d = phi_d[k];
        const auto [wi, wo] = brdf::from_half_diff(hd);
        AnisoFrameBins frame(layout);
        frame.add(wi, wo, brdf::Rgbd::Constant(value[k]), brdf::Rgbd::Constant(1e-4));
        for (const AnisoBinAggregate& a : frame.aggregates()) {
            table.merge(a);
        }
        bins[static_cast<std::size_t>(k)] = aniso_bin(layout, wi, wo);
    }
    ASSERT_EQ(bins[1], bins[0] + 1);  // Q: the next phi_h bin
    ASSERT_EQ(bins[2], bins[0] - 1);  // R: flat neighbour, grid diagonal
    brdf::RigErrorBudget budget = brdf::quiet_error_budget();
    budget.light_arm.repeatability_deg = 2;
    const brdf::Dataset plain = table.to_dataset("t", 1, false);
    const brdf::Dataset stated = stated_dataset(table, "t", 1, false, budget, 0);
    ASSERT_EQ(stated.samples.size(), 3u);  // bin order: R, P, Q
    const brdf::Sample& r = stated.samples[0];
    const brdf::Sample& p = stated.samples[1];
    const brdf::Sample& q = stated.samples[2];
    const double u_dir = 2 * kD;
    const double slope = 0.5 / configuration_distance(p, q, false);
    EXPECT_NEAR(p.sigma[0], std::hypot(plain.samples[1].sigma[0], slope * u_dir), 1e-15);
    EXPECT_NEAR(q.sigma[0], std::hypot(plain.samples[2].sigma[0], slope * u_dir), 1e-15);
    EXPECT_GT(p.sigma[0], 1.2 * plain.samples[1].sigma[0]);
    EXPECT_NEAR(r.sigma[0], plain.samples[0].sigma[0], 1e-18);
}

}  // namespace
}  // namespace gonio::acquisition
