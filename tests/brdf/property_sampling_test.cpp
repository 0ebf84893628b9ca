// Importance sampling against its pdf: chi-square goodness of fit of sampled directions against the
// pdf integrated over bins (pbrt-style), for the microfacet normal samplers (density D cos) and the
// lobe samplers (GGX visible normals, density over wo). Seeds are printed on failure.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "brdf_test_util.h"
#include "gonio/brdf/sampling.h"

namespace gonio::brdf {
namespace {

using test_util::chi2_upper_tail;

struct Binning {
    int n_theta;
    int n_phi;
    double theta_max;  ///< pi/2: the upper hemisphere; directions below fall in the remainder
    /// Bin index, or -1 for a direction outside the binned region.
    int bin(const Vec3d& w) const {
        if (theta_max <= kPi / 2 && w.z() < 0) {
            return -1;
        }
        const double theta = std::acos(std::max(-1.0, std::min(1.0, w.z())));
        double phi = std::atan2(w.y(), w.x());
        if (phi < 0) {
            phi += 2 * kPi;
        }
        const int i = std::min(n_theta - 1, static_cast<int>(theta / theta_max * n_theta));
        const int j = std::min(n_phi - 1, static_cast<int>(phi / (2 * kPi) * n_phi));
        return i * n_phi + j;
    }
};

/// Integrates pdf over each bin (8 x 8 midpoint sub-grid), draws n samples, merges bins with
/// expected counts below 5 into a remainder that also holds the probability outside the bins
/// (1 - total: directions below the horizon and samples lost because the sampled normal faced
/// away), and returns the chi-square upper tail probability. Also returns the binned total.
double chi_square_p(const std::function<Vec3d(double, double)>& sample,
                    const std::function<double(const Vec3d&)>& pdf,
                    const Binning& b,
                    int n,
                    std::uint64_t seed,
                    double* total_probability,
                    int* lost) {
    std::vector<double> expected(b.n_theta * b.n_phi, 0.0);
    const int sub = 8;
    const double dt = b.theta_max / b.n_theta / sub;
    const double dp = 2 * kPi / b.n_phi / sub;
    double total = 0;
    for (int i = 0; i < b.n_theta; ++i) {
        for (int j = 0; j < b.n_phi; ++j) {
            double sum = 0;
            for (int si = 0; si < sub; ++si) {
                const double theta = (i * sub + si + 0.5) * dt;
                for (int sj = 0; sj < sub; ++sj) {
                    const double phi = (j * sub + sj + 0.5) * dp;
                    sum += pdf(spherical_to_cartesian(theta, phi)) * std::sin(theta) * dt * dp;
                }
            }
            expected[i * b.n_phi + j] = sum;
            total += sum;
        }
    }
    *total_probability = total;
    std::vector<double> observed(expected.size(), 0.0);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    *lost = 0;
    int outside = 0;
    for (int k = 0; k < n; ++k) {
        const double u1 = u(rng);
        const double u2 = u(rng);
        const Vec3d w = sample(u1, u2);
        if (w.squaredNorm() == 0) {
            ++*lost;
            continue;
        }
        const int index = b.bin(w);
        if (index < 0) {
            ++outside;
            continue;
        }
        observed[index] += 1;
    }
    double chi2 = 0;
    int dof = -1;
    double pooled_e = 0;
    double pooled_o = 0;
    for (std::size_t k = 0; k < expected.size(); ++k) {
        const double e = expected[k] * n;
        if (e < 5) {
            pooled_e += e;
            pooled_o += observed[k];
            continue;
        }
        chi2 += (observed[k] - e) * (observed[k] - e) / e;
        ++dof;
    }
    // The remainder outside the bins: lost samples and directions below the horizon.
    pooled_e += std::max(0.0, n * (1 - total));
    pooled_o += *lost + outside;
    if (pooled_e >= 5) {
        chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        ++dof;
    }
    return chi2_upper_tail(chi2, dof);
}

struct Case {
    const char* name;
    Distribution d;
    double ax;
    double ay;
};

const Case kCases[] = {{"ggx iso 0.2", Distribution::kGgx, 0.2, 0.2},
                       {"ggx iso 0.7", Distribution::kGgx, 0.7, 0.7},
                       {"ggx aniso", Distribution::kGgx, 0.15, 0.5},
                       {"beckmann iso 0.3", Distribution::kBeckmann, 0.3, 0.3},
                       {"beckmann aniso", Distribution::kBeckmann, 0.6, 0.2},
                       {"blinn-phong 20", Distribution::kBlinnPhong, 0, 0}};

Lobe<double> lobe_of(const Case& c) {
    Lobe<double> l;
    l.distribution = c.d;
    l.alpha_x = c.ax;
    l.alpha_y = c.ay;
    l.anisotropic = c.ax != c.ay;
    l.exponent = 20;
    return l;
}

TEST(Sampling, NormalSamplersFollowDCosTheta) {
    std::uint64_t seed = 1001;
    for (const Case& c : kCases) {
        const Lobe<double> l = lobe_of(c);
        auto sample = [&](double u1, double u2) -> Vec3d {
            switch (c.d) {
                case Distribution::kGgx:
                    return sample_ggx_normal(c.ax, c.ay, u1, u2);
                case Distribution::kBeckmann:
                    return sample_beckmann_normal(c.ax, c.ay, u1, u2);
                case Distribution::kStudentT:
                    return sample_student_t_normal(c.ax, c.ay, l.gamma, u1, u2);
                case Distribution::kTabulated:
                    // No table among these cases (unit_tabulated_ndf_test samples one).
                case Distribution::kBlinnPhong:
                    break;
            }
            return sample_blinn_phong_normal(l.exponent, u1, u2);
        };
        auto pdf = [&](const Vec3d& h) { return lobe_D(l, h) * std::max(0.0, h.z()); };
        double total = 0;
        int lost = 0;
        const double p = chi_square_p(sample, pdf, {24, 24, kPi / 2}, 200000, seed, &total, &lost);
        EXPECT_NEAR(total, 1.0, 2e-3) << c.name;
        EXPECT_GT(p, 1e-4) << c.name << " seed " << seed;
        ++seed;
    }
}

TEST(Sampling, LobeSamplesFollowPdfLobe) {
    std::uint64_t seed = 2002;
    for (const Case& c : kCases) {
        const Lobe<double> l = lobe_of(c);
        for (double theta_i : {0.1, 0.8, 1.4}) {
            const Vec3d wi = spherical_to_cartesian(theta_i, 0.4);
            auto sample = [&](double u1, double u2) -> Vec3d {
                const DirectionSample s = sample_lobe(l, wi, u1, u2);
                if (s.pdf == 0) {
                    return Vec3d::Zero();
                }
                // The reported pdf is the density of the returned direction.
                EXPECT_NEAR(s.pdf, pdf_lobe(l, wi, s.w), 1e-12 * s.pdf);
                return s.w;
            };
            auto pdf = [&](const Vec3d& wo) { return pdf_lobe(l, wi, wo); };
            double total = 0;
            int lost = 0;
            // Bins over the upper hemisphere of wo; below it the density has an integrable
            // singularity at wo = -wi (Beckmann, Blinn-Phong), which bins would not resolve.
            const double p =
                chi_square_p(sample, pdf, {32, 32, kPi / 2}, 100000, seed, &total, &lost);
            if (c.d == Distribution::kGgx) {
                // Visible-normal sampling never produces a back-facing normal.
                EXPECT_EQ(lost, 0);
            }
            EXPECT_LE(total, 1.0 + 3e-3);
            EXPECT_GT(p, 1e-4) << c.name << " theta_i " << theta_i << " seed " << seed;
            ++seed;
        }
    }
}

TEST(Sampling, VisibleNormalDensityIsNormalised) {
    // integral of D_v(h) dh = 1 (it is the G1 normalisation divided by cos theta_v).
    for (double theta : {0.0, 0.6, 1.3}) {
        const Vec3d v = spherical_to_cartesian(theta, 1.0);
        double sum = 0;
        const int n = 600;
        for (int i = 0; i < n; ++i) {
            const double s = (i + 0.5) / n;
            const double t = 0.5 * kPi * s * s;
            const double dt = kPi * s / n;
            for (int j = 0; j < 200; ++j) {
                const double p = (j + 0.5) * 2 * kPi / 200;
                sum += pdf_ggx_vndf(v, spherical_to_cartesian(t, p), 0.3, 0.6) * std::sin(t) * dt *
                       (2 * kPi / 200);
            }
        }
        EXPECT_NEAR(sum, 1.0, 1e-3) << "theta " << theta;
    }
}

}  // namespace
}  // namespace gonio::brdf
