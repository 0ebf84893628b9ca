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

/// Flat index of the bin holding (wi, wo).
std::size_t bin_of(const TableGrid& g, const Vec3d& wi, const Vec3d& wo) {
    const HalfDiff<double> hd = to_half_diff(wi, wo);
    return g.index(
        g.theta_h_index(hd.theta_h), g.theta_d_index(hd.theta_d), g.phi_d_index(hd.phi_d));
}

/// Largest difference, per channel, between the valid bins of the 3 x 3 x 3 neighbourhood of a
/// bin (phi_d periodic) and the bin itself.
Rgbd local_spread(const TabulatedBrdf& t, std::size_t flat) {
    const TableGrid& g = t.grid();
    const std::array<int, 3> c = g.unflatten(flat);
    Rgbd lo = Rgbd::Constant(std::numeric_limits<double>::infinity());
    Rgbd hi = Rgbd::Constant(-std::numeric_limits<double>::infinity());
    for (int dh = -1; dh <= 1; ++dh) {
        for (int dd = -1; dd <= 1; ++dd) {
            for (int dp = -1; dp <= 1; ++dp) {
                const int ih = c[0] + dh;
                const int id = c[1] + dd;
                if (ih < 0 || ih >= g.n_theta_h || id < 0 || id >= g.n_theta_d) {
                    continue;
                }
                const int ip = ((c[2] + dp) % g.n_phi_d + g.n_phi_d) % g.n_phi_d;
                const std::size_t k = g.index(ih, id, ip);
                if (!t.bin_valid(k)) {
                    continue;
                }
                const Rgbd v = t.bin_value(k);
                lo = lo.cwiseMin(v);
                hi = hi.cwiseMax(v);
            }
        }
    }
    if (!std::isfinite(lo[0])) {
        return Rgbd::Zero();
    }
    return hi - lo;
}

/// Allowance of one table comparison (CheckOptions, table section): spread + k sigma.
Rgbd table_allowance(const TabulatedBrdf& t,
                     const CheckOptions& o,
                     std::size_t bin_a,
                     std::size_t bin_b,
                     const Rgbd& a,
                     const Rgbd& b) {
    const Rgbd spread = local_spread(t, bin_a).cwiseMax(local_spread(t, bin_b));
    Rgbd var_a = (o.noise_relative * a).cwiseAbs2();
    Rgbd var_b = (o.noise_relative * b).cwiseAbs2();
    if (bin_a < o.bin_sigma.size() && bin_b < o.bin_sigma.size()) {
        var_a += o.bin_sigma[bin_a].cwiseAbs2();
        var_b += o.bin_sigma[bin_b].cwiseAbs2();
    }
    return spread + o.noise_sigmas * (var_a + var_b).cwiseSqrt();
}

/// A symmetric comparison check (reciprocity, isotropy) over the pairs. `other` gives the second
/// value and the directions it was evaluated at.
template <class Other>
CheckResult compare_check(const Brdf& brdf,
                          const CheckOptions& options,
                          const char* name,
                          double tolerance,
                          Other other) {
    CheckResult r;
    r.name = name;
    const auto* table = dynamic_cast<const TabulatedBrdf*>(&brdf);
    r.tolerance = table != nullptr ? 1.0 : tolerance;
    r.measure = table != nullptr ? "difference / (bin spread + noise)" : "relative difference";
    for (const Pair& p : test_pairs(options)) {
        std::string how;
        Pair q = p;
        const Rgbd b = other(p, how, q);
        r.evaluations += 2;
        if (table != nullptr) {
            const TableLookup la = table->lookup(p.wi, p.wo);
            const TableLookup lb = table->lookup(q.wi, q.wo);
            if (!la.valid || !lb.valid) {
                // An unmeasured bin on either side: nothing to compare.
                ++r.skipped;
                continue;
            }
            const Rgbd allow = table_allowance(*table,
                                               options,
                                               bin_of(table->grid(), p.wi, p.wo),
                                               bin_of(table->grid(), q.wi, q.wo),
                                               la.value,
                                               lb.value);
            double d = 0;
            for (int c = 0; c < 3; ++c) {
                const double diff = std::abs(la.value[c] - lb.value[c]);
                // A tiny absolute floor keeps identical zero values at ratio 0.
                d = std::max(d, diff / (allow[c] + 1e-12 * (1 + std::abs(la.value[c]))));
            }
            if (d > r.violation) {
                r.violation = d;
                char buf[160];
                std::snprintf(buf,
                              sizeof buf,
                              "; values %.4g vs %.4g 1/sr (largest channel)",
                              la.value.maxCoeff(),
                              lb.value.maxCoeff());
                r.where = pair_text(p) + how + buf;
            }
            continue;
        }
        const Rgbd a = brdf.eval(p.wi, p.wo);
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
    if (r.skipped > 0) {
        r.detail = std::to_string(r.skipped) + " pairs in unmeasured bins not compared";
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
                         [&](const Pair& p, std::string&, Pair& q) {
                             q = {p.wo, p.wi};
                             return brdf.eval(p.wo, p.wi);
                         });
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
                         [&](const Pair& p, std::string& how, Pair& q) {
                             const double a = u(rng);
                             how = " rotated by " + fmt("%.4f", a * kDeg) + " deg";
                             q = {rotate_z(p.wi, a), rotate_z(p.wo, a)};
                             return brdf.eval(q.wi, q.wo);
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
    if (dynamic_cast<const TabulatedBrdf*>(&brdf) != nullptr && options.noise_relative > 0) {
        // A measured table's stated noise: the albedo may exceed 1 by that much (values fully
        // correlated, the conservative case).
        r.tolerance += options.noise_sigmas * options.noise_relative * std::max(max_albedo, 0.0);
        r.detail += "; tolerance includes the stated noise";
    }
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

double bonferroni_threshold(std::size_t n, double false_alarm) {
    const double p = false_alarm / static_cast<double>(std::max<std::size_t>(n, 1));
    // Two-sided tail of the standard normal: P(|z| > k) = erfc(k / sqrt 2); solved by bisection.
    double lo = 0, hi = 40;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        if (std::erfc(mid / std::sqrt(2.0)) > p) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return std::max(3.0, hi);
}

std::vector<Rgbd> bin_sigma_from_dataset(const TableGrid& grid, const Dataset& data) {
    std::vector<Rgbd> out(grid.size(), Rgbd::Zero());
    for (const Sample& s : data.samples) {
        out[bin_of(grid, s.wi(), s.wo())] = s.sigma;
    }
    return out;
}

namespace {

/// Canonical angles of a sample (degrees): theta_i, theta_o, |delta_phi| in [0, 180].
struct Canon {
    double ti, to, dphi, phi_i;
};

Canon canon(const Sample& s) {
    return {s.theta_i * kDeg,
            s.theta_o * kDeg,
            std::abs(wrap_pi(s.phi_o - s.phi_i)) * kDeg,
            wrap_pi(s.phi_i) * kDeg};
}

std::string sample_text(const Sample& s) {
    char buf[200];
    std::snprintf(buf,
                  sizeof buf,
                  "theta_i %.2f phi_i %.2f theta_o %.2f phi_o %.2f deg%s",
                  s.theta_i * kDeg,
                  s.phi_i * kDeg,
                  s.theta_o * kDeg,
                  s.phi_o * kDeg,
                  s.line ? (" (line " + std::to_string(s.line) + ")").c_str() : "");
    return buf;
}

/// z of a pair (DatasetCheckOptions).
double pair_z(const Sample& a, const Sample& b, double floor) {
    double z = 0;
    for (int c = 0; c < 3; ++c) {
        const double m = std::max(std::abs(a.value[c]), std::abs(b.value[c]));
        const double var =
            a.sigma[c] * a.sigma[c] + b.sigma[c] * b.sigma[c] + floor * floor * m * m;
        const double diff = std::abs(a.value[c] - b.value[c]);
        if (var > 0) {
            z = std::max(z, diff / std::sqrt(var));
        } else if (diff > 0) {
            // No uncertainty at all and a difference: infinitely many sigmas.
            z = std::numeric_limits<double>::infinity();
        }
    }
    return z;
}

/// Compares every matched pair (match(a, b) true, a < b) and keeps the worst z.
template <class Match>
CheckResult pair_check(const Dataset& data,
                       const DatasetCheckOptions& o,
                       const char* name,
                       const std::vector<Canon>& c,
                       Match match) {
    CheckResult r;
    r.name = name;
    r.measure = "z = |a - b| / combined sigma";
    // Buckets of theta_i keep the search near linear.
    const double tol = o.match_tolerance_deg;
    std::vector<std::vector<std::size_t>> by_ti(static_cast<std::size_t>(90.0 / tol) + 2);
    for (std::size_t i = 0; i < c.size(); ++i) {
        by_ti[std::min(by_ti.size() - 1, static_cast<std::size_t>(c[i].ti / tol))].push_back(i);
    }
    std::size_t pairs = 0;
    double worst = 0;
    std::size_t wa = 0, wb = 0;
    for (std::size_t i = 0; i < c.size(); ++i) {
        double key = 0;
        if (!match(c[i], c[i], key, true)) {
            continue;
        }
        const long centre = static_cast<long>(key / tol);
        for (long k = centre - 1; k <= centre + 1; ++k) {
            if (k < 0 || k >= static_cast<long>(by_ti.size())) {
                continue;
            }
            for (std::size_t j : by_ti[static_cast<std::size_t>(k)]) {
                if (j <= i || !match(c[i], c[j], key, false)) {
                    continue;
                }
                ++pairs;
                const double z = pair_z(data.samples[i], data.samples[j], o.relative_floor);
                r.evaluations += 2;
                if (z > worst || (std::isinf(z) && !std::isinf(worst))) {
                    worst = z;
                    wa = i;
                    wb = j;
                }
            }
        }
    }
    r.violation = worst;
    r.tolerance = bonferroni_threshold(pairs, o.false_alarm);
    if (pairs == 0) {
        r.applicable = false;
        r.where = "-";
        r.detail = "no matched pair of samples";
        return r;
    }
    r.where = sample_text(data.samples[wa]) + " vs " + sample_text(data.samples[wb]);
    char buf[200];
    std::snprintf(buf,
                  sizeof buf,
                  "%zu pairs; k = %.2f for a false alarm chance of %.0e; Y %.4g vs %.4g 1/sr",
                  pairs,
                  r.tolerance,
                  o.false_alarm,
                  data.samples[wa].value.mean(),
                  data.samples[wb].value.mean());
    r.detail = buf;
    finish(r);
    return r;
}

}  // namespace

std::vector<CheckResult> check_dataset(const Dataset& data, const DatasetCheckOptions& o) {
    std::vector<Canon> c;
    c.reserve(data.samples.size());
    for (const Sample& s : data.samples) {
        c.push_back(canon(s));
    }
    const double tol = o.match_tolerance_deg;
    std::vector<CheckResult> out;

    CheckResult nn;
    nn.name = "non-negativity";
    nn.measure = "-(value / sigma), worst";
    const double k = bonferroni_threshold(data.samples.size() * 3, o.false_alarm);
    nn.tolerance = k;
    nn.where = "-";
    for (const Sample& s : data.samples) {
        for (int ch = 0; ch < 3; ++ch) {
            ++nn.evaluations;
            const double sig = std::hypot(s.sigma[ch], o.relative_floor * std::abs(s.value[ch]));
            const double v = s.value[ch] >= 0 ? 0.0
                             : sig > 0        ? -s.value[ch] / sig
                                              : std::numeric_limits<double>::infinity();
            if (v > nn.violation) {
                nn.violation = v;
                nn.where = sample_text(s);
            }
        }
    }
    finish(nn);
    out.push_back(nn);

    // Reciprocity: a's (theta_i, theta_o) = b's (theta_o, theta_i), same |delta_phi|; pairs with
    // theta_i = theta_o say nothing about reciprocity and are left out.
    out.push_back(pair_check(
        data, o, "reciprocity", c, [&](const Canon& a, const Canon& b, double& key, bool probe) {
            if (probe) {
                key = a.to;
                return std::abs(a.ti - a.to) > tol;
            }
            return std::abs(a.ti - b.to) <= tol && std::abs(a.to - b.ti) <= tol &&
                   std::abs(a.dphi - b.dphi) <= tol;
        }));
    // Isotropy: the same canonical configuration at another phi_i.
    out.push_back(pair_check(
        data, o, "isotropy", c, [&](const Canon& a, const Canon& b, double& key, bool probe) {
            if (probe) {
                key = a.ti;
                return true;
            }
            return std::abs(a.ti - b.ti) <= tol && std::abs(a.to - b.to) <= tol &&
                   std::abs(a.dphi - b.dphi) <= tol &&
                   std::abs(wrap_pi((a.phi_i - b.phi_i) / kDeg)) * kDeg > tol;
        }));
    CheckResult e;
    e.name = "energy";
    e.measure = "max directional albedo - 1";
    e.applicable = false;
    e.where = "-";
    e.detail = "needs the BRDF over every direction: check a fit or a table";
    out.push_back(e);
    return out;
}

}  // namespace gonio::brdf
