// lobe_shape_packets against the scalar shape: S = D G / (4 cos_i cos_o) and dS/dalpha of one
// isotropic lobe through a one-slot Jet of brdf/'s formulas (microfacet.h), sample by sample, as
// the Jet path of the fitting computes them. Seeded grids of direction pairs with the edges: both
// directions along the normal (theta_h = 0), grazing directions (1e-6 and 1e-9 above the
// horizon), wi = wo, and alpha at the fit's bounds [1e-4, 1.5]; sizes that leave a partial last
// packet. Tolerances: S within a relative kValue = 1e-15 for GGX (the same operations in the same
// order, a few roundings apart at most) and 1e-12 for Beckmann (xsimd's exp and erfc instead of
// the C library's); dS within kDerivative = 1e-11 of the derivative's natural scale |dS| + S /
// alpha (the closed forms and the Jet's chain rule round differently where D' cancels, e.g. at
// Beckmann's e = 1).

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "gonio/brdf/coords.h"
#include "gonio/brdf/microfacet.h"
#include "gonio/fitting/lobe_shape_packets.h"

namespace gonio::fitting {
namespace {

using J = ceres::Jet<double, 1>;

struct Arrays {
    std::vector<double> hxy2, hz2, ti, to, inv;
};

Arrays grid(std::uint32_t seed, int random_pairs) {
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> pairs;
    const double g = brdf::kPi / 2;
    const double thetas[] = {0.0, 1e-8, 0.4, 1.1, g - 1e-6, g - 1e-9};
    for (double ti : thetas) {
        for (double to : thetas) {
            for (double dphi : {0.0, 1.3, brdf::kPi}) {
                pairs.emplace_back(brdf::spherical_to_cartesian(ti, 0.2),
                                   brdf::spherical_to_cartesian(to, 0.2 + dphi));
            }
        }
    }
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < random_pairs; ++k) {
        pairs.emplace_back(brdf::spherical_to_cartesian(std::acos(u(rng)), 2 * brdf::kPi * u(rng)),
                           brdf::spherical_to_cartesian(std::acos(u(rng)), 2 * brdf::kPi * u(rng)));
    }
    Arrays a;
    for (const auto& [wi, wo] : pairs) {
        // The quantities PreparedSamples stores for an isotropic structure.
        const brdf::Vec3d h = (wi + wo).normalized();
        a.hxy2.push_back(h.x() * h.x() + h.y() * h.y());
        a.hz2.push_back(h.z() * h.z());
        a.ti.push_back((wi.x() * wi.x() + wi.y() * wi.y()) / (wi.z() * wi.z()));
        a.to.push_back((wo.x() * wo.x() + wo.y() * wo.y()) / (wo.z() * wo.z()));
        a.inv.push_back(1 / (4 * wi.z() * wo.z()));
    }
    return a;
}

/// The scalar shape of sample k and its derivative by a one-slot Jet.
J scalar_shape(const LobeShapeKind& kind, double alpha, const Arrays& a, std::size_t k) {
    const J al(alpha, 0);
    const J D = kind.beckmann
                    ? brdf::D_beckmann_from_squares(J(a.hxy2[k]), J(0.0), J(a.hz2[k]), al, al)
                    : brdf::D_ggx_from_squares(J(a.hxy2[k]), J(0.0), J(a.hz2[k]), al, al);
    J G(1.0);
    if (kind.smith != 0) {
        const J a2i = al * al * J(a.ti[k]);
        const J a2o = al * al * J(a.to[k]);
        const J li =
            kind.beckmann ? brdf::lambda_beckmann_from_a2(a2i) : brdf::lambda_ggx_from_a2(a2i);
        const J lo =
            kind.beckmann ? brdf::lambda_beckmann_from_a2(a2o) : brdf::lambda_ggx_from_a2(a2o);
        G = kind.smith == 1 ? brdf::G_smith_correlated(li, lo) : brdf::G_smith_separable(li, lo);
    }
    return D * G * J(a.inv[k]);
}

TEST(LobeShapePackets, MatchTheScalarShapeAndItsJetDerivative) {
    const Arrays a = grid(2026, 301);
    const std::size_t n = a.hxy2.size();
    ASSERT_NE(n % 8, 0u);  // a partial last packet at every width
    int checked = 0, nonzero_derivatives = 0;
    for (bool beckmann : {false, true}) {
        for (int smith : {0, 1, 2}) {
            const LobeShapeKind kind{beckmann, smith};
            for (double alpha : {1e-4, 3e-3, 0.08, 0.4, 1.0, 1.5}) {
                LobeShapeInputs in{
                    a.hxy2.data(), a.hz2.data(), a.ti.data(), a.to.data(), a.inv.data()};
                std::vector<double> S(n), dS(n);
                lobe_shape_packets(kind, alpha, in, n, S.data(), dS.data());
                const double value_tol = beckmann ? 1e-12 : 1e-15;
                for (std::size_t k = 0; k < n; ++k) {
                    const J ref = scalar_shape(kind, alpha, a, k);
                    ASSERT_TRUE(std::isfinite(ref.a) && std::isfinite(ref.v[0])) << k;
                    EXPECT_LE(std::abs(S[k] - ref.a), value_tol * std::abs(ref.a) + 1e-300)
                        << "beckmann " << beckmann << " smith " << smith << " alpha " << alpha
                        << " sample " << k << ": " << S[k] << " vs " << ref.a;
                    const double scale = std::abs(ref.v[0]) + std::abs(ref.a) / alpha;
                    EXPECT_LE(std::abs(dS[k] - ref.v[0]), 1e-11 * scale + 1e-300)
                        << "beckmann " << beckmann << " smith " << smith << " alpha " << alpha
                        << " sample " << k << ": " << dS[k] << " vs " << ref.v[0];
                    nonzero_derivatives += ref.v[0] != 0;
                    ++checked;
                }
            }
        }
    }
    EXPECT_EQ(checked, static_cast<int>(36 * n));
    EXPECT_GT(nonzero_derivatives, checked / 2);
}

TEST(LobeShapePackets, AGrazingPairKeepsAFiniteShape) {
    // Both directions 1e-9 above the horizon, opposite in azimuth: h at the normal, tan^2 theta
    // about 1e18 for both, so Lambda is large and G small but positive.
    const double c = std::cos(brdf::kPi / 2 - 1e-9);
    const double s2 = 1 - c * c;
    const double hxy2 = 0, hz2 = 1, t = s2 / (c * c), inv = 1 / (4 * c * c);
    LobeShapeInputs in{&hxy2, &hz2, &t, &t, &inv};
    for (bool beckmann : {false, true}) {
        double S = -1, dS = -1;
        lobe_shape_packets(LobeShapeKind{beckmann, 1}, 0.3, in, 1, &S, &dS);
        const J ref = scalar_shape(
            LobeShapeKind{beckmann, 1}, 0.3, Arrays{{hxy2}, {hz2}, {t}, {t}, {inv}}, 0);
        EXPECT_TRUE(std::isfinite(S) && std::isfinite(dS));
        EXPECT_GT(S, 0);
        EXPECT_NEAR(S, ref.a, 1e-12 * ref.a);
        EXPECT_NEAR(dS, ref.v[0], 1e-11 * (std::abs(ref.v[0]) + ref.a / 0.3));
    }
}

}  // namespace
}  // namespace gonio::fitting
