// Initialisation: data-driven starts scored on a reduction, then screened by short solves.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "fit_stages.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/fitting/reduction.h"

namespace gonio::fitting::detail {

namespace {

using brdf::ModelD;
using brdf::Rgbd;
using brdf::Sample;

// Samples that score the multi-start candidates and on which the screen's short solves rank the
// best of them (prepared once for both): each of the 13 candidates costs two or three passes
// over them (one or two for its linear terms, one for its cost), which dominated a fit of a few
// thousand points at 4000; 1500 stratified samples rank the starts as the screen's solves do.
constexpr std::size_t kScoreSamples = 1500;
constexpr std::size_t kScreenStarts = 4;  // starts screened by a short solve
constexpr int kScreenIterations = 15;     // iterations of a screening solve

/// Objective value (1/2 sum of squared residuals, as Ceres reports it) of a model on prepared
/// samples; infinity when a residual is not finite.
double objective(const PreparedSamples& ps, const std::vector<double>& x, int threads) {
    double s = 0;
    if (!ps.sum_of_squares(x.data(), &s, threads)) {
        return std::numeric_limits<double>::infinity();
    }
    return 0.5 * s;
}

/// Percentile (0..1) of a vector (copied).
double percentile(std::vector<double> v, double q) {
    if (v.empty()) {
        return 0;
    }
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
    return v[k];
}

/// Alpha estimated from the width of the specular peak above the diffuse floor: the largest
/// tan(theta_h) whose excess is at least half the peak's, divided by the half-maximum point of
/// the distribution in units of alpha (GGX: (1 + t^2/a^2)^-2 = 1/2 at t = a sqrt(sqrt 2 - 1);
/// Beckmann: exp(-t^2/a^2) = 1/2 at t = a sqrt(ln 2)). Returns 0 when there is no peak. cos
/// theta_h comes from `ps`, prepared on `samples` (has_cos_h), or from the directions.
double estimate_alpha(const std::vector<Sample>& samples,
                      const PreparedSamples& ps,
                      const Rgbd& floor,
                      brdf::Distribution d) {
    std::vector<double> excess(samples.size());
    std::vector<double> tan_h(samples.size());
    const bool prepared = ps.has_cos_h() && ps.size() == samples.size();
    double peak = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        double cos_i, cos_o, h_z;
        if (prepared) {
            // Both directions above the horizon (fit() validates them): h is defined.
            cos_i = ps.cos_i(i);
            cos_o = std::cos(samples[i].theta_o);
            h_z = ps.cos_h(i);
        } else {
            const brdf::Vec3d wi = samples[i].wi();
            const brdf::Vec3d wo = samples[i].wo();
            const brdf::Vec3d h = wi + wo;
            const double norm = h.norm();
            if (norm == 0) {
                // Opposite directions: no half vector, no information on the lobe.
                tan_h[i] = 1e9;
                excess[i] = 0;
                continue;
            }
            cos_i = wi.z();
            cos_o = wo.z();
            h_z = h.z() / norm;
        }
        const double cos_h = std::max(h_z, 1e-9);
        tan_h[i] = std::sqrt(std::max(0.0, 1 - cos_h * cos_h)) / cos_h;
        // Projected-area form: D times 4 cos_i cos_o removes the 1/(cos cos) foreshortening.
        excess[i] = ((samples[i].value - floor * brdf::kInvPi).sum() / 3) * cos_i * cos_o;
        peak = std::max(peak, excess[i]);
    }
    if (!(peak > 0)) {
        return 0;
    }
    double t_half = 0;
    double t_min = 1e9;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        if (excess[i] >= 0.5 * peak) {
            t_half = std::max(t_half, tan_h[i]);
        }
        if (tan_h[i] > 0) {
            t_min = std::min(t_min, tan_h[i]);
        }
    }
    if (t_half <= 0) {
        // Only the exact mirror sample is above half: the peak is narrower than the grid.
        t_half = 0.5 * t_min;
    }
    const double unit = d == brdf::Distribution::kBeckmann ? 0.8326 : 0.6436;
    return t_half / unit;
}

/// Sets the shape of lobe `i` from alpha (alpha_x = alpha_y = alpha or the Blinn-Phong exponent
/// 2 / alpha^2 - 2, the usual correspondence of the two lobes' widths), within the bounds.
void set_shape(ModelD& m, const ParameterMap& map, int lobe, double alpha) {
    for (const ScalarParam& s : map.scalars()) {
        if (s.lobe != lobe || !s.free) {
            continue;
        }
        double v;
        if (s.field == Field::kAlphaX || s.field == Field::kAlphaY || s.field == Field::kAlphaRgb) {
            v = alpha;
        } else if (s.field == Field::kExponent) {
            v = 2.0 / (alpha * alpha) - 2.0;
        } else {
            continue;
        }
        ParameterMap::set(m, s, std::clamp(v, s.lower, s.upper));
    }
}

const ScalarParam* find_free(const ParameterMap& map, Field f, int lobe, int channel) {
    for (const ScalarParam& s : map.scalars()) {
        if (s.free && s.field == f && s.lobe == lobe && (s.channel == channel || s.channel < 0)) {
            return &s;
        }
    }
    return nullptr;
}

/// The weights of linear_init's least squares, w_c = weight / (d_c + floor)^2 per sample and
/// channel: they depend on the data alone, so they are computed once for every start.
struct LinearWeights {
    std::vector<double> w[3];
    LinearWeights(const std::vector<Sample>& samples, double floor) {
        for (int c = 0; c < 3; ++c) {
            w[c].resize(samples.size());
            for (std::size_t i = 0; i < samples.size(); ++i) {
                const double d = samples[i].value[c];
                const double dp = std::max(d, 0.0);  // a value below zero within noise: 0
                w[c][i] = samples[i].weight / ((dp + floor) * (dp + floor));
            }
        }
    }
};

/// The free parameters that enter the model linearly, per channel: the diffuse albedo and lobe
/// 0's amplitude (its scale, or Schlick's f0 when the scale is fixed). nullptr when not free.
struct LinearTerms {
    const ScalarParam* rho[3] = {nullptr, nullptr, nullptr};
    const ScalarParam* amp[3] = {nullptr, nullptr, nullptr};
    bool amp_is_f0 = false;
};

LinearTerms find_linear_terms(const ModelD& m, const ParameterMap& map) {
    LinearTerms t;
    for (int c = 0; c < 3; ++c) {
        t.rho[c] = find_free(map, Field::kDiffuse, -1, c);
        t.amp[c] = m.lobes.empty() ? nullptr : find_free(map, Field::kScale, 0, c);
        if (t.amp[c] == nullptr && !m.lobes.empty() &&
            m.lobes[0].fresnel.type == brdf::FresnelType::kSchlick) {
            t.amp[c] = find_free(map, Field::kF0, 0, c);
            t.amp_is_f0 = t.amp[c] != nullptr;
        }
    }
    return t;
}

/// The weighted normal equations a u = b of u = (albedo, amplitude), per channel.
struct LinearSystem {
    Eigen::Matrix2d a[3];
    Eigen::Vector2d b[3];
};

LinearSystem linear_normal_equations(const ModelD& m,
                                     bool amp_is_f0,
                                     const std::vector<Sample>& samples,
                                     const PreparedSamples& prepared,
                                     const LinearWeights& lw,
                                     int threads) {
    // Basis values: the model without diffuse and with lobe 0's amplitude at 0 and at 1.
    ModelD m0 = m;
    m0.has_diffuse = false;
    ModelD m1 = m0;
    if (!m.lobes.empty()) {
        if (amp_is_f0) {
            m0.lobes[0].fresnel.f0 = Rgbd::Zero();
            m1.lobes[0].fresnel.f0 = Rgbd::Ones();
        } else {
            m0.lobes[0].scale = Rgbd::Zero();
            m1.lobes[0].scale = Rgbd::Ones();
        }
    }
    // The basis on the prepared samples (the geometry is computed once for every start). With a
    // single lobe whose scale is the amplitude, m0 is the zero model: its values are not needed.
    const bool zero_m0 = m0.lobes.size() == 1 && !amp_is_f0;
    std::vector<Rgbd> v0, v1;
    if (!zero_m0) {
        prepared.model_values(m0, v0, threads);
    }
    prepared.model_values(m1, v1, threads);
    constexpr double b0 = brdf::kInvPi;
    LinearSystem sys;
    for (int c = 0; c < 3; ++c) {
        // Sums of w basis basis^T and w basis (d - f0), basis = (1/pi, f1 - f0), in sample order.
        double a00 = 0, a01 = 0, a11 = 0, r0 = 0, r1 = 0;
        const double* w = lw.w[c].data();
        for (std::size_t i = 0; i < samples.size(); ++i) {
            const double f0 = zero_m0 ? 0.0 : v0[i][c];
            const double b1 = v1[i][c] - f0;
            const double res = samples[i].value[c] - f0;
            const double wb0 = w[i] * b0;
            const double wb1 = w[i] * b1;
            a00 += wb0 * b0;
            a01 += wb0 * b1;
            a11 += wb1 * b1;
            r0 += wb0 * res;
            r1 += wb1 * res;
        }
        sys.a[c] << a00, a01, a01, a11;
        sys.b[c] << r0, r1;
    }
    return sys;
}

/// Channel c's albedo and amplitude from the system: both when both are free (a negative one at
/// its lower bound, 0, and the other solved alone), else the free one with the other as it is in
/// the model. Terms that are not free keep their current values.
void solve_channel(const ModelD& m,
                   const ParameterMap& map,
                   const LinearTerms& t,
                   const LinearSystem& sys,
                   int c,
                   double* u_rho,
                   double* u_amp) {
    const Eigen::Matrix2d& a = sys.a[c];
    const Eigen::Vector2d& b = sys.b[c];
    const bool use_rho = t.rho[c] != nullptr;
    const bool use_amp = t.amp[c] != nullptr;
    *u_rho = use_rho ? map.value_of(m, *t.rho[c]) : 0;
    *u_amp = use_amp ? map.value_of(m, *t.amp[c]) : 0;
    auto solve1 = [&](int k, double fixed_other) {
        const int o = 1 - k;
        const double rhs = b[k] - a(k, o) * fixed_other;
        return a(k, k) > 0 ? rhs / a(k, k) : 0.0;
    };
    if (use_rho && use_amp) {
        const double det = a.determinant();
        if (std::abs(det) > 1e-300) {
            const Eigen::Vector2d u = a.inverse() * b;
            *u_rho = u[0];
            *u_amp = u[1];
        }
        if (*u_rho < 0) {
            *u_rho = 0;
            *u_amp = solve1(1, 0);
        } else if (*u_amp < 0) {
            *u_amp = 0;
            *u_rho = solve1(0, 0);
        }
    } else if (use_rho) {
        // The lobe as it is (amplitude fixed) is part of the prediction.
        double fixed_amp = 0;
        if (!m.lobes.empty()) {
            fixed_amp = t.amp_is_f0 ? m.lobes[0].fresnel.f0[c] : m.lobes[0].scale[c];
        }
        *u_rho = solve1(0, fixed_amp);
    } else if (use_amp) {
        *u_amp = solve1(1, m.has_diffuse ? m.diffuse[c] : 0.0);
    }
}

/// Stores the channels' values u of the parameters p inside their bounds; a shared parameter (one
/// value for the three channels) starts at the channels' mean.
void store_linear(ModelD& m, const ScalarParam* const* p, const double* u) {
    if (p[0] == nullptr) {
        return;
    }
    for (int c = 0; c < 3; ++c) {
        const double v = p[c]->channel < 0 ? (u[0] + u[1] + u[2]) / 3 : u[c];
        if (std::isfinite(v)) {
            ParameterMap::set(m, *p[c], std::clamp(v, p[c]->lower, p[c]->upper));
        }
    }
}

/// Linear least squares of the terms that enter the model linearly, per channel, given the
/// shapes: the diffuse albedo and lobe 0's amplitude (its scale, or Schlick's f0 when the scale is
/// fixed: F = x^5 + f0 (1 - x^5) is linear in f0). Relative weights 1 / (d + floor)^2 so that the
/// peak does not decide alone. A negative solution puts that term at its lower bound and solves
/// for the other; results are brought inside the bounds (these are start values, not results).
void linear_init(ModelD& m,
                 const ParameterMap& map,
                 const std::vector<Sample>& samples,
                 const PreparedSamples& prepared,
                 const LinearWeights& lw,
                 int threads) {
    const LinearTerms t = find_linear_terms(m, map);
    const LinearSystem sys =
        linear_normal_equations(m, t.amp_is_f0, samples, prepared, lw, threads);
    double u_rho[3] = {0, 0, 0};
    double u_amp[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) {
        solve_channel(m, map, t, sys, c, &u_rho[c], &u_amp[c]);
    }
    store_linear(m, t.rho, u_rho);
    store_linear(m, t.amp, u_amp);
}

/// Every free scalar brought inside its bounds (start values only).
std::vector<double> clamp_start(const ParameterMap& map, std::vector<double> x) {
    for (int k = 0; k < map.size(); ++k) {
        const ScalarParam& s = map.scalars()[map.free()[k]];
        x[k] = std::clamp(x[k], s.lower, s.upper);
    }
    return x;
}

/// Off-specular floor: a low percentile of each channel among samples far from the mirror
/// direction (theta_h > 45 degrees), or of all samples when there are none.
Rgbd off_specular_floor(const std::vector<Sample>& score_set, const PreparedSamples& scorer) {
    std::vector<char> is_far(score_set.size());
    std::size_t n_far = 0;
    const bool prepared_h = scorer.has_cos_h() && scorer.size() == score_set.size();
    const double cos_far = std::cos(brdf::kPi / 4);
    for (std::size_t i = 0; i < score_set.size(); ++i) {
        is_far[i] = prepared_h ? scorer.cos_h(i) < cos_far
                               : brdf::to_half_diff(score_set[i].wi(), score_set[i].wo()).theta_h >
                                     brdf::kPi / 4;
        n_far += is_far[i];
    }
    Rgbd floor = Rgbd::Zero();
    for (int c = 0; c < 3; ++c) {
        std::vector<double> v;
        v.reserve(score_set.size());
        for (std::size_t i = 0; i < score_set.size(); ++i) {
            if (n_far < 10 || is_far[i]) {
                v.push_back(score_set[i].value[c]);
            }
        }
        floor[c] = brdf::kPi * percentile(std::move(v), 0.2);
    }
    return floor;
}

/// The slopes of the starts: the estimate, half and twice it, random log-uniform ones up to
/// o.starts, and (with several starts) a fixed log-spaced ladder.
std::vector<double> start_alphas(double alpha, const FitOptions& o) {
    if (!(alpha > 0) || !std::isfinite(alpha)) {
        alpha = 0.3;
    }
    alpha = std::clamp(alpha, 1e-3, 1.5);
    std::vector<double> alphas = {alpha, 0.5 * alpha, 2 * alpha};
    std::mt19937_64 rng(o.seed);
    std::uniform_real_distribution<double> log_alpha(std::log(1e-3), std::log(1.0));
    while (static_cast<int>(alphas.size()) < std::max(1, o.starts)) {
        alphas.push_back(std::exp(log_alpha(rng)));
    }
    alphas.resize(std::max(1, o.starts));
    if (o.starts > 1) {
        // A fixed log-spaced ladder over the range of real lobes as well: the width estimate
        // fails when the peak is narrower than the angular grid (only exact mirror samples see
        // it), and scoring a start costs one pass over the small scoring set.
        for (double a = 2e-3; a < 1.2; a *= 2.5) {
            alphas.push_back(a);
        }
    }
    return alphas;
}

/// Turns every anisotropic lobe with a free orientation to phi_deg with its slopes 4:1 apart
/// around a * 3^i (lobe i); false when the model has no such lobe.
bool turn_lobes(ModelD& mc, const ParameterMap& map, double a, double phi_deg) {
    bool turned = false;
    for (int i = 0; i < static_cast<int>(mc.lobes.size()); ++i) {
        const double ai = a * std::pow(3.0, i);
        set_shape(mc, map, i, ai);
        const ScalarParam* ax = find_free(map, Field::kAlphaX, i, -1);
        const ScalarParam* ay = find_free(map, Field::kAlphaY, i, -1);
        const ScalarParam* phi = find_free(map, Field::kOrientation, i, -1);
        if (ax == nullptr || ay == nullptr || phi == nullptr) {
            continue;
        }
        ParameterMap::set(mc, *ax, std::clamp(0.5 * ai, ax->lower, ax->upper));
        ParameterMap::set(mc, *ay, std::clamp(2.0 * ai, ay->lower, ay->upper));
        ParameterMap::set(mc, *phi, std::clamp(phi_deg, phi->lower, phi->upper));
        turned = true;
    }
    return turned;
}

/// Data-driven starts scored by the objective, best first.
std::vector<Candidate> initial_candidates(const ParameterMap& map,
                                          const std::vector<Sample>& score_set,
                                          const PreparedSamples& scorer,
                                          const FitOptions& o) {
    const int threads = thread_count(o.num_threads);
    const LinearWeights lw(score_set, o.relative_floor);
    // A start: the shapes as given, the linear terms solved, scored by the objective.
    auto scored = [&](ModelD mc) {
        linear_init(mc, map, score_set, scorer, lw, threads);
        Candidate c{clamp_start(map, map.values_of(mc)), 0};
        c.cost = objective(scorer, c.x, threads);
        return c;
    };
    ModelD m = map.base();
    std::vector<Candidate> out;
    if (m.lobes.empty()) {
        out.push_back(scored(m));
        return out;
    }
    const Rgbd floor = off_specular_floor(score_set, scorer);
    const std::vector<double> alphas =
        start_alphas(estimate_alpha(score_set, scorer, floor, m.lobes[0].distribution), o);
    for (double a : alphas) {
        ModelD mc = m;
        for (int i = 0; i < static_cast<int>(mc.lobes.size()); ++i) {
            // Further lobes start wider, by a factor of 3 each.
            set_shape(mc, map, i, a * std::pow(3.0, i));
        }
        out.push_back(scored(mc));
    }
    // Anisotropic lobes with a free orientation: starts with the slopes 4:1 apart at four
    // orientations 45 degrees apart, which cover every class of the lobe's symmetries (period
    // 180, quarter turn with alpha_x and alpha_y exchanged) within 22.5 degrees. From equal slopes
    // alone the orientation has no derivative and the solve would find it only by way of the
    // widths.
    for (double a : alphas) {
        for (double phi_deg : {0.0, 45.0, 90.0, 135.0}) {
            ModelD mc = m;
            if (!turn_lobes(mc, map, a, phi_deg)) {
                break;
            }
            out.push_back(scored(mc));
        }
    }
    std::stable_sort(out.begin(), out.end(), [](const Candidate& a, const Candidate& b) {
        return a.cost < b.cost;  // NaN/Inf costs sort last
    });
    return out;
}

}  // namespace

std::vector<Sample> reduce_work(const FitContext& ctx,
                                const std::vector<Sample>& work,
                                std::size_t budget,
                                std::uint64_t seed) {
    if (budget == 0 || budget >= work.size()) {
        return work;
    }
    if (ctx.coords_of != &work || ctx.work_coords.size() != work.size()) {
        ctx.work_coords = stratum_coordinates(work);
        ctx.coords_of = &work;
    }
    return stratified_reduce(work, budget, seed, ctx.work_coords);
}

Expected<std::vector<Candidate>> starting_points(const FitContext& ctx,
                                                 const FitSpec& spec,
                                                 const std::vector<Sample>& work) {
    if (ctx.options.auto_init) {
        // The working set itself when it is not larger (no copy).
        ctx.score_set = &work;
        if (work.size() > kScoreSamples) {
            ctx.score_reduction = reduce_work(ctx, work, kScoreSamples, ctx.options.seed);
            ctx.score_set = &ctx.score_reduction;
        }
        ctx.score_ps = std::make_shared<PreparedSamples>(ctx.map, *ctx.score_set, ctx.cost);
        return initial_candidates(*ctx.map, *ctx.score_set, *ctx.score_ps, ctx.options);
    }
    std::vector<Candidate> candidates;
    candidates.push_back({ctx.map->values_of(spec.model), 0});
    for (int k = 0; k < ctx.map->size(); ++k) {
        const ScalarParam& s = ctx.map->scalars()[ctx.map->free()[k]];
        if (candidates[0].x[k] < s.lower || candidates[0].x[k] > s.upper) {
            return make_error("start value of " + s.name + " = " +
                              std::to_string(candidates[0].x[k]) + " outside its bounds [" +
                              std::to_string(s.lower) + ", " + std::to_string(s.upper) + "]");
        }
    }
    return candidates;
}

std::shared_ptr<PreparedSamples> prepare_work(const FitContext& ctx,
                                              const std::vector<Sample>& work) {
    if (ctx.score_ps && ctx.score_set == &work && ctx.options.loss == LossKind::kNone) {
        return ctx.score_ps;
    }
    return prepare(ctx, work);
}

// A start's raw cost misleads when its width is right but its amplitudes are not (for example a
// narrow lobe under a grid that misses most of its peak), and a full solve from a wrong start ends
// in a local minimum: the tails of a wide lobe standing in for the diffuse term. Hence the short
// solves before the ranking.
void screen_starts(const FitContext& ctx, std::vector<Candidate>& candidates, SolverInfo& solver) {
    const FitOptions& o = ctx.options;
    if (!o.auto_init || candidates.size() <= 1 || o.check_gradients) {
        return;
    }
    const auto since = Clock::now();
    // The scoring set, prepared once: the screen ranks the starts on the samples that scored
    // them (with the fit's robust loss, when it has one, on a preparation of its own).
    const std::vector<Sample>& screen = *ctx.score_set;
    const std::shared_ptr<const PreparedSamples> ps_screen =
        o.loss == LossKind::kNone ? ctx.score_ps : prepare(ctx, screen);
    const std::size_t k = std::min(candidates.size(), kScreenStarts);
    ceres::Solver::Summary last;
    int its = 0;
    for (std::size_t c = 0; c < k; ++c) {
        SolveOutcome s = solve(
            ctx, ps_screen, candidates[c].x, std::min(o.max_iterations, kScreenIterations), 1e-6);
        its += iterations_of(s.summary);
        last = s.summary;
        if (s.summary.IsSolutionUsable() && std::isfinite(s.summary.final_cost) &&
            all_finite(s.x)) {
            candidates[c].x = s.x;
            candidates[c].cost = s.summary.final_cost;
        } else {
            candidates[c].cost = std::numeric_limits<double>::infinity();
        }
    }
    std::stable_sort(candidates.begin(),
                     candidates.begin() + static_cast<long>(k),
                     [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
    record_stage(solver, "screen", screen.size(), last, since, its);
}

}  // namespace gonio::fitting::detail
