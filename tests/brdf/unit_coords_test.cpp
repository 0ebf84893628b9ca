#include <gtest/gtest.h>

#include <random>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {
namespace {

Vec3d random_upper(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double theta = std::acos(u(rng));
    const double phi = 2 * kPi * u(rng) - kPi;
    return spherical_to_cartesian(theta, phi);
}

TEST(Coords, SphericalRoundTrip) {
    const std::uint64_t seed = 20261122;
    std::mt19937_64 rng(seed);
    for (int k = 0; k < 10000; ++k) {
        const Vec3d v = random_upper(rng);
        const Spherical<double> s = cartesian_to_spherical(v);
        const Vec3d back = spherical_to_cartesian(s.theta, s.phi);
        ASSERT_LT((back - v).norm(), 1e-14) << "seed " << seed << " k " << k;
    }
    const Spherical<double> pole = cartesian_to_spherical(Vec3d(0, 0, 1));
    EXPECT_EQ(pole.theta, 0.0);
    EXPECT_EQ(pole.phi, 0.0);
}

TEST(Coords, HalfDiffRoundTrip) {
    const std::uint64_t seed = 7;
    std::mt19937_64 rng(seed);
    for (int k = 0; k < 10000; ++k) {
        const Vec3d wi = random_upper(rng);
        const Vec3d wo = random_upper(rng);
        const HalfDiff<double> hd = to_half_diff(wi, wo);
        ASSERT_GE(hd.theta_h, 0.0);
        ASSERT_LE(hd.theta_h, kPi / 2);
        ASSERT_LE(hd.theta_d, kPi / 2 + 1e-12);
        const auto [wi2, wo2] = from_half_diff(hd);
        ASSERT_LT((wi2 - wi).norm(), 1e-12) << "seed " << seed << " k " << k;
        ASSERT_LT((wo2 - wo).norm(), 1e-12) << "seed " << seed << " k " << k;
    }
}

TEST(Coords, HalfDiffOfMirrorConfigurationHasNormalHalfVector) {
    const Vec3d wi = spherical_to_cartesian(0.7, 0.3);
    const HalfDiff<double> hd = to_half_diff(wi, reflect_z(wi));
    EXPECT_NEAR(hd.theta_h, 0.0, 1e-15);
    EXPECT_NEAR(hd.theta_d, 0.7, 1e-15);
}

TEST(Coords, HalfDiffDegenerateOppositeDirections) {
    const Vec3d wi = spherical_to_cartesian(0.4, 1.0);
    const HalfDiff<double> hd = to_half_diff(wi, Vec3d(-wi));
    EXPECT_EQ(hd.theta_h, 0.0);
    EXPECT_NEAR(hd.theta_d, 0.4, 1e-15);
}

TEST(Coords, CanonicalFoldsIsotropyAndReciprocity) {
    const Vec3d wi = spherical_to_cartesian(0.9, 2.5);
    const Vec3d wo = spherical_to_cartesian(0.3, -2.9);
    const Canonical<double> c = to_canonical(wi, wo);
    EXPECT_NEAR(c.theta_i, 0.3, 1e-14);
    EXPECT_NEAR(c.theta_r, 0.9, 1e-14);
    // phi_o - phi_i = -5.4 wraps to 2 pi - 5.4.
    EXPECT_NEAR(c.delta_phi, 2 * kPi - 5.4, 1e-14);
    const Canonical<double> swapped = to_canonical(wo, wi);
    EXPECT_NEAR(swapped.delta_phi, c.delta_phi, 1e-14);
    const auto [a, b] = from_canonical(c);
    const Canonical<double> again = to_canonical(a, b);
    EXPECT_NEAR(again.delta_phi, c.delta_phi, 1e-14);
    EXPECT_NEAR(again.theta_i, c.theta_i, 1e-14);
}

}  // namespace
}  // namespace gonio::brdf
