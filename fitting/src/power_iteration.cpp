// The tabulated NDF by power iteration and its fit (power_iteration.h).

#include "gonio/fitting/power_iteration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "gonio/brdf/coords.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::fitting {

namespace {

using brdf::Rgbd;
using brdf::Sample;

/// Largest theta_d threshold, degrees: every sample (the Fresnel term is divided out per sample).
constexpr double kMaxThetaDDeg = 90.0;
/// Fewest backscattering samples an extraction accepts.
constexpr std::size_t kMinBackscatter = 10;

/// One backscattering sample as the iteration uses it.
struct Retro {
    double y;       ///< (f - rho/pi) 4 cos_i cos_o / (scale F), channels summed (1/sr times sr).
    double cos_i;   ///< cos(theta_i)
    double cos_o;   ///< cos(theta_o)
    std::size_t k;  ///< Grid interval of theta_h.
    double t;       ///< Weight of node k + 1.
    double weight;  ///< The sample's weight.
};

/// Samples a fit would use: finite, both directions above the horizon, not a reference
/// re-measurement, not saturated.
std::vector<Sample> usable_samples(const std::vector<Sample>& in) {
    std::vector<Sample> out;
    out.reserve(in.size());
    for (const Sample& s : in) {
        if (!brdf::validate_sample(s).empty() || !(std::cos(s.theta_i) > 0) ||
            !(std::cos(s.theta_o) > 0) ||
            (s.flags & (brdf::kFlagReference | brdf::kFlagSaturated)) != 0) {
            continue;
        }
        out.push_back(s);
    }
    return out;
}

/// Fills the nodes without data: linear between reached neighbours, constant beyond the ends.
std::size_t fill_gaps(std::vector<double>& d, const std::vector<double>& den) {
    const std::size_t n = d.size();
    std::vector<std::size_t> reached;
    for (std::size_t k = 0; k < n; ++k) {
        if (den[k] > 0) {
            reached.push_back(k);
        }
    }
    if (reached.empty()) {
        return n;
    }
    for (std::size_t k = 0; k < reached.front(); ++k) {
        d[k] = d[reached.front()];
    }
    for (std::size_t k = reached.back() + 1; k < n; ++k) {
        d[k] = d[reached.back()];
    }
    for (std::size_t r = 0; r + 1 < reached.size(); ++r) {
        const std::size_t a = reached[r], b = reached[r + 1];
        for (std::size_t k = a + 1; k < b; ++k) {
            const double t = static_cast<double>(k - a) / static_cast<double>(b - a);
            d[k] = (1 - t) * d[a] + t * d[b];
        }
    }
    return n - reached.size();
}

/// Solves the symmetric tridiagonal system (diag, off: A[k][k + 1] = A[k + 1][k] = off[k]) by
/// Gaussian elimination without pivoting (the matrix of hat-function normal equations is diagonally
/// dominant where every node is reached). A node without data (diag 0, its row and column 0)
/// stands apart: it gets 0 and is filled afterwards. A tiny ridge (1e-12 of the largest diagonal)
/// keeps nodes reached only at the far end of their support solvable.
std::vector<double> solve_tridiagonal(std::vector<double> diag,
                                      const std::vector<double>& off,
                                      std::vector<double> rhs) {
    const std::size_t n = diag.size();
    const double ridge = 1e-12 * *std::max_element(diag.begin(), diag.end());
    std::vector<bool> empty(n);
    for (std::size_t k = 0; k < n; ++k) {
        empty[k] = !(diag[k] > 0);
        diag[k] = empty[k] ? 1.0 : diag[k] + ridge;
        if (empty[k]) {
            rhs[k] = 0.0;
        }
    }
    std::vector<double> c(n, 0.0);  // the upper diagonal after elimination, divided
    for (std::size_t k = 0; k < n; ++k) {
        if (k > 0) {
            const double l = empty[k] || empty[k - 1] ? 0.0 : off[k - 1];
            diag[k] -= l * c[k - 1];
            rhs[k] -= l * rhs[k - 1];
        }
        c[k] = k + 1 < n && !empty[k] && !empty[k + 1] ? off[k] / diag[k] : 0.0;
        rhs[k] /= diag[k];
    }
    for (std::size_t k = n - 1; k-- > 0;) {
        rhs[k] -= c[k] * rhs[k + 1];
    }
    return rhs;
}

/// G of the lobe's shadowing at the two cosines for a table with node values sigma.
double shadowing_of(brdf::Shadowing s,
                    const std::vector<double>& sigma,
                    double cos_i,
                    double cos_o,
                    double g_vgroove) {
    switch (s) {
        case brdf::Shadowing::kSmithCorrelated:
        case brdf::Shadowing::kSmithSeparable: {
            const double li = std::max(0.0, brdf::tabulated_ndf_lookup(sigma, cos_i) / cos_i - 1.0);
            const double lo = std::max(0.0, brdf::tabulated_ndf_lookup(sigma, cos_o) / cos_o - 1.0);
            return s == brdf::Shadowing::kSmithCorrelated ? 1.0 / (1.0 + li + lo)
                                                          : 1.0 / ((1.0 + li) * (1.0 + lo));
        }
        case brdf::Shadowing::kVGroove:
            return g_vgroove;
        case brdf::Shadowing::kNone:
            break;
    }
    return 1.0;
}

/// A sample with the factors removed: the diffuse term and scale * F of the lobe.
struct Pre {
    double cos_d;
    Retro r;
    double g_vgroove;
};

/// The samples above the horizon with a positive lobe factor, each with the model's diffuse term
/// and the lobe's scale * F removed, located on the grid of n nodes.
std::vector<Pre> remove_factors(const std::vector<Sample>& samples,
                                const brdf::ModelD& factors,
                                std::size_t n) {
    const brdf::Lobe<double>& lobe = factors.lobes[0];
    std::vector<Pre> pre;
    pre.reserve(samples.size());
    for (const Sample& s : samples) {
        const brdf::Vec3d wi = s.wi();
        const brdf::Vec3d wo = s.wo();
        const brdf::Dir3<double> di{wi.x(), wi.y(), wi.z()}, dout{wo.x(), wo.y(), wo.z()};
        if (!(wi.z() > 0) || !(wo.z() > 0)) {
            continue;
        }
        const brdf::HalfGeometry<double> g = brdf::half_geometry(di, dout);
        double num = 0, den = 0;
        for (int c = 0; c < 3; ++c) {
            num += s.value[c] - (factors.has_diffuse ? factors.diffuse[c] * brdf::kInvPi : 0.0);
            den += lobe.scale[c] * brdf::lobe_F(lobe.fresnel, c, g.cos_d, g.one_minus_cos_d);
        }
        if (!(den > 0)) {
            continue;
        }
        Pre p;
        p.cos_d = g.cos_d;
        p.r.y = num / den * 4.0 * wi.z() * wo.z();
        p.r.cos_i = wi.z();
        p.r.cos_o = wo.z();
        brdf::tabulated_ndf_locate(g.h.z, n, &p.r.k, &p.r.t);
        p.r.weight = s.weight;
        p.g_vgroove = lobe.shadowing == brdf::Shadowing::kVGroove
                          ? brdf::G_vgroove_from_cosines(g.h.z, wi.z(), wo.z(), g.cos_d)
                          : 1.0;
        pre.push_back(p);
    }
    return pre;
}

/// The samples within the theta_d threshold of backscattering, the threshold doubled (up to
/// kMaxThetaDDeg) until they number min_samples; *threshold_deg is the one used.
std::vector<Pre> select_backscatter(const std::vector<Pre>& pre,
                                    const PowerIterationOptions& o,
                                    double* threshold_deg) {
    std::vector<Pre> retro;
    for (double thr = o.theta_d_max_deg;; thr = std::min(2 * thr, kMaxThetaDDeg)) {
        const double cos_thr = std::cos(thr * brdf::kPi / 180.0);
        retro.clear();
        for (const Pre& p : pre) {
            if (p.cos_d >= cos_thr) {
                retro.push_back(p);
            }
        }
        *threshold_deg = thr;
        if (retro.size() >= o.min_samples || thr >= kMaxThetaDDeg) {
            return retro;
        }
    }
}

/// The piecewise-linear D closest to the y / G of the samples in weighted least squares (G from
/// the current node values sigma), clamped at 0: the normal equations of the hat functions are
/// tridiagonal (diag, off: A[k][k + 1]). *den receives diag (each node's weight).
std::vector<double> least_squares_d(const std::vector<Pre>& retro,
                                    brdf::Shadowing shadowing,
                                    const std::vector<double>& sigma,
                                    std::size_t n,
                                    std::vector<double>* den) {
    std::vector<double> diag(n, 0.0), off(n, 0.0), rhs(n, 0.0);
    for (const Pre& p : retro) {
        const Retro& r = p.r;
        const double G = shadowing_of(shadowing, sigma, r.cos_i, r.cos_o, p.g_vgroove);
        if (!(G > 0)) {
            continue;
        }
        const double v = r.y / G;
        const double a = 1 - r.t, b = r.t;
        diag[r.k] += r.weight * a * a;
        diag[r.k + 1] += r.weight * b * b;
        off[r.k] += r.weight * a * b;
        rhs[r.k] += r.weight * a * v;
        rhs[r.k + 1] += r.weight * b * v;
    }
    std::vector<double> next = solve_tridiagonal(diag, off, rhs);
    for (double& x : next) {
        // D >= 0: noise below the diffuse floor is no negative microfacet density.
        x = std::max(0.0, x);
    }
    *den = std::move(diag);
    return next;
}

/// The largest change of a node from the previous iterate d (normalised) to the normalised
/// iterate `next`, relative to next's peak.
double relative_change(const std::vector<double>& K,
                       const std::vector<double>& d,
                       const std::vector<double>& next) {
    double change = 0, peak = 0;
    for (double x : next) {
        peak = std::max(peak, x);
    }
    // The first iterate is measured against the normalised start.
    const double d_norm = brdf::tabulated_ndf_sigma(K, d)[0];
    for (std::size_t k = 0; k < next.size(); ++k) {
        change = std::max(change, std::abs(next[k] - d[k] / d_norm));
    }
    return change / peak;
}

}  // namespace

Expected<NdfExtraction> extract_ndf(const std::vector<Sample>& samples,
                                    const brdf::ModelD& factors,
                                    const PowerIterationOptions& o) {
    const std::size_t n = o.nodes;
    if (n < brdf::kTabulatedNdfMinNodes || n > brdf::kTabulatedNdfMaxNodes || o.iterations < 1 ||
        !(o.theta_d_max_deg > 0 && o.theta_d_max_deg <= kMaxThetaDDeg)) {
        return make_error(
            "power iteration: 2 to 1024 nodes, iterations >= 1 and a "
            "theta_d threshold in (0, 90] degrees are required");
    }
    if (factors.lobes.empty() || factors.lobes[0].distribution != brdf::Distribution::kTabulated) {
        return make_error("power iteration: the model's first lobe must be tabulated");
    }
    const brdf::Lobe<double>& lobe = factors.lobes[0];
    NdfExtraction out;
    const std::vector<Pre> retro =
        select_backscatter(remove_factors(samples, factors, n), o, &out.theta_d_max_deg);
    out.samples = retro.size();
    if (retro.size() < kMinBackscatter) {
        return make_error("power iteration: " + std::to_string(retro.size()) + " samples within " +
                          std::to_string(static_cast<int>(kMaxThetaDDeg)) +
                          " degrees of backscattering (theta_d); at least " +
                          std::to_string(kMinBackscatter) +
                          " are needed to extract the microfacet distribution");
    }
    const std::vector<double> K = brdf::tabulated_ndf_sigma_matrix(n);
    std::vector<double> d(n, 1.0);
    if (lobe.table != nullptr && lobe.table->d.size() == n) {
        d = lobe.table->d;
    }
    std::vector<double> sigma = brdf::tabulated_ndf_sigma(K, d);
    for (int it = 1; it <= o.iterations; ++it) {
        std::vector<double> den;
        std::vector<double> next = least_squares_d(retro, lobe.shadowing, sigma, n, &den);
        out.empty_nodes = fill_gaps(next, den);
        const double norm = brdf::tabulated_ndf_sigma(K, next)[0];
        if (!(norm > 0) || !std::isfinite(norm)) {
            return make_error(
                "power iteration: the backscattering samples hold nothing above the "
                "diffuse term (int D cos = " +
                std::to_string(norm) + "); no microfacet distribution to extract");
        }
        for (double& x : next) {
            x /= norm;
        }
        out.change = relative_change(K, d, next);
        d = std::move(next);
        sigma = brdf::tabulated_ndf_sigma(K, d);
        out.iterations = it;
        if (out.change < 1e-7) {
            break;
        }
    }
    Expected<brdf::TabulatedNdf> table = brdf::make_tabulated_ndf(std::move(d), "power iteration");
    if (!table) {
        return tl::unexpected(table.error());
    }
    out.table = std::move(*table);
    return out;
}

bool needs_power_iteration(const FitSpec& spec) {
    for (const brdf::Lobe<double>& l : spec.model.lobes) {
        if (l.distribution == brdf::Distribution::kTabulated && l.table == nullptr) {
            return true;
        }
    }
    return false;
}

int table_nodes(const brdf::ModelD& model) {
    int n = 0;
    for (const brdf::Lobe<double>& l : model.lobes) {
        if (l.distribution == brdf::Distribution::kTabulated && l.table != nullptr) {
            n += static_cast<int>(l.table->d.size());
        }
    }
    return n;
}

Expected<FitResult> fit_power_iteration(const brdf::Dataset& data,
                                        const FitSpec& spec,
                                        const PowerIterationOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    if (spec.model.lobes.size() != 1 ||
        spec.model.lobes[0].distribution != brdf::Distribution::kTabulated) {
        return make_error("model tabulated: one tabulated lobe (its D extracted from the data)");
    }
    if (o.rounds < 1) {
        return make_error("power iteration: rounds >= 1 required");
    }
    const std::vector<Sample> valid = usable_samples(data.samples);
    if (valid.empty()) {
        return make_error(data.source + ": no valid sample to fit");
    }
    brdf::ModelD m = spec.model;
    m.lobes[0].table = nullptr;
    bool diffuse_free = false;
    for (const ParamSpec& p : spec.params) {
        diffuse_free = diffuse_free || (p.field == Field::kDiffuse && p.free);
    }
    if (m.has_diffuse && diffuse_free) {
        // The first diffuse: a low percentile of each channel far from the specular peak (theta_h
        // above 45 degrees), of all samples when fewer than 10 lie there (as fit()'s starts).
        for (int c = 0; c < 3; ++c) {
            std::vector<double> far, all;
            for (const Sample& s : valid) {
                all.push_back(s.value[c]);
                if (brdf::to_half_diff(s.wi(), s.wo()).theta_h > brdf::kPi / 4) {
                    far.push_back(s.value[c]);
                }
            }
            std::vector<double>& v = far.size() >= 10 ? far : all;
            const std::size_t q = static_cast<std::size_t>(0.2 * static_cast<double>(v.size() - 1));
            std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(q), v.end());
            m.diffuse[c] = std::min(brdf::kPi * v[q], 10.0);
        }
    }
    Expected<FitResult> res = make_error("power iteration: no round ran");
    NdfExtraction ext;
    int iterations = 0;
    double extract_s = 0;
    for (int round = 0; round < o.rounds; ++round) {
        const auto te = std::chrono::steady_clock::now();
        Expected<NdfExtraction> e = extract_ndf(valid, m, o);
        extract_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - te).count();
        if (!e) {
            return make_error(data.source + ": " + e.error().message);
        }
        ext = std::move(*e);
        iterations += ext.iterations;
        m.lobes[0].table = std::make_shared<const brdf::TabulatedNdf>(ext.table);
        FitSpec s = spec;
        s.model = m;
        s.options.starts = 1;
        if (round > 0) {
            // From the previous round's factors.
            s.options.auto_init = false;
        }
        if (round + 1 < o.rounds) {
            s.options.covariance = false;
            s.options.polish_iterations = 0;
            s.options.reweight_rounds = 0;
        }
        res = fit(data, s);
        if (!res) {
            return res;
        }
        if (!res->solver.converged) {
            break;
        }
        m = res->model;
    }
    StageInfo stage;
    stage.name = "power iteration";
    stage.samples = ext.samples;
    stage.iterations = iterations;
    stage.termination = "table of " + std::to_string(ext.table.d.size()) + " nodes from " +
                        std::to_string(ext.samples) + " samples within " +
                        std::to_string(static_cast<int>(ext.theta_d_max_deg)) +
                        " deg of backscattering, " + std::to_string(ext.empty_nodes) +
                        " nodes filled from neighbours, " + std::to_string(o.rounds) + " rounds";
    stage.time_s = extract_s;
    res->solver.stages.insert(res->solver.stages.begin(), stage);
    res->solver.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
}

Expected<FitResult> fit_any(const brdf::Dataset& data, const FitSpec& spec) {
    return needs_power_iteration(spec) ? fit_power_iteration(data, spec) : fit(data, spec);
}

}  // namespace gonio::fitting
