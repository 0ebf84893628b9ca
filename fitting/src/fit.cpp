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
#include "gonio/fitting/exposure_paths.h"
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

namespace {

/// The samples of a fit: the valid ones (the dataset's own when every one is, else `valid_copy`),
/// the solve's (`used`: an optional stratified reduction to max_samples; without one `valid`
/// itself, no copy of a million samples) and the working set of the starts and the main solve
/// (`work`: coarse to fine, on a large input a stratified reduction of `used` to coarse_samples
/// whose weights keep each stratum's sum; the result is then polished on `used`). Neither copied
/// nor moved: its pointers point into itself.
struct FitSamples {
    std::vector<Sample> valid_copy;
    const std::vector<Sample>* valid = nullptr;
    std::vector<Sample> reduced;
    const std::vector<Sample>* used = nullptr;
    std::vector<Sample> coarse;
    const std::vector<Sample>* work = nullptr;

    FitSamples() = default;
    FitSamples(const FitSamples&) = delete;
    FitSamples& operator=(const FitSamples&) = delete;
};

/// The error of an input without a valid sample, with the first sample's own reason, so that a
/// whole input in degrees says so.
std::string no_valid_sample(const brdf::Dataset& data, const SampleCounts& counts) {
    std::string first;
    for (std::size_t i = 0; i < data.samples.size() && first.empty(); ++i) {
        if (const std::string r = brdf::validate_sample(data.samples[i]); !r.empty()) {
            first = "; sample " + std::to_string(i + 1) + ": " + r;
        }
    }
    return data.source + ": no valid sample to fit (" + std::to_string(counts.rejected) +
           " rejected, " + std::to_string(counts.reference) + " reference, " +
           std::to_string(counts.saturated) + " saturated)" + first;
}

/// Fills `s` (FitSamples) and result.samples; the working set's stratum coordinates are kept in
/// `ctx` (those of its samples in `used`: the scoring set's reduction of the working set needs no
/// transform of its own). Error when no sample is valid.
Expected<void> select_fit_samples(const brdf::Dataset& data,
                                  FitContext& ctx,
                                  FitSamples& s,
                                  FitResult& result) {
    const FitOptions& o = ctx.options;
    s.valid = &select_samples(data, o, ctx.threads, result.samples, s.valid_copy);
    if (s.valid->empty()) {
        return make_error(no_valid_sample(data, result.samples));
    }
    if (o.max_samples > 0 && o.max_samples < s.valid->size()) {
        s.reduced = stratified_reduce(*s.valid, o.max_samples, o.seed);
    }
    s.used = s.reduced.empty() ? s.valid : &s.reduced;
    result.samples.used = s.used->size();
    s.work = s.used;
    if (o.coarse_samples == 0 || s.used->size() <= 2 * o.coarse_samples) {
        return {};
    }
    const std::vector<StratumCoords> coords = stratum_coordinates(*s.used);
    std::vector<std::size_t> coarse_of;
    s.coarse = stratified_reduce(*s.used, o.coarse_samples, o.seed + 1, coords, &coarse_of);
    ctx.work_coords.resize(coarse_of.size());
    for (std::size_t i = 0; i < coarse_of.size(); ++i) {
        ctx.work_coords[i] = coords[coarse_of[i]];
    }
    ctx.coords_of = &s.coarse;
    s.work = &s.coarse;
    return {};
}

/// Starts, screening, main solve and refinement on all samples; fills the solver record.
/// `ps_work`: the working set prepared; `ps_used`: the solve's samples prepared, when they were.
Expected<SolveOutcome> run_solves(const FitContext& ctx,
                                  const FitSpec& spec,
                                  const FitSamples& s,
                                  std::shared_ptr<PreparedSamples>& ps_work,
                                  std::shared_ptr<PreparedSamples>& ps_used,
                                  SolverInfo& solver) {
    Expected<std::vector<Candidate>> candidates = detail::starting_points(ctx, spec, *s.work);
    if (!candidates) {
        return make_error(candidates.error().message);
    }
    solver.starts = static_cast<int>(candidates->size());
    const auto t_solve = detail::Clock::now();
    detail::screen_starts(ctx, *candidates, solver);
    ps_work = detail::prepare_work(ctx, *s.work);
    const bool coarse = !s.coarse.empty();
    SolveOutcome best = detail::main_solve(
        ctx, ps_work, *s.work, *candidates, coarse ? "reduced" : "solve", solver);
    const bool converged = best.summary.termination_type == ceres::CONVERGENCE;
    solver.initial_cost = best.summary.initial_cost;
    solver.termination = ceres::TerminationTypeToString(best.summary.termination_type);
    solver.message = best.summary.message;
    ps_used = coarse ? nullptr : ps_work;
    if (converged) {
        detail::refine(ctx, *s.used, coarse, ps_used, best, solver);
    }
    solver.solve_time_s = std::chrono::duration<double>(detail::Clock::now() - t_solve).count();
    solver.final_cost = best.summary.final_cost;
    const bool finite = detail::all_finite(best.x);
    solver.converged = converged && finite;
    if (!finite) {
        solver.message += " (non-finite parameter values)";
    }
    return best;
}

/// Parameters (on a bound or not), lobes the fit has dropped, uncertainties, metrics on all valid
/// samples and the goodness of fit of the solution `best`.
void judge_solution(const FitContext& ctx,
                    const FitSamples& s,
                    SolveOutcome& best,
                    const std::shared_ptr<PreparedSamples>& ps_work,
                    std::shared_ptr<PreparedSamples>& ps_used,
                    FitResult& result) {
    const FitOptions& o = ctx.options;
    std::vector<bool> on_bound;
    canonical_orientations(*ctx.map, best.x);
    collect_parameters(*ctx.map, best.x, result, on_bound);
    result.vanished_lobes = detail::vanished_lobes(result.model, *s.work, ps_work.get());
    std::optional<double> chi2;
    if (result.solver.converged && o.covariance) {
        if (!ps_used) {
            ps_used = detail::prepare(ctx, *s.used);
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
    const std::vector<Sample>& valid = *s.valid;
    result.metrics =
        ps_used && s.reduced.empty()
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
}

}  // namespace

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
    FitSamples samples;
    if (auto selected = select_fit_samples(data, ctx, samples, result); !selected) {
        return make_error(selected.error().message);
    }
    std::shared_ptr<PreparedSamples> ps_work;
    std::shared_ptr<PreparedSamples> ps_used;
    Expected<SolveOutcome> best = run_solves(ctx, spec, samples, ps_work, ps_used, result.solver);
    if (!best) {
        return make_error(best.error().message);
    }
    judge_solution(ctx, samples, *best, ps_work, ps_used, result);
    result.solver.wall_time_s = std::chrono::duration<double>(detail::Clock::now() - t0).count();
    return result;
}

std::string format_auto_choice(const AutoChoice& choice) {
    std::string out = "model auto: " + choice.criterion + "\n";
    char line[256];
    std::snprintf(line,
                  sizeof line,
                  "%-4s %-26s %6s %12s %16s\n",
                  "rank",
                  "model",
                  "params",
                  "log_rmse",
                  "BIC");
    out += line;
    for (std::size_t i = 0; i < choice.ranking.size(); ++i) {
        const RankedModel& m = choice.ranking[i];
        std::snprintf(line,
                      sizeof line,
                      "%-4zu %-26s %6d %12.6g %16.8g%s\n",
                      i + 1,
                      m.name.c_str(),
                      m.parameters,
                      m.log_rmse,
                      m.criterion,
                      m.converged ? "" : "  (did not converge)");
        out += line;
    }
    if (!choice.rejected.empty()) {
        out += "not fitted (a second lobe did not pay for ggx):";
        for (const std::string& r : choice.rejected) {
            out += " " + r;
        }
        out += "\n";
    }
    return out + "chosen: " + choice.chosen + "\n";
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
    // V-groove shadowing (Cook and Torrance 1982) with the two families whose slopes it was
    // written for: measured plastics and paints follow it where Smith's G falls off too early.
    for (const auto& [name, dist] :
         {std::pair<const char*, brdf::Distribution>{"ggx v-groove", brdf::Distribution::kGgx},
          {"beckmann v-groove", brdf::Distribution::kBeckmann}}) {
        ModelOptions mo;
        mo.distribution = dist;
        mo.shadowing = brdf::Shadowing::kVGroove;
        if (Expected<FitSpec> spec = make_fit_spec(mo)) {
            spec->options = options;
            out.emplace_back(name, *spec);
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

/// Samples of the stratified set on which the candidates of an automatic choice are fitted:
/// every candidate's fit costs in proportion to its samples; 1000 strata-balanced samples keep
/// the specular peak's share (the reduction's strata are sqrt-spaced in theta_h).
constexpr std::size_t kRankSamples = 1000;

/// Samples on which the candidates are scored: all valid samples up to twice this many, else a
/// stratified reduction to it whose weights stand for all of them (the criterion's RSS is then
/// an unbiased estimate of the one on all valid samples).
constexpr std::size_t kScoreSamples = 4000;

/// Bound on the iterations of each candidate's solve on the ranking set: from a shared start the
/// ranking needs the candidates' standing, not their last digits (the winner is then fitted to
/// convergence on all samples).
constexpr int kRankIterations = 40;

/// Bound on the iterations of a candidate with a second lobe (which starts where its family's
/// one lobe ended, rank_all) or a Student-t lobe (whose iterations cost as much as those of every
/// other candidate together: its Lambda is a continued fraction). A Student-t lobe started at
/// GGX (gamma = 2) creeps along its tail gamma; after 20 iterations its criterion lies within 1
/// of the one after 40 on the demo material, the three RGL files and 30,000 samples of the red
/// plastic (no choice changes); after 12, paper's choice changes.
constexpr int kRankIterationsCostly = 20;

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

/// `spec` from its model's values, brought inside the bounds of its free parameters, with a single
/// start (no multi-start, no data-driven start).
FitSpec single_start_within_bounds(FitSpec spec) {
    brdf::ModelD& m = spec.model;
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
    return single_start_within_bounds(std::move(spec));
}

/// A two-lobe candidate started from the fitted one-lobe model `one` of its family: the first
/// lobe as fitted, the second 3x wider at a tenth of its scale (single start, every free value
/// brought inside its bounds). Nested this way, the pair starts where one lobe ended.
FitSpec with_second_lobe(FitSpec spec, const brdf::ModelD& one) {
    brdf::ModelD& m = spec.model;
    if (m.has_diffuse && one.has_diffuse) {
        m.diffuse = one.diffuse;
    }
    m.lobes[0] = one.lobes[0];
    brdf::Lobe<double> wide = one.lobes[0];
    wide.alpha_x *= 3;
    wide.alpha_y *= 3;
    wide.alpha_rgb *= 3;
    wide.scale *= 0.1;
    m.lobes[1] = wide;
    return single_start_within_bounds(std::move(spec));
}

/// A spec that continues from the fitted model `m` (single start).
FitSpec continued_from(FitSpec spec, const brdf::ModelD& m) {
    spec.model = m;
    spec.options.auto_init = false;
    spec.options.starts = 1;
    return spec;
}

/// The samples of an automatic choice: how many are valid (the n of the criterion), the scoring
/// set and the fitting set (a stratified reduction of the scoring set to about kRankSamples).
struct RankingSets {
    std::size_t valid = 0;
    brdf::Dataset score;
    brdf::Dataset fit;
};

RankingSets make_ranking_sets(const brdf::Dataset& data, const FitOptions& o) {
    RankingSets sets;
    SampleCounts counts;
    std::vector<Sample> copy;
    const std::vector<Sample>& valid =
        select_samples(data, o, detail::thread_count(o.num_threads), counts, copy);
    sets.valid = valid.size();
    for (brdf::Dataset* d : {&sets.score, &sets.fit}) {
        d->source = data.source;
        d->has_sigma = data.has_sigma;
    }
    sets.score.samples = valid.size() <= 2 * kScoreSamples
                             ? valid
                             : stratified_reduce(valid, kScoreSamples, o.seed + 3);
    sets.fit.samples = stratified_reduce(sets.score.samples, kRankSamples, o.seed + 4);
    return sets;
}

/// Per channel, the sum of the squared log residuals of `m` over the valid samples, estimated
/// from the weighted scoring set (its weights sum to the samples they stand for).
Rgbd log_rss(const brdf::ModelD& m, const RankingSets& sets) {
    Rgbd rss = Rgbd::Zero();
    double weight = 0;
    for (const Sample& s : sets.score.samples) {
        const Rgbd f = sample_model_value(m, s);
        const double cos_i = s.wi().z();
        for (int c = 0; c < 3; ++c) {
            const double r = channel_residual(ResidualForm::kLog, f[c], s.value[c], cos_i, 0);
            rss[c] += s.weight * r * r;
        }
        weight += s.weight;
    }
    return weight > 0 ? Rgbd(rss * (static_cast<double>(sets.valid) / weight))
                      : Rgbd::Constant(std::numeric_limits<double>::infinity());
}

/// One candidate fitted on the ranking set and its standing.
struct RankedFit {
    RankedModel rank;
    brdf::ModelD model;  ///< Its fitted model (the start of the final fit if it wins).
};

/// The criterion of a model with `p` free parameters whose log residuals over `samples` valid
/// samples sum (squared, per channel) to `rss`: BIC = n log(RSS / n) + p log(n), n = 3 x samples.
double bic_of(const Rgbd& rss_rgb, std::size_t samples, int p) {
    const double n = 3.0 * static_cast<double>(samples);
    const double rss = rss_rgb.sum();
    // Residuals at rounding level carry no information: below 1e-12 per residual (log units; the
    // arithmetic's own rounding is near 1e-16) the RSS is held at that floor, so that among models
    // that all reproduce the data to rounding the fewest parameters win, not the luckiest rounding.
    constexpr double kResidualFloor = 1e-12;
    const double rss_floor = n * kResidualFloor * kResidualFloor;
    if (!(rss >= 0) || !std::isfinite(rss) || samples == 0) {
        return std::numeric_limits<double>::infinity();
    }
    return n * std::log(std::max(rss, rss_floor) / n) + p * std::log(n);
}

/// Fits one candidate on the fitting set (at most kRankIterations, kRankIterationsCostly for a
/// second lobe or a Student-t lobe; no polish, no covariance, log
/// residual) and scores it by BIC on all valid samples, estimated on the scoring set; empty with
/// `error` set when the fit could not run. A solve stopped by the iteration bound is ranked (its
/// model is as far as the ranking needs); one that failed or left a non-finite value is not. A
/// tabulated candidate extracts its table from the scoring set and fits its factors on a
/// reduction of it to the fitting set's size.
std::optional<RankedFit> rank_candidate(const RankingSets& sets,
                                        const std::string& name,
                                        FitSpec spec,
                                        std::string* error) {
    FitOptions& o = spec.options;
    o.coarse_samples = kRankSamples;
    o.polish_iterations = 0;
    o.reweight_rounds = 0;
    o.covariance = false;
    o.residual = ResidualForm::kLog;
    const bool costly =
        spec.model.lobes.size() > 1 ||
        std::any_of(spec.model.lobes.begin(), spec.model.lobes.end(), [](const auto& l) {
            return l.distribution == brdf::Distribution::kStudentT;
        });
    o.max_iterations = std::min(o.max_iterations, costly ? kRankIterationsCostly : kRankIterations);
    Expected<FitResult> r = fit_any(needs_power_iteration(spec) ? sets.score : sets.fit, spec);
    if (!r) {
        *error = name + ": " + r.error().message;
        return std::nullopt;
    }
    RankedFit out;
    out.model = r->model;
    RankedModel& rm = out.rank;
    rm.name = name;
    int p = 0;
    for (const FittedParameter& fp : r->parameters) {
        p += fp.free ? 1 : 0;
    }
    // A table's nodes are parameters estimated from the data too.
    p += table_nodes(r->model);
    rm.parameters = p;
    const Rgbd rss = log_rss(r->model, sets);
    rm.log_rmse = (rss / static_cast<double>(sets.valid)).cwiseSqrt().mean();
    rm.criterion = bic_of(rss, sets.valid, p);
    rm.converged = std::isfinite(rm.criterion) &&
                   (r->solver.converged || r->solver.termination == "NO_CONVERGENCE");
    return out;
}

/// The one-lobe structure of which `spec` is the two-lobe extension (same distribution and
/// shadowing), found among the ranked fits; null when there is none.
const brdf::ModelD* one_lobe_of(const FitSpec& spec, const std::vector<RankedFit>& fits) {
    if (spec.model.lobes.size() != 2) {
        return nullptr;
    }
    const brdf::Lobe<double>& l = spec.model.lobes[0];
    for (const RankedFit& f : fits) {
        if (f.rank.converged && f.model.lobes.size() == 1 &&
            f.model.lobes[0].distribution == l.distribution &&
            f.model.lobes[0].shadowing == l.shadowing &&
            f.model.lobes[0].fresnel.type == l.fresnel.type) {
            return &f.model;
        }
    }
    return nullptr;
}

/// The ranked fit of one isotropic GGX lobe with `lobes` lobes and Smith shadowing; null when
/// there is none.
const RankedFit* ranked_ggx(const std::vector<RankedFit>& fits, std::size_t lobes) {
    for (const RankedFit& f : fits) {
        if (f.rank.converged && f.model.lobes.size() == lobes &&
            f.model.lobes[0].distribution == brdf::Distribution::kGgx &&
            f.model.lobes[0].shadowing != brdf::Shadowing::kVGroove) {
            return &f;
        }
    }
    return nullptr;
}

/// Early rejection: a two-lobe candidate of another family than GGX is hopeless when GGX's second
/// lobe did not lower GGX's criterion (the data hold no second lobe that pays for its
/// parameters). GGX with two lobes is the cheapest two-lobe fit, so it is the probe; a Student-t
/// pair costs as much as every other candidate together.
bool second_lobe_hopeless(const FitSpec& spec, const std::vector<RankedFit>& fits) {
    if (spec.model.lobes.size() < 2 ||
        spec.model.lobes[0].distribution == brdf::Distribution::kGgx) {
        return false;
    }
    const RankedFit* one = ranked_ggx(fits, 1);
    const RankedFit* two = ranked_ggx(fits, 2);
    return one != nullptr && two != nullptr && !(two->rank.criterion < one->rank.criterion);
}

/// Every candidate ranked but the hopeless ones (second_lobe_hopeless). Shared starts: the first
/// (one isotropic GGX lobe) fitted on the fitting set with its own starts seeds every other
/// one-lobe analytic candidate; a two-lobe candidate starts from its family's fitted lobe; a
/// tabulated one extracts its table. `first_error`: the first candidate that could not run;
/// `rejected`: the names of the candidates left out as hopeless.
std::vector<RankedFit> rank_all(const RankingSets& sets,
                                const std::vector<std::pair<std::string, FitSpec>>& candidates,
                                std::vector<std::size_t>& spec_of,
                                std::string& first_error,
                                std::vector<std::string>& rejected) {
    std::vector<RankedFit> fits;
    std::optional<brdf::ModelD> seed;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        const FitSpec& spec = candidates[i].second;
        if (second_lobe_hopeless(spec, fits)) {
            rejected.push_back(candidates[i].first);
            continue;
        }
        FitSpec start = spec;
        if (const brdf::ModelD* one = one_lobe_of(spec, fits)) {
            start = with_second_lobe(spec, *one);
        } else if (seed && !needs_power_iteration(spec)) {
            start = started_from(spec, *seed);
        }
        std::string error;
        std::optional<RankedFit> rf = rank_candidate(sets, candidates[i].first, start, &error);
        if (!rf) {
            if (first_error.empty()) {
                first_error = error;
            }
            continue;
        }
        if (i == 0 && rf->rank.converged && seeds_candidates(rf->model)) {
            seed = rf->model;
        }
        fits.push_back(std::move(*rf));
        spec_of.push_back(i);
    }
    return fits;
}

/// The winner and what it came from.
struct Choice {
    std::string name;
    FitSpec spec;
    brdf::ModelD model;  ///< Its optimum on the ranking set.
};

/// Whether `spec` has an RGB-roughness variant that auto tries: not with Student-t lobes, whose
/// Lambda (a continued fraction) per channel makes that one fit cost more than every candidate
/// together (`--model student-t --roughness rgb` fits it).
bool tries_rgb_roughness(const FitSpec& spec) {
    for (const brdf::Lobe<double>& l : spec.model.lobes) {
        if (l.distribution == brdf::Distribution::kStudentT) {
            return false;
        }
    }
    return with_rgb_roughness(spec).has_value();
}

/// RGB-varying roughness as a refinement: the structure of the best-ranked candidate that takes
/// it (`base`, the winner itself unless that is a Student-t one) with one alpha per channel,
/// fitted on the fitting set from `base`'s optimum, replaces the winner when BIC prefers it and
/// the log RMSE drops by at least kMinRgbRoughnessGain. One more fit of one structure instead of
/// doubling the candidates. Listed in the ranking unless it ranks above the winner by BIC without
/// the gain (noise-free data, where RSS is rounding): the ranking stays ordered, chosen first.
void refine_rgb_roughness(const RankingSets& sets,
                          const RankedModel& winner,
                          const Choice& base,
                          Choice& choice,
                          std::vector<RankedFit>& fits) {
    std::optional<FitSpec> rgb = with_rgb_roughness(base.spec);
    if (!rgb) {
        return;
    }
    brdf::ModelD start = base.model;
    for (brdf::Lobe<double>& l : start.lobes) {
        l.rgb_roughness = true;
        l.alpha_rgb = Rgbd::Constant(l.alpha_x);
    }
    std::string error;
    const std::string name = base.name + " rgb-roughness";
    std::optional<RankedFit> rf = rank_candidate(sets, name, continued_from(*rgb, start), &error);
    if (!rf) {
        return;
    }
    const bool better = rf->rank.converged && rf->rank.criterion < winner.criterion &&
                        winner.log_rmse - rf->rank.log_rmse >= kMinRgbRoughnessGain;
    if (better || !(rf->rank.criterion < winner.criterion)) {
        fits.push_back(*rf);
    }
    if (better) {
        choice = Choice{name, *rgb, rf->model};
    }
}

/// The best-ranked fit (lowest criterion among the ranked ones) whose candidate satisfies `pred`;
/// fits.size() when none does.
template <typename Pred>
std::size_t best_ranked(const std::vector<RankedFit>& fits,
                        const std::vector<std::size_t>& spec_of,
                        const std::vector<std::pair<std::string, FitSpec>>& candidates,
                        Pred&& pred) {
    std::size_t best = fits.size();
    for (std::size_t k = 0; k < fits.size(); ++k) {
        if (fits[k].rank.converged && pred(candidates[spec_of[k]].second) &&
            (best == fits.size() || fits[k].rank.criterion < fits[best].rank.criterion)) {
            best = k;
        }
    }
    return best;
}

}  // namespace

Expected<AutoFitResult> fit_auto(const brdf::Dataset& data,
                                 const std::vector<std::pair<std::string, FitSpec>>& candidates) {
    AutoFitResult out;
    out.criterion =
        "BIC = n log(RSS/n) + p log(n) of the log residuals on all valid samples (n = 3 x "
        "samples, p = free parameters), each candidate fitted on a stratified set of at most " +
        std::to_string(kRankSamples) + " samples; lower is better";
    if (candidates.empty()) {
        return make_error("--model auto: no candidate");
    }
    const RankingSets sets = make_ranking_sets(data, candidates.front().second.options);
    std::vector<std::size_t> spec_of;
    std::string first_error;
    std::vector<RankedFit> fits = rank_all(sets, candidates, spec_of, first_error, out.rejected);
    const std::size_t win =
        best_ranked(fits, spec_of, candidates, [](const FitSpec&) { return true; });
    if (win == fits.size()) {
        return make_error("--model auto: no candidate converged" +
                          (first_error.empty() ? std::string() : " (" + first_error + ")"));
    }
    Choice choice{candidates[spec_of[win]].first, candidates[spec_of[win]].second, fits[win].model};
    const RankedModel winner = fits[win].rank;
    const std::size_t base = best_ranked(fits, spec_of, candidates, tries_rgb_roughness);
    if (base < fits.size()) {
        const Choice from{
            candidates[spec_of[base]].first, candidates[spec_of[base]].second, fits[base].model};
        refine_rgb_roughness(sets, winner, from, choice, fits);
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
    out.chosen = choice.name;
    // The winner on all samples, from its ranking optimum (a tabulated winner extracts its table
    // again from all samples): solved on a reduction to kRankSamples, then polished on all.
    FitSpec final_spec = needs_power_iteration(choice.spec)
                             ? choice.spec
                             : continued_from(choice.spec, choice.model);
    final_spec.options.coarse_samples = kRankSamples;
    Expected<FitResult> best = fit_any(data, final_spec);
    if (!best) {
        return make_error(out.chosen + ": " + best.error().message);
    }
    out.best = *best;
    out.best.automatic = AutoChoice{out.chosen, out.criterion, out.ranking, out.rejected};
    return out;
}

}  // namespace gonio::fitting
