// The Student-t distribution of slopes (brdf/student_t.h) against independent references:
// - D is normalised over projected area for every tail parameter;
// - its Smith Lambda satisfies the visible-normal normalisation (Heitz 2014, eq. 2 with the Smith
//   G1), which holds only with the exact Lambda, including heavy tails (gamma = 1.6);
// - gamma = 2 is GGX (D and Lambda), large gamma tends to Beckmann;
// - log Gamma against std::lgamma; derivatives of Jets against central differences;
// - the slope sampler's radial distribution against D cos(theta_h).

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/sampling.h"
#include "gonio/brdf/student_t.h"
#include "test_quadrature.h"

namespace gonio::brdf {
namespace {

using testing::integrate_hemisphere;

/// Integral over the upper hemisphere of g(w) dw for integrands that are peaked at the normal and
/// weakly singular at the horizon (a Student-t D with gamma < 2 grows like cos^(2 gamma - 4)
/// there): theta in [0, 1] by the cubic map of integrate_hemisphere, theta in [1, pi/2] with
/// cos(theta) = cos(1) v^5, which turns cos^-0.8 into a smooth integrand in v.
template <class G>
double integrate_hemisphere_tails(G g, int n_theta, int n_phi) {
    const double theta0 = 1.0;
    const double dphi = 2.0 * kPi / n_phi;
    auto ring = [&](double theta) {
        const double sin_t = std::sin(theta);
        const double cos_t = std::cos(theta);
        double sum = 0;
        for (int j = 0; j < n_phi; ++j) {
            const double phi = (j + 0.5) * dphi;
            sum += g(Vec3d(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t));
        }
        return sum * dphi;
    };
    double total = 0;
    const double ds = 1.0 / n_theta;
    for (int i = 0; i < n_theta; ++i) {
        // theta = theta0 s^3: d(theta) = 3 theta0 s^2 ds; dw = sin(theta) d(theta) d(phi).
        const double s = (i + 0.5) * ds;
        const double theta = theta0 * s * s * s;
        total += ring(theta) * std::sin(theta) * 3 * theta0 * s * s * ds;
    }
    const double c0 = std::cos(theta0);
    for (int i = 0; i < n_theta; ++i) {
        // cos(theta) = c0 v^5: sin(theta) d(theta) = 5 c0 v^4 dv.
        const double v = (i + 0.5) * ds;
        const double theta = std::acos(c0 * std::pow(v, 5));
        total += ring(theta) * 5 * c0 * std::pow(v, 4) * ds;
    }
    return total;
}

const double kGammas[] = {1.6, 2.0, 3.0, 10.0, 60.0};

struct StudentAlphas {
    double x;
    double y;
};
const StudentAlphas kStudentAlphas[] = {{0.05, 0.05}, {0.2, 0.2}, {0.6, 0.6}, {0.1, 0.4}};

TEST(StudentT, NormalisedOverProjectedArea) {
    for (double g : kGammas) {
        for (const StudentAlphas& a : kStudentAlphas) {
            const double integral = integrate_hemisphere(
                [&](const Vec3d& h) { return D_student_t(h, a.x, a.y, g) * h.z(); }, 2000, 400);
            // The heaviest tail (gamma 1.6) puts mass near the horizon, where the quadrature is
            // coarsest; its integrand there goes like cos^0.2.
            EXPECT_NEAR(integral, 1.0, g < 2 ? 2e-3 : 3e-4)
                << "gamma " << g << " alpha " << a.x << " " << a.y;
        }
    }
}

TEST(StudentT, GammaTwoIsGgx) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 2000; ++i) {
        const double theta = 0.5 * kPi * u(rng) * 0.999;
        const Vec3d w = spherical_to_cartesian(theta, 2 * kPi * u(rng));
        const double ax = 0.01 + u(rng);
        const double ay = 0.01 + u(rng);
        const double d_ggx = D_ggx(w, ax, ay);
        EXPECT_NEAR(D_student_t(w, ax, ay, 2.0), d_ggx, 1e-12 * d_ggx) << "seed 7 sample " << i;
        const double l_ggx = lambda_ggx(w, ax, ay);
        EXPECT_NEAR(lambda_student_t(w, ax, ay, 2.0), l_ggx, 1e-12 * l_ggx + 1e-300)
            << "seed 7 sample " << i << " theta " << theta;
    }
}

TEST(StudentT, LargeGammaTendsToBeckmann) {
    const double alpha = 0.3;
    for (double theta : {0.05, 0.2, 0.5, 1.0, 1.4}) {
        const Vec3d w = spherical_to_cartesian(theta, 0.4);
        const double db = D_beckmann(w, alpha, alpha);
        const double e = std::pow(std::tan(theta) / alpha, 2);
        // log D - log D_Beckmann = e - gamma log(1 + e / (gamma - 1)) = (e^2 / 2 - e) / (gamma - 1)
        // + O(1 / (gamma - 1)^2) (the series of log1p); the next term bounds the difference.
        for (double g : {100.0, 1000.0}) {
            const double ds = D_student_t(w, alpha, alpha, g);
            const double c = g - 1;
            EXPECT_NEAR(std::log(ds / db),
                        (e * e / 2 - e) / c,
                        (e * e / 2 + e * e * e / 3) / (c * c) + 1e-12)
                << "theta " << theta << " gamma " << g;
        }
        const double lb = lambda_beckmann(w, alpha, alpha);
        const double l1000 = lambda_student_t(w, alpha, alpha, 1000.0);
        const double l100 = lambda_student_t(w, alpha, alpha, 100.0);
        // Converges from above, monotonically in gamma.
        EXPECT_GE(l100, l1000) << "theta " << theta;
        EXPECT_NEAR(l1000, lb, 0.05 * lb + 1e-15) << "theta " << theta;
    }
}

TEST(StudentT, SmithG1SatisfiesVisibleNormalNormalisation) {
    for (double g : {1.6, 2.5, 5.0, 30.0}) {
        for (const StudentAlphas& a :
             {StudentAlphas{0.2, 0.2}, StudentAlphas{0.5, 0.5}, StudentAlphas{0.15, 0.45}}) {
            for (double theta_o : {0.0, 0.5, 1.0, 1.3, 1.5}) {
                for (double phi_o : {0.0, 0.8}) {
                    const Vec3d wo = spherical_to_cartesian(theta_o, phi_o);
                    const double lam = lambda_student_t(wo, a.x, a.y, g);
                    const double integral = integrate_hemisphere_tails(
                        [&](const Vec3d& h) {
                            return G1(wo, h, lam) * std::max(0.0, wo.dot(h)) *
                                   D_student_t(h, a.x, a.y, g);
                        },
                        600,
                        240);
                    EXPECT_NEAR(integral, wo.z(), 1e-3 * (1 + 1 / std::max(wo.z(), 0.1)))
                        << "gamma " << g << " alpha " << a.x << " " << a.y << " theta_o " << theta_o
                        << " phi_o " << phi_o << " Lambda " << lam;
                }
            }
        }
    }
}

TEST(StudentT, EdgeCases) {
    const double a = 0.2;
    for (double g : {1.6, 2.0, 40.0}) {
        EXPECT_EQ(lambda_student_t(Vec3d(0, 0, 1), a, a, g), 0.0);
        EXPECT_TRUE(std::isinf(lambda_student_t(Vec3d(1, 0, 0), a, a, g)));
        EXPECT_EQ(D_student_t(Vec3d(0, 0, -1), a, a, g), 0.0);
        EXPECT_EQ(D_student_t(Vec3d(1, 0, 0), a, a, g), 0.0);
        EXPECT_NEAR(D_student_t(Vec3d(0, 0, 1), a, a, g), 1 / (kPi * a * a), 1e-12);
        // Just above the horizon and almost along the normal: finite, non-negative.
        for (double theta : {1e-9, 1e-4, kPi / 2 - 1e-6, kPi / 2 - 1e-12}) {
            const Vec3d w = spherical_to_cartesian(theta, 0.3);
            const double d = D_student_t(w, a, a, g);
            const double l = lambda_student_t(w, a, a, g);
            EXPECT_TRUE(std::isfinite(d) && d >= 0) << "gamma " << g << " theta " << theta;
            EXPECT_TRUE(std::isfinite(l) && l >= 0) << "gamma " << g << " theta " << theta;
        }
    }
}

TEST(StudentT, LogGammaMatchesTheStandardLibrary) {
    for (double x = 0.3; x < 200; x *= 1.37) {
        EXPECT_NEAR(
            student_t_detail::log_gamma(x), std::lgamma(x), 1e-13 * (1 + std::abs(std::lgamma(x))))
            << "x " << x;
    }
}

TEST(StudentT, JetDerivativesMatchCentralDifferences) {
    using J = ceres::Jet<double, 3>;
    for (double g : {1.7, 2.0, 4.0, 50.0}) {
        for (double theta : {0.1, 0.6, 1.2, 1.5}) {
            const Vec3d w = spherical_to_cartesian(theta, 0.7);
            const Vec3<J> wj(J(w.x()), J(w.y()), J(w.z()));
            const double ax = 0.25, ay = 0.4;
            const J jax(ax, 0), jay(ay, 1), jg(g, 2);
            const J d = D_student_t(wj, jax, jay, jg);
            const J l = lambda_student_t(wj, jax, jay, jg);
            const double h[3] = {1e-6 * ax, 1e-6 * ay, 1e-6 * g};
            for (int k = 0; k < 3; ++k) {
                double p[3] = {ax, ay, g};
                double m[3] = {ax, ay, g};
                p[k] += h[k];
                m[k] -= h[k];
                const double dd =
                    (D_student_t(w, p[0], p[1], p[2]) - D_student_t(w, m[0], m[1], m[2])) /
                    (2 * h[k]);
                const double dl = (lambda_student_t(w, p[0], p[1], p[2]) -
                                   lambda_student_t(w, m[0], m[1], m[2])) /
                                  (2 * h[k]);
                EXPECT_NEAR(d.v[k], dd, 1e-6 * (std::abs(dd) + std::abs(d.a)))
                    << "D gamma " << g << " theta " << theta << " slot " << k;
                EXPECT_NEAR(l.v[k], dl, 1e-6 * (std::abs(dl) + std::abs(l.a)) + 1e-14)
                    << "Lambda gamma " << g << " theta " << theta << " slot " << k;
            }
        }
    }
}

TEST(StudentT, SampledNormalsFollowDCos) {
    // The fraction of sampled normals within theta_h < t equals the integral of D cos over that
    // cap, computed independently by quadrature.
    const double a = 0.3;
    for (double g : {1.8, 3.0, 20.0}) {
        std::mt19937_64 rng(11);
        std::uniform_real_distribution<double> u(0, 1);
        const int n = 200000;
        const double caps[] = {0.1, 0.3, 0.6, 1.0};
        int inside[4] = {0, 0, 0, 0};
        for (int i = 0; i < n; ++i) {
            const Vec3d h = sample_student_t_normal(a, a, g, u(rng), u(rng));
            const double t = std::acos(std::min(1.0, h.z()));
            for (int k = 0; k < 4; ++k) {
                inside[k] += t < caps[k] ? 1 : 0;
            }
        }
        for (int k = 0; k < 4; ++k) {
            const double expected = integrate_hemisphere(
                [&](const Vec3d& h) {
                    return std::acos(std::min(1.0, h.z())) < caps[k]
                               ? D_student_t(h, a, a, g) * h.z()
                               : 0.0;
                },
                2000,
                8);
            const double p = static_cast<double>(inside[k]) / n;
            EXPECT_NEAR(p, expected, 4 * std::sqrt(expected * (1 - expected) / n) + 2e-3)
                << "gamma " << g << " cap " << caps[k] << " seed 11";
        }
    }
}

}  // namespace
}  // namespace gonio::brdf
