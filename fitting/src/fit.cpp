// The fit as a sequence of named stages (fit_stages.h): sample selection, reduction, starts,
// screening, main solve, refinement on all samples, parameters, uncertainties, goodness of fit.

#include "gonio/fitting/fit.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>

#include "fit_stages.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/thread_pool.h"
#include "gonio/brdf/values_below_zero.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/power_iteration.h"
#include "gonio/fitting/prepared_samples.h"
#include "gonio/fitting/reduction.h"

namespace gonio::fitting {

namespace detail {

int thread_count(int requested) {
    return gonio::resolve_threads(requested);
}

Bound at_bound(double value, const ScalarParam& s) {
    const double tol = 1e-9 * std::max(s.upper - s.lower, 1e-300);
    if (value <= s.lower + tol) {
        return Bound::kLower;
    }
    if (value >= s.upper - tol) {
        return Bound::kUpper;
    }
    return Bound::kNone;
}

const char* bound_name(Bound b) {
    switch (b) {
        case Bound::kLower:
            return "lower";
        case Bound::kUpper:
            return "upper";
        case Bound::kNone:
            break;
    }
    return "";
}

}  // namespace detail

namespace {

using brdf::Rgbd;
using brdf::Sample;
using detail::Bound;
using detail::Candidate;
using detail::FitContext;
using detail::SampleKind;
using detail::SolveOutcome;

constexpr std::size_t kMaxRejectedLines = 100;

bool valid_options(const FitOptions& o) {
    return o.starts >= 1 && o.max_iterations >= 1 && o.relative_floor > 0 && o.loss_scale > 0 &&
           o.polish_iterations >= 0 && o.reweight_rounds >= 0;
}

/// Validity: rows rejected while reading plus samples that break the rules now (a dataset built
/// in memory has not been through the reader). Reference re-measurements are counted apart (they
/// are not BRDF samples); saturated samples are left out (their value is only a lower bound).
/// Returns the valid samples (without sigmas unless the fit uses them) and fills the counts: the
/// dataset's own samples when every one is valid and none needs its sigma cleared (no copy of a
/// million samples), else the selection, held in `copy`.
const std::vector<Sample>& select_samples(const brdf::Dataset& data,
                                          const FitOptions& o,
                                          int threads,
                                          SampleCounts& counts,
                                          std::vector<Sample>& copy) {
    std::vector<std::size_t> rejected_lines;
    for (const brdf::RejectedRow& r : data.rejected) {
        rejected_lines.push_back(r.line);
    }
    std::size_t rejected_here = 0;
    // (wi.z = cos theta_i.)
    std::vector<SampleKind> kind(data.samples.size(), SampleKind::kValid);
    const bool keep_sigma = o.use_sigma && data.has_sigma;
    // Set when a sample is left out or loses its sigma: the selection then differs from the input.
    std::atomic<bool> differs{false};
    // Values below zero within their noise are kept (brdf/values_below_zero.h).
    const double noise = brdf::implied_noise(data.samples);
    parallel_ranges(data.samples.size(), threads, [&](std::size_t, std::size_t b, std::size_t e) {
        bool changed = false;
        for (std::size_t i = b; i < e; ++i) {
            const Sample& s = data.samples[i];
            if (!brdf::validate_sample(s, brdf::below_zero_allowance(s, noise)).empty() ||
                !(std::cos(s.theta_i) > 0) || !(std::cos(s.theta_o) > 0) ||
                !(s.value.maxCoeff() <= brdf::kMaxSampleValue) ||
                !(s.sigma.maxCoeff() <= brdf::kMaxSampleValue)) {
                kind[i] = SampleKind::kInvalid;
            } else if ((s.flags & brdf::kFlagReference) != 0) {
                kind[i] = SampleKind::kReference;
            } else if ((s.flags & brdf::kFlagSaturated) != 0) {
                kind[i] = SampleKind::kSaturated;
            }
            changed = changed || kind[i] != SampleKind::kValid ||
                      (!keep_sigma && !(s.sigma == Rgbd::Zero()).all());
        }
        if (changed) {
            differs.store(true, std::memory_order_relaxed);
        }
    });
    const bool alias = !differs.load(std::memory_order_relaxed);
    if (!alias) {
        reserve_huge(copy, data.samples.size());
    }
    std::vector<Sample>& valid = copy;
    std::size_t n_valid = 0;
    for (std::size_t i = 0; i < data.samples.size(); ++i) {
        const Sample& s = data.samples[i];
        switch (kind[i]) {
            case SampleKind::kInvalid:
                ++rejected_here;
                rejected_lines.push_back(s.line != 0 ? s.line : i + 1);
                break;
            case SampleKind::kReference:
                ++counts.reference;
                break;
            case SampleKind::kSaturated:
                ++counts.saturated;
                break;
            case SampleKind::kValid:
                ++n_valid;
                if (!alias) {
                    valid.push_back(s);
                    if (!keep_sigma) {
                        valid.back().sigma = Rgbd::Zero();
                    }
                }
                break;
        }
    }
    std::sort(rejected_lines.begin(), rejected_lines.end());
    counts.input = data.samples.size() + data.rejected.size();
    counts.valid = n_valid;
    counts.rejected = data.rejected.size() + rejected_here;
    rejected_lines.resize(std::min(rejected_lines.size(), kMaxRejectedLines));
    counts.rejected_lines = rejected_lines;
    return alias ? data.samples : copy;
}

/// The fitted parameters of x (free and fixed, in report order), each free one's bound if it
/// ended on one; `on_bound[k]` for free scalar k, and the report's "at_bounds" lines.
void collect_parameters(const ParameterMap& map,
                        const std::vector<double>& x,
                        FitResult& result,
                        std::vector<bool>& on_bound) {
    result.model = map.model<double>(x.data());
    on_bound.assign(map.size(), false);
    for (const ScalarParam& s : map.scalars()) {
        FittedParameter p;
        p.name = s.name;
        p.value = map.value_of(result.model, s);
        p.free = s.free;
        result.parameters.push_back(p);
    }
    for (FittedParameter& p : result.parameters) {
        for (int k = 0; k < map.size(); ++k) {
            const ScalarParam& s = map.scalars()[map.free()[k]];
            if (s.name != p.name) {
                continue;
            }
            const Bound b = detail::at_bound(p.value, s);
            if (b == Bound::kNone) {
                continue;
            }
            p.at_bound = detail::bound_name(b);
            on_bound[k] = true;
            char buf[64];
            std::snprintf(buf, sizeof buf, "%.6g", b == Bound::kLower ? s.lower : s.upper);
            result.at_bounds.push_back(p.name + " (" + p.at_bound + " bound " + buf + ")");
        }
    }
}

/// Brings every anisotropic lobe with a free orientation to its canonical form, which describes
/// the same lobe (brdf/lobe_orientation.h): alpha_x <= alpha_y (by the quarter-turn symmetry,
/// when both slopes are free within the same bounds: they are exchanged and the orientation
/// turned by 90 degrees), then the orientation in [0, 180) (by the period; when that value lies
/// within the orientation's bounds). The lobe's x axis is then the direction of its smaller
/// slopes: the brushing direction of a brushed metal, whose grooves run along it.
void canonical_orientations(const ParameterMap& map, std::vector<double>& x) {
    auto free_index = [&](Field f, int lobe) {
        for (int k = 0; k < map.size(); ++k) {
            const ScalarParam& s = map.scalars()[map.free()[k]];
            if (s.field == f && s.lobe == lobe) {
                return k;
            }
        }
        return -1;
    };
    for (int l = 0; l < static_cast<int>(map.base().lobes.size()); ++l) {
        const int ko = free_index(Field::kOrientation, l);
        if (ko < 0) {
            continue;
        }
        const ScalarParam& so = map.scalars()[map.free()[ko]];
        const int kx = free_index(Field::kAlphaX, l);
        const int ky = free_index(Field::kAlphaY, l);
        double phi = x[ko];
        if (kx >= 0 && ky >= 0) {
            const ScalarParam& sx = map.scalars()[map.free()[kx]];
            const ScalarParam& sy = map.scalars()[map.free()[ky]];
            if (x[kx] > x[ky] && sx.lower == sy.lower && sx.upper == sy.upper) {
                std::swap(x[kx], x[ky]);
                phi += 90;
            }
        }
        phi -= 180 * std::floor(phi / 180);
        if (phi >= 180) {
            // Rounding of a value just below a multiple of 180.
            phi = 0;
        }
        if (phi >= so.lower && phi <= so.upper) {
            x[ko] = phi;
        }
    }
}

}  // namespace

std::vector<std::string> parameter_names(const FitSpec& spec) {
    std::vector<std::string> out;
    Expected<ParameterMap> map = ParameterMap::make(spec);
    if (map) {
        for (const ScalarParam& s : map->scalars()) {
            out.push_back(s.name);
        }
    }
    return out;
}

Expected<FitResult> fit(const brdf::Dataset& data, const FitSpec& spec) {
    const auto t0 = detail::Clock::now();
    const FitOptions& o = spec.options;
    Expected<ParameterMap> map_or = ParameterMap::make(spec);
    if (!map_or) {
        return make_error(map_or.error().message);
    }
    if (!valid_options(o)) {
        return make_error(
            "fit options: starts >= 1, max_iterations >= 1, relative_floor > 0, loss_scale > 0, "
            "polish_iterations >= 0 and reweight_rounds >= 0 are required");
    }
    FitContext ctx{
        o, std::make_shared<const ParameterMap>(*map_or), {}, 0, {}, nullptr, nullptr, nullptr, {}};
    ctx.threads = detail::thread_count(o.num_threads);
    ctx.cost.residual = o.residual;
    ctx.cost.relative_floor = o.relative_floor;
    ctx.cost.use_sigma = o.use_sigma && data.has_sigma;
    FitResult result;
    result.data = data.source;
    result.residual = o.residual;
    result.loss = o.loss;

    // Samples: the valid ones; the solve's (an optional stratified reduction to max_samples;
    // without one the solve works on `valid` itself, no copy of a million samples); and the working
    // set of the starts and the main solve: coarse to fine, on a large input a stratified reduction
    // to coarse_samples (weights keep each stratum's sum), the result then polished on all samples.
    std::vector<Sample> valid_copy;
    const std::vector<Sample>& valid =
        select_samples(data, o, ctx.threads, result.samples, valid_copy);
    if (valid.empty()) {
        // The first sample's own reason, so that a whole input in degrees says so.
        std::string first;
        for (std::size_t i = 0; i < data.samples.size() && first.empty(); ++i) {
            if (const std::string r = brdf::validate_sample(data.samples[i]); !r.empty()) {
                first = "; sample " + std::to_string(i + 1) + ": " + r;
            }
        }
        return make_error(data.source + ": no valid sample to fit (" +
                          std::to_string(result.samples.rejected) + " rejected, " +
                          std::to_string(result.samples.reference) + " reference, " +
                          std::to_string(result.samples.saturated) + " saturated)" + first);
    }
    const std::vector<Sample> reduced = o.max_samples > 0 && o.max_samples < valid.size()
                                            ? stratified_reduce(valid, o.max_samples, o.seed)
                                            : std::vector<Sample>{};
    const std::vector<Sample>& used = reduced.empty() ? valid : reduced;
    result.samples.used = used.size();
    // The coarse set's stratum coordinates are those of its samples in `used`: the scoring set's
    // reduction of the working set needs no transform of its own.
    std::vector<std::size_t> coarse_of;
    const std::vector<Sample> coarse = [&] {
        if (o.coarse_samples == 0 || used.size() <= 2 * o.coarse_samples) {
            return std::vector<Sample>{};
        }
        const std::vector<StratumCoords> coords = stratum_coordinates(used);
        std::vector<Sample> out =
            stratified_reduce(used, o.coarse_samples, o.seed + 1, coords, &coarse_of);
        ctx.work_coords.resize(coarse_of.size());
        for (std::size_t i = 0; i < coarse_of.size(); ++i) {
            ctx.work_coords[i] = coords[coarse_of[i]];
        }
        return out;
    }();
    if (!coarse.empty()) {
        ctx.coords_of = &coarse;
    }
    const std::vector<Sample>& work = coarse.empty() ? used : coarse;

    // Starts, screening, main solve, refinement on all samples.
    Expected<std::vector<Candidate>> candidates = detail::starting_points(ctx, spec, work);
    if (!candidates) {
        return make_error(candidates.error().message);
    }
    result.solver.starts = static_cast<int>(candidates->size());
    const auto t_solve = detail::Clock::now();
    detail::screen_starts(ctx, *candidates, result.solver);
    const auto ps_work = detail::prepare_work(ctx, work);
    SolveOutcome best = detail::main_solve(
        ctx, ps_work, work, *candidates, coarse.empty() ? "solve" : "reduced", result.solver);
    const bool converged = best.summary.termination_type == ceres::CONVERGENCE;
    result.solver.initial_cost = best.summary.initial_cost;
    result.solver.termination = ceres::TerminationTypeToString(best.summary.termination_type);
    result.solver.message = best.summary.message;
    std::shared_ptr<PreparedSamples> ps_used = coarse.empty() ? ps_work : nullptr;
    if (converged) {
        detail::refine(ctx, used, !coarse.empty(), ps_used, best, result.solver);
    }
    result.solver.solve_time_s =
        std::chrono::duration<double>(detail::Clock::now() - t_solve).count();
    result.solver.final_cost = best.summary.final_cost;
    const bool finite = detail::all_finite(best.x);
    result.solver.converged = converged && finite;
    if (!finite) {
        result.solver.message += " (non-finite parameter values)";
    }

    // Parameters (on a bound or not), lobes the fit has dropped, uncertainties, goodness of fit.
    std::vector<bool> on_bound;
    canonical_orientations(*ctx.map, best.x);
    collect_parameters(*ctx.map, best.x, result, on_bound);
    result.vanished_lobes = detail::vanished_lobes(result.model, work, ps_work.get());
    std::optional<double> chi2;
    if (result.solver.converged && o.covariance) {
        if (!ps_used) {
            ps_used = detail::prepare(ctx, used);
        }
        detail::uncertainties(*ps_used,
                              ctx.threads,
                              best.x,
                              ctx.cost.use_sigma,
                              on_bound,
                              result.parameters,
                              result.not_identifiable,
                              &chi2,
                              &result.covariance);
        result.covariance_method =
            ctx.cost.use_sigma
                ? "inverse J^T J of the residuals normalised by relative sigmas reweighted at the "
                  "model (IRLS), scaled by max(1, reduced chi-square)"
                : "sandwich H^-1 M H^-1 (heteroscedasticity-consistent, HC0; no sigma columns)";
    }
    // On all valid samples: from the prepared ones when they are those (no reduction).
    result.metrics =
        ps_used && reduced.empty()
            ? detail::evaluate_metrics(result.model, valid, o.relative_floor, *ps_used, ctx.threads)
            : evaluate_metrics(result.model, valid, o.relative_floor);
    // (An f0 fitted per channel: its parameters are named lobes[i].fresnel.f0[c].)
    const bool f0_per_channel =
        std::any_of(result.parameters.begin(), result.parameters.end(), [](const auto& p) {
            return p.free && p.name.find(".fresnel.f0[") != std::string::npos;
        });
    result.goodness =
        detail::judge(result.metrics, chi2, valid.size(), result.model, f0_per_channel);
    result.solver.usable = result.solver.converged && result.goodness.represents;
    result.solver.wall_time_s = std::chrono::duration<double>(detail::Clock::now() - t0).count();
    return result;
}

std::vector<std::pair<std::string, FitSpec>> auto_candidates(const FitOptions& options) {
    std::vector<std::pair<std::string, FitSpec>> out;
    const std::pair<const char*, brdf::Distribution> families[] = {
        {"ggx", brdf::Distribution::kGgx},
        {"beckmann", brdf::Distribution::kBeckmann},
        {"blinn-phong", brdf::Distribution::kBlinnPhong},
        {"student-t", brdf::Distribution::kStudentT},
    };
    for (int lobes : {1, 2}) {
        for (const auto& [name, dist] : families) {
            if (lobes == 2 && dist != brdf::Distribution::kGgx &&
                dist != brdf::Distribution::kStudentT) {
                continue;
            }
            ModelOptions mo;
            mo.distribution = dist;
            mo.lobes = lobes;
            Expected<FitSpec> spec = make_fit_spec(mo);
            if (!spec) {
                continue;
            }
            spec->options = options;
            out.emplace_back(std::string(name) + (lobes == 2 ? " x2" : ""), *spec);
        }
    }
    ModelOptions tab;
    tab.distribution = brdf::Distribution::kTabulated;
    if (Expected<FitSpec> spec = make_fit_spec(tab)) {
        spec->options = options;
        out.emplace_back("tabulated", *spec);
    }
    return out;
}

namespace {

/// The smallest gain in log RMSE (channel mean, on the ranking set) for which the RGB-roughness
/// variant may replace the winner: below it the difference is rounding in noise-free data, far
/// below the noise of any measurement (2 % noise alone gives 0.02).
constexpr double kMinRgbRoughnessGain = 1e-4;

/// Samples of the stratified set on which the candidates of an automatic choice are fitted and
/// ranked. Every candidate's fit costs in proportion to its samples; 2000 strata-balanced samples
/// keep the specular peak's share (the reduction's strata are sqrt-spaced in theta_h).
constexpr std::size_t kRankSamples = 2000;

/// Ratio of the half-maximum points of GGX and Beckmann in units of alpha (initialisation.cpp,
/// estimate_alpha): a Beckmann lobe as wide as a GGX lobe of slope alpha has 0.773 alpha.
constexpr double kBeckmannPerGgxAlpha = 0.6436 / 0.8326;

/// The spec with one slope parameter per channel in every lobe (Lobe::rgb_roughness), when
/// every lobe is an isotropic ggx, beckmann or student-t one whose alpha the spec fits; else
/// empty.
std::optional<FitSpec> with_rgb_roughness(const FitSpec& spec) {
    FitSpec out = spec;
    if (out.model.lobes.empty()) {
        return std::nullopt;
    }
    for (brdf::Lobe<double>& l : out.model.lobes) {
        const bool analytic = l.distribution == brdf::Distribution::kGgx ||
                              l.distribution == brdf::Distribution::kBeckmann ||
                              l.distribution == brdf::Distribution::kStudentT;
        if (!analytic || l.anisotropic || l.rgb_roughness) {
            return std::nullopt;
        }
        l.rgb_roughness = true;
        l.alpha_rgb = Rgbd::Constant(l.alpha_x);
    }
    bool any = false;
    for (ParamSpec& p : out.params) {
        if (p.field == Field::kAlphaX) {
            p.field = Field::kAlphaRgb;
            p.shared = false;
            any = any || p.free;
        }
    }
    if (!any) {
        return std::nullopt;
    }
    return out;
}

/// Whether `m` can seed the other candidates: one isotropic GGX lobe with a single alpha.
bool seeds_candidates(const brdf::ModelD& m) {
    return m.lobes.size() == 1 && m.lobes[0].distribution == brdf::Distribution::kGgx &&
           !m.lobes[0].anisotropic && !m.lobes[0].rgb_roughness;
}

/// A shared start: the candidate `spec` started from the fitted GGX model `ref` (one lobe): the
/// same diffuse albedo, Fresnel f0 and scale; the width mapped so that the half-maximum of D
/// stays where the data put it (Beckmann 0.773 alpha, Blinn-Phong e = 2 / alpha_B^2 - 2,
/// Student-t at gamma = 2, which is GGX itself); further lobes 3x wider each at a tenth of the
/// scale, as the data-driven starts place them. Every free value is brought inside its bounds.
/// A single start (no multi-start, no screening): `ref` is already near the optimum.
FitSpec started_from(FitSpec spec, const brdf::ModelD& ref) {
    const brdf::Lobe<double>& r = ref.lobes[0];
    brdf::ModelD& m = spec.model;
    if (m.has_diffuse && ref.has_diffuse) {
        m.diffuse = ref.diffuse;
    }
    for (std::size_t i = 0; i < m.lobes.size(); ++i) {
        brdf::Lobe<double>& l = m.lobes[i];
        const double alpha = r.alpha_x * std::pow(3.0, static_cast<double>(i));
        const double alpha_b = alpha * kBeckmannPerGgxAlpha;
        switch (l.distribution) {
            case brdf::Distribution::kBeckmann:
                l.alpha_x = l.alpha_y = alpha_b;
                break;
            case brdf::Distribution::kBlinnPhong:
                l.exponent = 2 / (alpha_b * alpha_b) - 2;
                break;
            case brdf::Distribution::kStudentT:
                l.gamma = 2;
                l.alpha_x = l.alpha_y = alpha;
                break;
            default:
                l.alpha_x = l.alpha_y = alpha;
                break;
        }
        l.alpha_rgb = Rgbd::Constant(l.alpha_x);
        if (l.fresnel.type == brdf::FresnelType::kSchlick &&
            r.fresnel.type == brdf::FresnelType::kSchlick) {
            l.fresnel.f0 = r.fresnel.f0;
        }
        l.scale = r.scale * (i == 0 ? 1.0 : 0.1);
    }
    Expected<ParameterMap> map = ParameterMap::make(spec);
    if (map) {
        for (const ScalarParam& s : map->scalars()) {
            if (s.free) {
                ParameterMap::set(m, s, std::clamp(map->value_of(m, s), s.lower, s.upper));
            }
        }
    }
    spec.options.auto_init = false;
    spec.options.starts = 1;
    return spec;
}

/// A spec that continues from the fitted model `m` (single start).
FitSpec continued_from(FitSpec spec, const brdf::ModelD& m) {
    spec.model = m;
    spec.options.auto_init = false;
    spec.options.starts = 1;
    return spec;
}

/// One candidate fitted on the ranking set and its standing.
struct RankedFit {
    RankedModel rank;
    brdf::ModelD model;  ///< Its fitted model (the start of the polish if it wins).
};

/// Fits one candidate on the ranking set (no polish, no covariance, log residual) and scores it
/// by BIC; empty with `error` set when the fit could not run. `total_weight` is the sum of the
/// ranking samples' weights (a stratified reduction's weights sum to the samples it stands for).
std::optional<RankedFit> rank_candidate(const brdf::Dataset& ranking,
                                        double total_weight,
                                        const std::string& name,
                                        FitSpec spec,
                                        std::string* error) {
    spec.options.polish_iterations = 0;
    spec.options.reweight_rounds = 0;
    spec.options.covariance = false;
    spec.options.residual = ResidualForm::kLog;
    Expected<FitResult> r = fit_any(ranking, spec);
    if (!r) {
        *error = name + ": " + r.error().message;
        return std::nullopt;
    }
    RankedFit out;
    out.model = r->model;
    RankedModel& rm = out.rank;
    rm.name = name;
    rm.converged = r->solver.converged;
    int p = 0;
    for (const FittedParameter& fp : r->parameters) {
        p += fp.free ? 1 : 0;
    }
    // A table's nodes are parameters estimated from the data too.
    p += table_nodes(r->model);
    rm.parameters = p;
    rm.log_rmse = r->metrics.log_rmse.mean();
    // RSS on the samples of the last solve: final_cost = RSS / 2 with the samples' weights, which
    // sum to the number of samples they stand for: normalise to the solve's size. (The ranking
    // set is at most twice FitOptions::coarse_samples, so the solve is on all of it.)
    const std::size_t n_red =
        r->solver.stages.empty() ? r->samples.used : r->solver.stages.back().samples;
    const double n = 3.0 * static_cast<double>(n_red);
    const double rss = total_weight > 0
                           ? 2 * r->solver.final_cost * static_cast<double>(n_red) / total_weight
                           : 0.0;
    // Residuals at rounding level carry no information: below 1e-12 per residual (log units; the
    // arithmetic's own rounding is near 1e-16) the RSS is held at that floor, so that among models
    // that all reproduce the data to rounding the fewest parameters win, not the luckiest rounding.
    constexpr double kResidualFloor = 1e-12;
    const double rss_floor = n * kResidualFloor * kResidualFloor;
    rm.criterion = rss >= 0 ? n * std::log(std::max(rss, rss_floor) / n) + p * std::log(n)
                            : std::numeric_limits<double>::infinity();
    return out;
}

}  // namespace

Expected<AutoFitResult> fit_auto(const brdf::Dataset& data,
                                 const std::vector<std::pair<std::string, FitSpec>>& candidates) {
    AutoFitResult out;
    out.criterion =
        "BIC = n log(RSS/n) + p log(n) of the log residuals on a stratified set of at most " +
        std::to_string(kRankSamples) +
        " samples (n = 3 x samples, p = free parameters); lower is better";
    if (candidates.empty()) {
        return make_error("--model auto: no candidate");
    }
    const FitOptions& o0 = candidates.front().second.options;
    // The first candidate (the default family) fitted in full on all samples: the result when it
    // wins, and the start that every other candidate shares.
    Expected<FitResult> reference = fit_any(data, candidates.front().second);
    if (!reference) {
        return make_error("--model auto: " + candidates.front().first + ": " +
                          reference.error().message);
    }
    const bool shared_start = reference->solver.converged && seeds_candidates(reference->model);

    // The ranking set: a stratified reduction of the valid samples (their weights kept, so the
    // objective estimates the one on all samples).
    SampleCounts counts;
    std::vector<Sample> valid_copy;
    const std::vector<Sample>& valid =
        select_samples(data, o0, detail::thread_count(o0.num_threads), counts, valid_copy);
    brdf::Dataset ranking;
    ranking.source = data.source;
    ranking.has_sigma = data.has_sigma;
    ranking.samples = stratified_reduce(valid, kRankSamples, o0.seed + 3);
    double total_weight = 0;
    for (const Sample& s : ranking.samples) {
        total_weight += s.weight;
    }

    std::vector<RankedFit> fits;
    std::vector<std::size_t> spec_of;  // index into candidates (or candidates.size(): the RGB one)
    std::string first_error;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        const FitSpec& spec = candidates[i].second;
        // The reference continues from its own optimum; the analytic candidates start from it;
        // a tabulated one extracts its table from the ranking set; without a reference to share,
        // each uses its own data-driven starts.
        FitSpec start = spec;
        if (shared_start && !needs_power_iteration(spec)) {
            start = i == 0 ? continued_from(spec, reference->model)
                           : started_from(spec, reference->model);
        }
        std::string error;
        std::optional<RankedFit> rf =
            rank_candidate(ranking, total_weight, candidates[i].first, start, &error);
        if (!rf) {
            if (first_error.empty()) {
                first_error = error;
            }
            continue;
        }
        fits.push_back(std::move(*rf));
        spec_of.push_back(i);
    }
    std::size_t win = fits.size();
    for (std::size_t k = 0; k < fits.size(); ++k) {
        if (fits[k].rank.converged &&
            (win == fits.size() || fits[k].rank.criterion < fits[win].rank.criterion)) {
            win = k;
        }
    }
    if (win == fits.size()) {
        return make_error("--model auto: no candidate converged" +
                          (first_error.empty() ? std::string() : " (" + first_error + ")"));
    }
    FitSpec chosen_spec = candidates[spec_of[win]].second;
    std::string chosen = candidates[spec_of[win]].first;
    brdf::ModelD chosen_model = fits[win].model;
    bool chosen_is_reference = spec_of[win] == 0;
    // RGB-varying roughness as a refinement of the winner: its structure with one alpha per
    // channel, fitted on the ranking set from the winner's optimum, replaces it when BIC prefers
    // it and the log RMSE drops by at least kMinRgbRoughnessGain. One more fit of one structure
    // instead of doubling the candidates.
    if (std::optional<FitSpec> rgb = with_rgb_roughness(chosen_spec)) {
        brdf::ModelD start = chosen_model;
        for (brdf::Lobe<double>& l : start.lobes) {
            l.rgb_roughness = true;
            l.alpha_rgb = Rgbd::Constant(l.alpha_x);
        }
        std::string error;
        const std::string name = chosen + " rgb-roughness";
        std::optional<RankedFit> rf =
            rank_candidate(ranking, total_weight, name, continued_from(*rgb, start), &error);
        if (rf) {
            const RankedModel& w = fits[win].rank;
            const bool better = rf->rank.converged && rf->rank.criterion < w.criterion &&
                                w.log_rmse - rf->rank.log_rmse >= kMinRgbRoughnessGain;
            // Listed in the ranking unless it ranks above the winner by BIC without the gain
            // (noise-free data, where RSS is rounding): the ranking stays ordered, chosen first.
            if (better || !(rf->rank.criterion < w.criterion)) {
                fits.push_back(*rf);
                spec_of.push_back(candidates.size());
            }
            if (better) {
                chosen = name;
                chosen_spec = *rgb;
                chosen_model = rf->model;
                chosen_is_reference = false;
            }
        }
    }
    for (const RankedFit& f : fits) {
        out.ranking.push_back(f.rank);
    }
    std::sort(
        out.ranking.begin(), out.ranking.end(), [](const RankedModel& a, const RankedModel& b) {
            if (a.converged != b.converged) {
                return a.converged;
            }
            return a.criterion < b.criterion;
        });
    out.chosen = chosen;
    // The winner on all samples: the reference fit itself, or a polish from the ranking optimum
    // (a tabulated winner extracts its table again from all samples).
    if (chosen_is_reference) {
        out.best = *reference;
        return out;
    }
    Expected<FitResult> best = needs_power_iteration(chosen_spec) || !shared_start
                                   ? fit_any(data, chosen_spec)
                                   : fit(data, continued_from(chosen_spec, chosen_model));
    if (!best) {
        return make_error(out.chosen + ": " + best.error().message);
    }
    out.best = *best;
    return out;
}

}  // namespace gonio::fitting
