// The tabulated microfacet distribution: grid, projected area, normalisation, sampling
// (tabulated_ndf.h).

#include "gonio/brdf/tabulated_ndf.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/limits.h"

namespace gonio::brdf {

namespace {

// Sub-intervals per grid interval in the quadrature of sigma.
constexpr int kQuadPerInterval = 16;

}  // namespace

double tabulated_ndf_theta(std::size_t k, std::size_t n) {
    const double u = static_cast<double>(k) / static_cast<double>(n - 1);
    return u * u * (kPi / 2.0);
}

double azimuthal_cosine(double a, double b) {
    if (b <= std::abs(a)) {
        // The whole circle is on one side of the plane.
        return a > 0.0 ? 2.0 * kPi * a : 0.0;
    }
    const double phi0 = std::acos(std::clamp(-a / b, -1.0, 1.0));
    return 2.0 * (a * phi0 + std::sqrt(std::max(0.0, b * b - a * a)));
}

std::vector<double> tabulated_ndf_sigma_matrix(std::size_t n) {
    std::vector<double> K(n * n, 0.0);
    const double h = 1.0 / static_cast<double>(n - 1);
    for (std::size_t j = 0; j < n; ++j) {
        const double theta = tabulated_ndf_theta(j, n);
        const double ct = std::cos(theta), st = std::sin(theta);
        for (std::size_t p = 0; p + 1 < n; ++p) {
            for (int q = 0; q < kQuadPerInterval; ++q) {
                const double t = (q + 0.5) / kQuadPerInterval;
                const double u = (static_cast<double>(p) + t) * h;
                const double theta_m = u * u * (kPi / 2.0);
                // d omega = sin(theta_m) dtheta_m dphi, dtheta_m = pi u du.
                const double w = azimuthal_cosine(ct * std::cos(theta_m), st * std::sin(theta_m)) *
                                 std::sin(theta_m) * kPi * u * h / kQuadPerInterval;
                K[j * n + p] += (1.0 - t) * w;
                K[j * n + p + 1] += t * w;
            }
        }
    }
    return K;
}

std::vector<double> tabulated_ndf_sigma(const std::vector<double>& K,
                                        const std::vector<double>& d) {
    const std::size_t n = d.size();
    std::vector<double> s(n, 0.0);
    for (std::size_t j = 0; j < n; ++j) {
        double sum = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
            sum += K[j * n + k] * d[k];
        }
        s[j] = sum;
    }
    return s;
}

Expected<TabulatedNdf> make_tabulated_ndf(std::vector<double> d, const std::string& where) {
    if (d.size() < kTabulatedNdfMinNodes || d.size() > kTabulatedNdfMaxNodes) {
        return make_error(where + ": " + std::to_string(d.size()) + " nodes (" +
                          std::to_string(kTabulatedNdfMinNodes) + " to " +
                          std::to_string(kTabulatedNdfMaxNodes) + ")");
    }
    double peak = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) {
        if (!std::isfinite(d[k]) || d[k] < 0.0) {
            return make_error(where + "[" + std::to_string(k) + "] = " + show_number(d[k]) +
                              ": D must be finite and >= 0");
        }
        peak = std::max(peak, d[k]);
    }
    if (!(peak > 0.0)) {
        return make_error(where + ": every node is 0 (no microfacet at all)");
    }
    const std::vector<double> K = tabulated_ndf_sigma_matrix(d.size());
    const double norm = tabulated_ndf_sigma(K, d)[0];
    if (!(norm > 0.0) || !std::isfinite(norm)) {
        return make_error(where + ": the projected area int D cos is " + show_number(norm) +
                          " (only the horizon node is above 0)");
    }
    for (double& x : d) {
        x /= norm;
    }
    TabulatedNdf out;
    out.sigma = tabulated_ndf_sigma(K, d);
    out.d = std::move(d);
    return out;
}

namespace {

/// Probability of each grid interval under D cos: int over the interval of D cos d omega, by the
/// same quadrature as sigma at the normal (so that they sum to sigma(normal) = 1).
std::vector<double> interval_masses(const TabulatedNdf& table) {
    const std::size_t n = table.d.size();
    const double h = 1.0 / static_cast<double>(n - 1);
    std::vector<double> mass(n - 1, 0.0);
    for (std::size_t p = 0; p + 1 < n; ++p) {
        for (int q = 0; q < kQuadPerInterval; ++q) {
            const double t = (q + 0.5) / kQuadPerInterval;
            const double u = (static_cast<double>(p) + t) * h;
            const double theta_m = u * u * (kPi / 2.0);
            const double d = (1.0 - t) * table.d[p] + t * table.d[p + 1];
            mass[p] += d * 2.0 * kPi * std::cos(theta_m) * std::sin(theta_m) * kPi * u * h /
                       kQuadPerInterval;
        }
    }
    return mass;
}

}  // namespace

double pdf_tabulated_normal(const TabulatedNdf& table, double cos_theta_h) {
    if (!(cos_theta_h > 0.0)) {
        // Microfacet normals face outward only.
        return 0.0;
    }
    const std::size_t n = table.d.size();
    std::size_t k = 0;
    double t = 0.0;
    tabulated_ndf_locate(cos_theta_h, n, &k, &t);
    const std::vector<double> mass = interval_masses(table);
    double total = 0.0;
    for (double m : mass) {
        total += m;
    }
    const double solid_angle =
        2.0 * kPi * (std::cos(tabulated_ndf_theta(k, n)) - std::cos(tabulated_ndf_theta(k + 1, n)));
    return mass[k] / total / solid_angle;
}

Vec3d sample_tabulated_normal(const TabulatedNdf& table, double u1, double u2) {
    const std::size_t n = table.d.size();
    const std::vector<double> mass = interval_masses(table);
    double total = 0.0;
    for (double m : mass) {
        total += m;
    }
    // The interval by its cumulative mass; u1 then reused within it.
    double target = u1 * total;
    std::size_t k = 0;
    while (k + 2 < n && target >= mass[k]) {
        target -= mass[k];
        ++k;
    }
    const double v = mass[k] > 0.0 ? std::clamp(target / mass[k], 0.0, 1.0) : 0.5;
    const double c0 = std::cos(tabulated_ndf_theta(k, n));
    const double c1 = std::cos(tabulated_ndf_theta(k + 1, n));
    const double cos_theta = c0 - v * (c0 - c1);
    const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
    const double phi = 2.0 * kPi * u2;
    return Vec3d(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta);
}

}  // namespace gonio::brdf
