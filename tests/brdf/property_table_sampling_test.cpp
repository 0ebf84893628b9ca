// Importance sampling of tables: chi-square goodness of fit of sample() against pdf(), pdf
// normalisation, and Monte Carlo albedo estimates against quadrature.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "brdf_test_util.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/table.h"
#include "gonio/brdf/table_sampling.h"

namespace gonio::brdf {
namespace {

TabulatedBrdf ggx_table(double alpha) {
    ModelD m;
    m.diffuse = Rgbd(0.1, 0.1, 0.1);
    Lobe<double> l;
    l.alpha_x = l.alpha_y = alpha;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd(0.5, 0.5, 0.5);
    m.lobes.push_back(l);
    TabulateOptions o;
    o.grid = TableGrid{30, 30, 60};
    o.threads = 1;
    TabulatedBrdf t = tabulate(AnalyticBrdf(m), o);
    t.set_interpolation(Interpolation::kTrilinear);
    return t;
}

// Integral of pdf(wi, .) over the cell [t0, t1] x [p0, p1] (theta, phi relative to phi_i) by the
// midpoint rule on an n x n subdivision with the sin(theta) Jacobian.
double integrate_pdf(const TableSampler& s,
                     const Vec3d& wi,
                     double phi_i,
                     double t0,
                     double t1,
                     double p0,
                     double p1,
                     int n) {
    double sum = 0;
    const double dt = (t1 - t0) / n;
    const double dp = (p1 - p0) / n;
    for (int a = 0; a < n; ++a) {
        const double theta = t0 + (a + 0.5) * dt;
        for (int b = 0; b < n; ++b) {
            const double phi = phi_i + p0 + (b + 0.5) * dp;
            sum += s.pdf(wi, spherical_to_cartesian(theta, phi)) * std::sin(theta);
        }
    }
    return sum * dt * dp;
}

using test_util::chi2_upper_tail;

TEST(TableSampling, ChiSquareOfSamplesAgainstPdf) {
    const TabulatedBrdf table = ggx_table(0.2);
    TableSamplerOptions so;
    so.n_theta_i = 16;
    so.n_theta_o = 32;
    so.n_phi_o = 64;
    const TableSampler sampler(table, so);
    const int n_t = 16;
    const int n_p = 32;
    const int n_samples = 100000;
    for (const double theta_i_deg : {5.0, 40.0, 75.0}) {
        const unsigned seed = 1000 + static_cast<unsigned>(theta_i_deg);
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> u(0, 1);
        const double phi_i = 0.3;
        const Vec3d wi = spherical_to_cartesian(theta_i_deg * kPi / 180, phi_i);
        std::vector<double> observed(n_t * n_p, 0.0);
        for (int k = 0; k < n_samples; ++k) {
            const DirectionSample d = sampler.sample(wi, u(rng), u(rng), u(rng));
            ASSERT_GT(d.pdf, 0) << "seed " << seed;
            ASSERT_GT(d.w.z(), 0) << "seed " << seed;
            ASSERT_NEAR(d.pdf, sampler.pdf(wi, d.w), 1e-12 * d.pdf);
            const Spherical<double> sp = cartesian_to_spherical(d.w);
            double rel = sp.phi - phi_i;
            rel -= 2 * kPi * std::floor(rel / (2 * kPi));
            const int a = std::min(static_cast<int>(sp.theta / (kPi / 2) * n_t), n_t - 1);
            const int b = std::min(static_cast<int>(rel / (2 * kPi) * n_p), n_p - 1);
            observed[a * n_p + b] += 1;
        }
        // Expected counts; cells below 5 expected are pooled into one.
        double chi2 = 0;
        int cells = 0;
        double pooled_obs = 0;
        double pooled_exp = 0;
        double total_p = 0;
        for (int a = 0; a < n_t; ++a) {
            for (int b = 0; b < n_p; ++b) {
                const double p = integrate_pdf(sampler,
                                               wi,
                                               phi_i,
                                               a * (kPi / 2) / n_t,
                                               (a + 1) * (kPi / 2) / n_t,
                                               b * 2 * kPi / n_p,
                                               (b + 1) * 2 * kPi / n_p,
                                               8);
                total_p += p;
                const double e = p * n_samples;
                if (e < 5) {
                    pooled_obs += observed[a * n_p + b];
                    pooled_exp += e;
                    continue;
                }
                chi2 += (observed[a * n_p + b] - e) * (observed[a * n_p + b] - e) / e;
                ++cells;
            }
        }
        if (pooled_exp > 0) {
            chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
            ++cells;
        }
        const double p_value = chi2_upper_tail(chi2, cells - 1);
        std::printf("theta_i %.0f deg: chi2 %.1f over %d cells, p = %.3g, integral of pdf %.6f\n",
                    theta_i_deg,
                    chi2,
                    cells,
                    p_value,
                    total_p);
        EXPECT_NEAR(total_p, 1.0, 1e-3) << "seed " << seed;
        EXPECT_GT(p_value, 1e-3) << "seed " << seed << " theta_i " << theta_i_deg;
    }
}

// Directional albedo of the table, integral of f cos over the hemisphere, by quadrature and by
// importance sampling: the estimates agree within their statistical error, and importance sampling
// has a smaller standard error than cosine sampling for a glossy table.
TEST(TableSampling, ImportanceSampledAlbedoMatchesQuadrature) {
    const TabulatedBrdf table = ggx_table(0.1);
    const TableSampler sampler(table);
    TableSamplerOptions cos_only;
    cos_only.uniform_fraction = 1.0;
    const TableSampler cosine(table, cos_only);
    const unsigned seed = 99;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (const double theta_i : {0.2, 0.9}) {
        const Vec3d wi = spherical_to_cartesian(theta_i, 1.0);
        // Quadrature: midpoint on 400 x 800 cells.
        const int nt = 400, np = 800;
        double quad = 0;
        for (int a = 0; a < nt; ++a) {
            const double th = (a + 0.5) * (kPi / 2) / nt;
            for (int b = 0; b < np; ++b) {
                const Vec3d wo = spherical_to_cartesian(th, (b + 0.5) * 2 * kPi / np);
                quad += table.eval(wi, wo)[1] * wo.z() * std::sin(th);
            }
        }
        quad *= (kPi / 2 / nt) * (2 * kPi / np);
        auto estimate = [&](const TableSampler& s, double* stderr_out) {
            const int n = 20000;
            double sum = 0, sum2 = 0;
            for (int k = 0; k < n; ++k) {
                const DirectionSample d = s.sample(wi, u(rng), u(rng), u(rng));
                const double x = table.eval(wi, d.w)[1] * d.w.z() / d.pdf;
                sum += x;
                sum2 += x * x;
            }
            const double mean = sum / n;
            *stderr_out = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
            return mean;
        };
        double se_is = 0, se_cos = 0;
        const double est_is = estimate(sampler, &se_is);
        const double est_cos = estimate(cosine, &se_cos);
        std::printf(
            "theta_i %.2f: albedo quadrature %.5f, importance %.5f +- %.5f, cosine %.5f +- %.5f\n",
            theta_i,
            quad,
            est_is,
            se_is,
            est_cos,
            se_cos);
        // Quadrature of a trilinear table on a 400 x 800 grid: ~1e-3 relative; allow 5 sigma.
        EXPECT_NEAR(est_is, quad, 5 * se_is + 2e-3 * quad) << "seed " << seed;
        EXPECT_NEAR(est_cos, quad, 5 * se_cos + 2e-3 * quad) << "seed " << seed;
        EXPECT_LT(se_is, se_cos) << "seed " << seed;
    }
}

TEST(TableSampling, HorizonAndEmptyTables) {
    const TableGrid g{4, 4, 8};
    TabulatedBrdf zero = TabulatedBrdf::empty(g, {1, 1, 1}, "empty");
    TableSamplerOptions o;
    o.n_theta_i = 4;
    o.n_theta_o = 8;
    o.n_phi_o = 16;
    const TableSampler s(zero, o);
    const Vec3d wi = spherical_to_cartesian(0.5, 0.0);
    // No data at all: pure cosine sampling, pdf = cos(theta_o) / pi.
    const Vec3d wo = spherical_to_cartesian(0.7, 2.0);
    EXPECT_NEAR(s.pdf(wi, wo), std::cos(0.7) / kPi, 1e-15);
    const DirectionSample d = s.sample(wi, 0.9, 0.3, 0.6);
    EXPECT_NEAR(d.pdf, d.w.z() / kPi, 1e-15);
    // At or below the horizon: nothing to sample, density 0.
    EXPECT_EQ(s.pdf(Vec3d(0, 0, -1), wo), 0.0);
    EXPECT_EQ(s.pdf(wi, Vec3d(0.6, 0, -0.8)), 0.0);
    EXPECT_EQ(s.sample(Vec3d(1, 0, 0), 0.5, 0.5, 0.5).pdf, 0.0);
}

}  // namespace
}  // namespace gonio::brdf
