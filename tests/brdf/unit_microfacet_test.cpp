// Microfacet distributions and masking against their defining integrals:
// - D is normalised over projected area: integral of D(h) cos(theta_h) dh = 1;
// - Smith G1 satisfies the visible-normal normalisation: integral of G1(wo, h) max(0, wo . h) D(h)
//   dh = cos(theta_o) (Heitz 2014, eq. 2 with the Smith G1), which holds only with the exact
//   Lambda;
// - Lambert's directional albedo equals rho.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gonio/brdf/blinn_phong.h"
#include "gonio/brdf/lambert.h"
#include "gonio/brdf/microfacet.h"
#include "test_quadrature.h"

namespace gonio::brdf {
namespace {

using testing::integrate_hemisphere;

struct Alphas {
    double x;
    double y;
};

const Alphas kAlphas[] = {{0.02, 0.02},
                          {0.1, 0.1},
                          {0.3, 0.3},
                          {0.6, 0.6},
                          {1.0, 1.0},
                          {0.05, 0.4},
                          {0.5, 0.1},
                          {1.0, 0.3}};

TEST(Ggx, NormalisedOverProjectedArea) {
    for (const Alphas& a : kAlphas) {
        const double integral =
            integrate_hemisphere([&](const Vec3d& h) { return D_ggx(h, a.x, a.y) * h.z(); });
        EXPECT_NEAR(integral, 1.0, 2e-4) << "alpha " << a.x << " " << a.y;
    }
}

TEST(Beckmann, NormalisedOverProjectedArea) {
    for (const Alphas& a : kAlphas) {
        const double integral =
            integrate_hemisphere([&](const Vec3d& h) { return D_beckmann(h, a.x, a.y) * h.z(); });
        EXPECT_NEAR(integral, 1.0, 2e-4) << "alpha " << a.x << " " << a.y;
    }
}

TEST(BlinnPhong, NormalisedOverProjectedArea) {
    for (double e : {1.0, 10.0, 100.0, 1000.0}) {
        const double integral =
            integrate_hemisphere([&](const Vec3d& h) { return D_blinn_phong(h, e) * h.z(); });
        EXPECT_NEAR(integral, 1.0, 2e-4) << "exponent " << e;
    }
}

TEST(Ggx, ClosedFormsAtTheNormalAndIsotropicAngle) {
    const double alpha = 0.3;
    EXPECT_NEAR(D_ggx(Vec3d(0, 0, 1), alpha, alpha), 1.0 / (kPi * alpha * alpha), 1e-12);
    // Isotropic form: D = alpha^2 / (pi ((alpha^2 - 1) cos^2 + 1)^2) (Walter et al. 2007, eq. 33).
    const double t = 0.7;
    const double c = std::cos(t);
    const double expected = alpha * alpha / (kPi * std::pow((alpha * alpha - 1) * c * c + 1, 2));
    EXPECT_NEAR(D_ggx(spherical_to_cartesian(t, 1.1), alpha, alpha), expected, 1e-12);
    // Lambda: (-1 + sqrt(1 + alpha^2 tan^2))/2.
    const double tan2 = std::pow(std::tan(t), 2);
    EXPECT_NEAR(lambda_ggx(spherical_to_cartesian(t, 2.0), alpha, alpha),
                (-1 + std::sqrt(1 + alpha * alpha * tan2)) / 2,
                1e-14);
    EXPECT_EQ(lambda_ggx(Vec3d(0, 0, 1), alpha, alpha), 0.0);
    EXPECT_EQ(D_ggx(Vec3d(1, 0, 0), alpha, alpha), 0.0);
}

TEST(Beckmann, LambdaMatchesTheErfForm) {
    const double alpha = 0.4;
    for (double t : {0.1, 0.5, 1.0, 1.4, 1.55}) {
        const double a = 1.0 / (alpha * std::tan(t));
        const double expected = (std::erf(a) - 1) / 2 + std::exp(-a * a) / (2 * a * std::sqrt(kPi));
        EXPECT_NEAR(lambda_beckmann(spherical_to_cartesian(t, 0.3), alpha, alpha), expected, 1e-13)
            << "theta " << t;
    }
    EXPECT_EQ(lambda_beckmann(Vec3d(0, 0, 1), alpha, alpha), 0.0);
}

template <class Lambda, class Dist>
void expect_visible_normalisation(Lambda lambda, Dist D, const char* name) {
    for (const Alphas& a : kAlphas) {
        if (a.x < 0.05) {
            continue;  // the quadrature of the sharpest lobe is covered by the D test
        }
        for (double theta_o : {0.0, 0.4, 0.9, 1.3, 1.5}) {
            for (double phi_o : {0.0, 0.8}) {
                const Vec3d wo = spherical_to_cartesian(theta_o, phi_o);
                const double lam = lambda(wo, a.x, a.y);
                const double integral = integrate_hemisphere(
                    [&](const Vec3d& h) {
                        return G1(wo, h, lam) * std::max(0.0, wo.dot(h)) * D(h, a.x, a.y);
                    },
                    400,
                    180);
                EXPECT_NEAR(integral, wo.z(), 5e-4 * (1 + 1 / std::max(wo.z(), 0.1)))
                    << name << " alpha " << a.x << " " << a.y << " theta_o " << theta_o << " phi_o "
                    << phi_o;
            }
        }
    }
}

TEST(Ggx, SmithG1SatisfiesVisibleNormalNormalisation) {
    expect_visible_normalisation(
        [](const Vec3d& w, double ax, double ay) { return lambda_ggx(w, ax, ay); },
        [](const Vec3d& h, double ax, double ay) { return D_ggx(h, ax, ay); },
        "ggx");
}

TEST(Beckmann, SmithG1SatisfiesVisibleNormalNormalisation) {
    expect_visible_normalisation(
        [](const Vec3d& w, double ax, double ay) { return lambda_beckmann(w, ax, ay); },
        [](const Vec3d& h, double ax, double ay) { return D_beckmann(h, ax, ay); },
        "beckmann");
}

TEST(Smith, CorrelatedIsAtLeastSeparableAndBothInUnitInterval) {
    for (double li : {0.0, 0.01, 0.5, 3.0}) {
        for (double lo : {0.0, 0.2, 10.0}) {
            const double gc = G_smith_correlated(li, lo);
            const double gs = G_smith_separable(li, lo);
            EXPECT_GE(gc, gs);
            EXPECT_LE(gc, 1.0);
            EXPECT_GE(gs, 0.0);
            EXPECT_DOUBLE_EQ(gs, 1.0 / (1 + li) / (1 + lo));
        }
    }
}

TEST(Ggx, OneDivisionFormsEqualTheTextbookForms) {
    // D with one division, the Lambda fraction and G of two fractions against the textbook forms
    // written out here in long double (the bracket of D, a2 / z^2, 1 / (1 + Lambda_i + Lambda_o)),
    // on a grid that includes the normal, grazing directions (z down to 1e-6) and alpha at the
    // bounds in use (1e-4 .. 4): agreement to within 9 units in the last place of a double.
    const double alphas[] = {1e-4, 0.01, 0.2, 1.0, 4.0};
    const double zs[] = {1.0, 0.9, 0.5, 0.1, 1e-3, 1e-6};
    double worst_d = 0, worst_l = 0, worst_g = 0, worst_s = 0;
    for (double ax : alphas) {
        for (double ay : alphas) {
            for (double z : zs) {
                for (double phi : {0.0, 0.4, 1.3}) {
                    const long double sz = std::sqrt(1.0L - static_cast<long double>(z) * z);
                    const long double x = sz * std::cos(static_cast<long double>(phi));
                    const long double y = sz * std::sin(static_cast<long double>(phi));
                    const long double lax = ax, lay = ay, lz = z;
                    const long double bracket = x * x / (lax * lax) + y * y / (lay * lay) + lz * lz;
                    const long double d_ref = 1.0L / (3.14159265358979323846264338327950288L * lax *
                                                      lay * bracket * bracket);
                    const double d = D_ggx_from_squares(
                        static_cast<double>(x * x), static_cast<double>(y * y), z * z, ax, ay);
                    worst_d = std::max(worst_d, static_cast<double>(std::fabs(d - d_ref) / d_ref));
                    const long double a2 = (lax * lax * x * x + lay * lay * y * y) / (lz * lz);
                    // (sqrt(1 + a2) - 1) / 2 without its cancellation at small a2.
                    const long double l_ref = a2 / (2.0L * (1.0L + std::sqrt(1.0L + a2)));
                    const double t = static_cast<double>(lax * lax * x * x + lay * lay * y * y);
                    const Fraction<double> l = lambda_ggx_fraction(t, z);
                    if (l_ref > 0) {
                        worst_l = std::max(
                            worst_l, static_cast<double>(std::fabs(l.num / l.den - l_ref) / l_ref));
                    }
                    // The other direction at a fixed elevation: G of the pair.
                    const Fraction<double> lo =
                        lambda_ggx_fraction(0.25 * ax * ax, std::sqrt(0.75));
                    const long double lo_a2 = 0.25L * lax * lax / 0.75L;
                    const long double lo_ref = lo_a2 / (2.0L * (1.0L + std::sqrt(1.0L + lo_a2)));
                    const long double g_ref = 1.0L / (1.0L + l_ref + lo_ref);
                    worst_g = std::max(
                        worst_g,
                        static_cast<double>(std::fabs(G_smith_correlated(l, lo) - g_ref) / g_ref));
                    const long double s_ref = 1.0L / ((1.0L + l_ref) * (1.0L + lo_ref));
                    worst_s = std::max(
                        worst_s,
                        static_cast<double>(std::fabs(G_smith_separable(l, lo) - s_ref) / s_ref));
                }
            }
        }
    }
    std::printf(
        "GGX one-division forms, worst relative error: D %.2e, Lambda %.2e, G correlated "
        "%.2e, G separable %.2e\n",
        worst_d,
        worst_l,
        worst_g,
        worst_s);
    EXPECT_LT(worst_d, 2e-15);
    EXPECT_LT(worst_l, 2e-15);
    EXPECT_LT(worst_g, 2e-15);
    EXPECT_LT(worst_s, 2e-15);
    // The value forms are the fraction forms over 1, bit for bit.
    EXPECT_EQ(lambda_ggx_from_a2(0.37),
              lambda_ggx_fraction(0.37, 1.0).num / lambda_ggx_fraction(0.37, 1.0).den);
    EXPECT_EQ(G_smith_correlated(0.2, 0.7), 1.0 / (1.0 + 0.2 + 0.7));
    EXPECT_EQ(G_smith_separable(0.2, 0.7), 1.0 / ((1.0 + 0.2) * (1.0 + 0.7)));
}

TEST(VGroove, ClosedFormValues) {
    // Both at normal incidence: h = n, G = min(1, 2, 2) = 1.
    const Vec3d n(0, 0, 1);
    EXPECT_DOUBLE_EQ(G_vgroove(n, n, n), 1.0);
    // Grazing wi: G -> 2 (n.h)(n.wi)/(wo.h) small.
    const Vec3d wi = spherical_to_cartesian(1.5, 0.0);
    const Vec3d wo = spherical_to_cartesian(0.2, kPi);
    const Vec3d h = (wi + wo).normalized();
    const double expected =
        std::min({1.0, 2 * h.z() * wo.z() / wo.dot(h), 2 * h.z() * wi.z() / wo.dot(h)});
    EXPECT_DOUBLE_EQ(G_vgroove(wi, wo, h), expected);
    EXPECT_LT(expected, 1.0);
}

TEST(Lambert, AlbedoEqualsRho) {
    const Rgbd rho(0.2, 0.5, 0.9);
    for (double theta_i : {0.0, 0.7, 1.4}) {
        const Vec3d wi = spherical_to_cartesian(theta_i, 0.3);
        for (int c = 0; c < 3; ++c) {
            const double albedo = integrate_hemisphere(
                [&](const Vec3d& wo) { return lambert(rho, wi, wo)[c] * wo.z(); }, 400, 64);
            EXPECT_NEAR(albedo, rho[c], 3e-5 * rho[c]);
        }
    }
    EXPECT_TRUE((lambert(rho, Vec3d(0, 0, 1), Vec3d(1, 0, 0)) == 0).all());
}

}  // namespace
}  // namespace gonio::brdf
