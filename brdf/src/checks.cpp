// Property checks on any BRDF.

#include "gonio/brdf/checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

namespace gonio::brdf {

namespace {

constexpr double kDeg = 180.0 / kPi;

/// One (wi, wo) pair to test.
struct Pair {
    Vec3d wi;
    Vec3d wo;
};

std::string fmt(const char* format, double a) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, a);
    return buf;
}

std::string dir_text(const Vec3d& w) {
    const Spherical<double> s = cartesian_to_spherical(w);
    char buf[96];
    std::snprintf(buf, sizeof buf, "(theta %.4f, phi %.4f) deg", s.theta * kDeg, s.phi * kDeg);
    return buf;
}

std::string pair_text(const Pair& p) {
    return "wi " + dir_text(p.wi) + " wo " + dir_text(p.wo);
}

/// Uniform over the upper hemisphere's area: cos(theta) uniform in (0, 1].
Vec3d random_direction(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double cos_theta = 1.0 - u(rng);
    const double phi = 2.0 * kPi * u(rng);
    const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
    return Vec3d(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta);
}

/// Edge directions: normal, 1e-6 rad off it, 45 and 89.999 degrees and exactly the horizon, at a
/// few azimuths.
std::vector<Vec3d> edge_directions() {
    std::vector<Vec3d> out;
    const double thetas[] = {0.0, 1e-6, kPi / 4, 89.999 / kDeg, kPi / 2};
    const double phis[] = {0.0, kPi / 3, kPi, -kPi / 2};
    for (double t : thetas) {
        for (double p : phis) {
            if (t == kPi / 2) {
                // Exactly at the horizon: z = 0 exactly, not cos(pi/2) = 6e-17.
                out.emplace_back(std::cos(p), std::sin(p), 0.0);
            } else {
                out.push_back(spherical_to_cartesian(t, p));
            }
        }
    }
    return out;
}

/// Every pair of edge directions, wi = wo and mirror pairs, then seeded random pairs (also their
/// mirror configurations).
std::vector<Pair> test_pairs(const CheckOptions& options) {
    std::vector<Pair> pairs;
    const std::vector<Vec3d> edges = edge_directions();
    for (const Vec3d& a : edges) {
        for (const Vec3d& b : edges) {
            pairs.push_back({a, b});
        }
        pairs.push_back({a, reflect_z(a)});
    }
    std::mt19937_64 rng(options.seed);
    for (int i = 0; i < options.random_pairs; ++i) {
        const Vec3d wi = random_direction(rng);
        Vec3d wo = random_direction(rng);
        if (i % 4 == 0) {
            // A quarter near the mirror direction, where specular lobes peak.
            wo = (reflect_z(wi) + 0.05 * (wo - Vec3d(0, 0, 1))).normalized();
            if (wo.z() <= 0) {
                wo = reflect_z(wi);
            }
        }
        pairs.push_back({wi, wo});
        if (i % 16 == 0) {
            pairs.push_back({wi, wi});
        }
    }
    return pairs;
}

double relative_difference(const Rgbd& a, const Rgbd& b) {
    double worst = 0;
    for (int c = 0; c < 3; ++c) {
        const double scale = std::max(std::abs(a[c]), std::abs(b[c])) + 1e-8;
        worst = std::max(worst, std::abs(a[c] - b[c]) / scale);
    }
    return worst;
}

bool finite(const Rgbd& v) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

void finish(CheckResult& r) {
    if (r.applicable) {
        r.passed = r.violation <= r.tolerance;
    }
}

/// A symmetric comparison check (reciprocity, isotropy) over the pairs.
template <class Other>
CheckResult compare_check(const Brdf& brdf,
                          const CheckOptions& options,
                          const char* name,
                          double tolerance,
                          Other other) {
    CheckResult r;
    r.name = name;
    r.tolerance = tolerance;
    r.measure = "relative difference";
    for (const Pair& p : test_pairs(options)) {
        const Rgbd a = brdf.eval(p.wi, p.wo);
        std::string how;
        const Rgbd b = other(p, how);
        r.evaluations += 2;
        const double d = (finite(a) && finite(b)) ? relative_difference(a, b)
                                                  : std::numeric_limits<double>::infinity();
        if (d > r.violation || (std::isinf(d) && !std::isinf(r.violation))) {
            r.violation = d;
            r.where = pair_text(p) + how;
        }
    }
    if (r.where.empty()) {
        r.where = "-";
    }
    finish(r);
    return r;
}

}  // namespace

CheckResult check_non_negativity(const Brdf& brdf, const CheckOptions& options) {
    CheckResult r;
    r.name = "non-negativity";
    r.tolerance = 0;
    r.measure = "-(most negative value) 1/sr";
    double min_value = std::numeric_limits<double>::infinity();
    std::vector<Pair> pairs = test_pairs(options);
    // Below-horizon directions too: values there must still be finite and non-negative.
    const std::size_t n = pairs.size();
    for (std::size_t i = 0; i < n; i += 7) {
        pairs.push_back({pairs[i].wi, Vec3d(pairs[i].wo.x(), pairs[i].wo.y(), -pairs[i].wo.z())});
    }
    for (const Pair& p : pairs) {
        const Rgbd v = brdf.eval(p.wi, p.wo);
        ++r.evaluations;
        if (!finite(v)) {
            if (!std::isinf(r.violation)) {
                r.violation = std::numeric_limits<double>::infinity();
                r.where = pair_text(p);
                r.detail = "non-finite value";
            }
            continue;
        }
        const double m = v.minCoeff();
        if (m < min_value) {
            min_value = m;
            if (!std::isinf(r.violation) && m < 0) {
                r.violation = -m;
                r.where = pair_text(p);
            }
        }
    }
    r.detail = r.detail.empty() ? "min value " + fmt("%.6g", min_value) : r.detail;
    if (r.where.empty()) {
        r.where = "-";
    }
    finish(r);
    return r;
}

CheckResult check_reciprocity(const Brdf& brdf, const CheckOptions& options) {
    return compare_check(brdf,
                         options,
                         "reciprocity",
                         options.reciprocity_tolerance,
                         [&](const Pair& p, std::string&) { return brdf.eval(p.wo, p.wi); });
}

CheckResult check_isotropy(const Brdf& brdf, const CheckOptions& options) {
    if (!brdf.isotropic()) {
        CheckResult r;
        r.name = "isotropy";
        r.measure = "relative difference";
        r.tolerance = options.isotropy_tolerance;
        r.applicable = false;
        r.passed = true;
        r.where = "-";
        r.detail = "not claimed (anisotropic)";
        return r;
    }
    std::mt19937_64 rng(options.seed ^ 0x9e3779b97f4a7c15ull);
    std::uniform_real_distribution<double> u(-kPi, kPi);
    return compare_check(brdf,
                         options,
                         "isotropy",
                         options.isotropy_tolerance,
                         [&](const Pair& p, std::string& how) {
                             const double a = u(rng);
                             how = " rotated by " + fmt("%.4f", a * kDeg) + " deg";
                             return brdf.eval(rotate_z(p.wi, a), rotate_z(p.wo, a));
                         });
}

Rgbd directional_albedo(const Brdf& brdf, const Vec3d& wi, int n_theta, int n_phi) {
    Rgbd sum = Rgbd::Zero();
    const double ds = 1.0 / n_theta;
    const double dphi = 2.0 * kPi / n_phi;
    for (int i = 0; i < n_theta; ++i) {
        const double s = (i + 0.5) * ds;
        const double theta_h = 0.5 * kPi * s * s * s;
        const double dtheta = 1.5 * kPi * s * s * ds;
        const double sin_h = std::sin(theta_h);
        const double cos_h = std::cos(theta_h);
        for (int j = 0; j < n_phi; ++j) {
            const double phi = (j + 0.5) * dphi;
            const Vec3d h(sin_h * std::cos(phi), sin_h * std::sin(phi), cos_h);
            const double cos_d = wi.dot(h);
            if (cos_d <= 0) {
                // This normal is seen from behind: its reflection would be below the horizon.
                continue;
            }
            const Vec3d wo = 2.0 * cos_d * h - wi;
            if (wo.z() <= 0) {
                // Below the horizon: the BRDF is zero there by contract.
                continue;
            }
            sum += brdf.eval(wi, wo) * (wo.z() * 4.0 * cos_d * sin_h * dtheta * dphi);
        }
    }
    return sum;
}

CheckResult check_energy_conservation(const Brdf& brdf, const CheckOptions& options) {
    CheckResult r;
    r.name = "energy";
    r.tolerance = options.energy_tolerance;
    r.measure = "max directional albedo - 1";
    const double thetas_deg[] = {0, 10, 20, 30, 40, 50, 60, 70, 80, 85, 89};
    std::vector<double> phis_deg = {0};
    if (!brdf.isotropic()) {
        phis_deg = {0, 45, 90};
    }
    double max_albedo = -1;
    for (double t : thetas_deg) {
        for (double p : phis_deg) {
            const Vec3d wi = spherical_to_cartesian(t / kDeg, p / kDeg);
            const Rgbd a =
                directional_albedo(brdf, wi, options.quadrature_theta, options.quadrature_phi);
            r.evaluations +=
                static_cast<std::size_t>(options.quadrature_theta) * options.quadrature_phi;
            for (int c = 0; c < 3; ++c) {
                if (!std::isfinite(a[c])) {
                    r.violation = std::numeric_limits<double>::infinity();
                    r.where = "theta_i " + fmt("%.0f", t) + " deg phi_i " + fmt("%.0f", p) + " deg";
                    r.detail = "non-finite albedo";
                    finish(r);
                    return r;
                }
                if (a[c] > max_albedo) {
                    max_albedo = a[c];
                    r.where = "theta_i " + fmt("%.0f", t) + " deg phi_i " + fmt("%.0f", p) +
                              " deg channel " + "rgb"[c];
                }
            }
        }
    }
    r.violation = std::max(0.0, max_albedo - 1.0);
    r.detail = "max albedo " + fmt("%.6f", max_albedo);
    finish(r);
    return r;
}

std::vector<CheckResult> run_checks(const Brdf& brdf, const CheckOptions& options) {
    return {check_non_negativity(brdf, options),
            check_reciprocity(brdf, options),
            check_isotropy(brdf, options),
            check_energy_conservation(brdf, options)};
}

bool all_passed(const std::vector<CheckResult>& results) {
    return std::all_of(
        results.begin(), results.end(), [](const CheckResult& r) { return r.passed; });
}

std::string format_check_table(const std::vector<CheckResult>& results) {
    std::string out;
    char line[512];
    std::snprintf(line,
                  sizeof line,
                  "%-15s %-6s %-12s %-10s %-28s %s\n",
                  "check",
                  "result",
                  "violation",
                  "tolerance",
                  "measure",
                  "where / detail");
    out += line;
    for (const CheckResult& r : results) {
        const char* verdict = !r.applicable ? "n/a" : (r.passed ? "ok" : "FAIL");
        std::string where = r.where;
        if (!r.detail.empty()) {
            where += where == "-" ? "" : "; ";
            where = (where == "-" ? "" : where) + r.detail;
        }
        std::snprintf(line,
                      sizeof line,
                      "%-15s %-6s %-12.4g %-10.3g %-28s %s\n",
                      r.name.c_str(),
                      verdict,
                      r.violation,
                      r.tolerance,
                      r.measure.c_str(),
                      where.c_str());
        out += line;
    }
    return out;
}

}  // namespace gonio::brdf
