#include "gonio/brdf/table_sampling.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"

namespace gonio::brdf {
namespace {

constexpr double kHalfPi = kPi / 2;

// Index k with cdf[k] <= u < cdf[k + 1], skipping zero-probability cells; cdf has n + 1 entries,
// cdf[0] = 0, cdf[n] = 1.
int find_interval(const double* cdf, int n, double u) {
    const double* it = std::upper_bound(cdf, cdf + n + 1, u);
    int k = static_cast<int>(it - cdf) - 1;
    k = std::min(std::max(k, 0), n - 1);
    // Land on a cell with positive probability (u can sit exactly on a flat stretch of the CDF).
    while (k < n - 1 && !(cdf[k + 1] > cdf[k])) {
        ++k;
    }
    while (k > 0 && !(cdf[k + 1] > cdf[k])) {
        --k;
    }
    return k;
}

// Rescales u from [cdf[k], cdf[k+1]) to [0, 1).
double remap(const double* cdf, int k, double u) {
    const double width = cdf[k + 1] - cdf[k];
    const double t = width > 0 ? (u - cdf[k]) / width : 0.5;
    return std::min(std::max(t, 0.0), 0x1.fffffffffffffp-1);
}

double luminance(const Rgbd& f) {
    return 0.2126 * f[0] + 0.7152 * f[1] + 0.0722 * f[2];
}

}  // namespace

TableSampler::TableSampler(const Brdf& brdf, const TableSamplerOptions& options)
    : options_(options) {
    GONIO_CHECK_MSG(
        options.n_theta_i > 0 && options.n_theta_o > 0 && options.n_phi_o > 0,
        "sampler grid " << options.n_theta_i << " " << options.n_theta_o << " " << options.n_phi_o);
    GONIO_CHECK_MSG(options.uniform_fraction >= 0 && options.uniform_fraction <= 1,
                    "uniform_fraction " << options.uniform_fraction);
    GONIO_CHECK_MSG(brdf.isotropic(), "TableSampler needs an isotropic BRDF: " << brdf.describe());
    const int ns = options.n_theta_i;
    const int nt = options.n_theta_o;
    const int np = options.n_phi_o;
    cell_prob_.assign(static_cast<std::size_t>(ns) * nt * np, 0.0);
    row_cdf_.assign(static_cast<std::size_t>(ns) * (nt + 1), 0.0);
    col_cdf_.assign(static_cast<std::size_t>(ns) * nt * (np + 1), 0.0);
    slice_ok_.assign(ns, 0);
    const double dtheta = kHalfPi / nt;
    const double dphi = 2 * kPi / np;
    for (int s = 0; s < ns; ++s) {
        const double theta_i = (s + 0.5) / ns * kHalfPi;
        const Vec3d wi = spherical_to_cartesian(theta_i, 0.0);
        double* prob = cell_prob_.data() + static_cast<std::size_t>(s) * nt * np;
        double total = 0;
        for (int i = 0; i < nt; ++i) {
            const double t0 = i * dtheta;
            const double t1 = (i + 1) * dtheta;
            // Integral of cos(theta) sin(theta) dtheta over the row: (sin^2 t1 - sin^2 t0) / 2.
            const double row_measure =
                (std::sin(t1) * std::sin(t1) - std::sin(t0) * std::sin(t0)) / 2 * dphi;
            const double theta_c = (i + 0.5) * dtheta;
            for (int j = 0; j < np; ++j) {
                const Vec3d wo = spherical_to_cartesian(theta_c, (j + 0.5) * dphi);
                const double y = luminance(brdf.eval(wi, wo));
                // Negative or non-finite luminance cannot be a probability: such cells get none.
                const double w = (std::isfinite(y) && y > 0) ? y * row_measure : 0.0;
                prob[i * np + j] = w;
                total += w;
            }
        }
        if (!(total > 0) || !std::isfinite(total)) {
            // Nothing to importance-sample for this slice: the cosine part takes over entirely.
            std::fill(prob, prob + static_cast<std::size_t>(nt) * np, 0.0);
            continue;
        }
        slice_ok_[s] = 1;
        double* rows = row_cdf_.data() + static_cast<std::size_t>(s) * (nt + 1);
        for (int i = 0; i < nt; ++i) {
            double* cols = col_cdf_.data() + (static_cast<std::size_t>(s) * nt + i) * (np + 1);
            double row_sum = 0;
            for (int j = 0; j < np; ++j) {
                prob[i * np + j] /= total;
                row_sum += prob[i * np + j];
                cols[j + 1] = row_sum;
            }
            for (int j = 1; j <= np; ++j) {
                // An empty row keeps a uniform conditional; it is never chosen (zero marginal).
                cols[j] = row_sum > 0 ? cols[j] / row_sum : static_cast<double>(j) / np;
            }
            cols[np] = 1.0;
            rows[i + 1] = rows[i] + row_sum;
        }
        rows[nt] = 1.0;
    }
}

int TableSampler::slice_of(double theta_i) const {
    const int ns = options_.n_theta_i;
    const int s = static_cast<int>(theta_i / kHalfPi * ns);
    return std::min(std::max(s, 0), ns - 1);
}

double TableSampler::table_pdf(int slice, double theta_o, double phi_rel) const {
    const int nt = options_.n_theta_o;
    const int np = options_.n_phi_o;
    const double dtheta = kHalfPi / nt;
    const double dphi = 2 * kPi / np;
    const int i = std::min(std::max(static_cast<int>(theta_o / dtheta), 0), nt - 1);
    const int j = std::min(std::max(static_cast<int>(phi_rel / dphi), 0), np - 1);
    const double p = cell_prob_[(static_cast<std::size_t>(slice) * nt + i) * np + j];
    // Solid angle of the cell: (cos t0 - cos t1) dphi.
    const double omega = (std::cos(i * dtheta) - std::cos((i + 1) * dtheta)) * dphi;
    return p / omega;
}

DirectionSample TableSampler::sample(const Vec3d& wi, double u_mix, double u1, double u2) const {
    DirectionSample out;
    if (!(wi.z() > 0)) {
        // Incidence at or below the horizon: no reflection to sample.
        return out;
    }
    const Spherical<double> si = cartesian_to_spherical(wi);
    const int s = slice_of(si.theta);
    const double e = slice_ok_[s] ? options_.uniform_fraction : 1.0;
    if (u_mix < e) {
        // Cosine-weighted hemisphere: cos(theta) = sqrt(1 - u1), phi = 2 pi u2.
        const double cos_t = std::sqrt(std::max(0.0, 1 - u1));
        out.w = spherical_to_cartesian(std::acos(cos_t), 2 * kPi * u2);
    } else {
        const int nt = options_.n_theta_o;
        const int np = options_.n_phi_o;
        const double* rows = row_cdf_.data() + static_cast<std::size_t>(s) * (nt + 1);
        const int i = find_interval(rows, nt, u1);
        const double v1 = remap(rows, i, u1);
        const double* cols = col_cdf_.data() + (static_cast<std::size_t>(s) * nt + i) * (np + 1);
        const int j = find_interval(cols, np, u2);
        const double v2 = remap(cols, j, u2);
        // Uniform in solid angle inside the cell: cos(theta) linear in v1, phi linear in v2.
        const double dtheta = kHalfPi / nt;
        const double dphi = 2 * kPi / np;
        const double c0 = std::cos(i * dtheta);
        const double c1 = std::cos((i + 1) * dtheta);
        const double cos_t = c0 + v1 * (c1 - c0);
        const double phi_rel = (j + v2) * dphi;
        out.w = spherical_to_cartesian(std::acos(std::min(cos_t, 1.0)), si.phi + phi_rel);
    }
    out.pdf = pdf(wi, out.w);
    return out;
}

double TableSampler::pdf(const Vec3d& wi, const Vec3d& wo) const {
    if (!(wi.z() > 0) || !(wo.z() > 0)) {
        // At or below the horizon: sample() never produces such a wo.
        return 0;
    }
    const Spherical<double> si = cartesian_to_spherical(wi);
    const Spherical<double> so = cartesian_to_spherical(wo);
    const int s = slice_of(si.theta);
    const double cos_pdf = wo.z() / kPi;
    if (!slice_ok_[s]) {
        // Empty slice: cosine sampling only.
        return cos_pdf;
    }
    double phi_rel = so.phi - si.phi;
    phi_rel -= 2 * kPi * std::floor(phi_rel / (2 * kPi));
    const double e = options_.uniform_fraction;
    return (1 - e) * table_pdf(s, so.theta, phi_rel) + e * cos_pdf;
}

}  // namespace gonio::brdf
