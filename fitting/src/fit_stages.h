#pragma once

// The stages of fit() (fit.cpp), one file each, internal to the fitting library:
//   initialisation.cpp  data-driven starts scored on a reduction, then screened by short solves;
//   solve.cpp           the bounded Levenberg-Marquardt solves (main solve, polish, reweighting);
//   uncertainties.cpp   identifiability and the covariance of the free parameters;
//   goodness.cpp        metrics, lobe shares and the verdict on whether the model represents the
//                       data.

#include <ceres/ceres.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gonio/brdf/dataset.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/prepared_samples.h"
#include "gonio/fitting/reduction.h"

namespace gonio::fitting::detail {

/// What a row of the dataset is to the fit.
enum class SampleKind : std::uint8_t {
    kValid,      ///< A BRDF sample above the horizon within the limits: fitted.
    kInvalid,    ///< Breaks a validity rule: rejected, its line reported.
    kReference,  ///< Drift-reference re-measurement (flag bit 2): not a BRDF sample, counted.
    kSaturated,  ///< Saturated (flag bit 0): its value is only a lower bound, left out, counted.
};

/// Threads of a pass: `requested` clamped to the project's pool, or the whole pool when 0.
int thread_count(int requested);

/// Which bound of its range a free scalar lies on.
enum class Bound {
    kNone,   ///< Inside the range.
    kLower,  ///< Within 1e-9 of the range above the lower bound.
    kUpper,  ///< Within 1e-9 of the range below the upper bound.
};

/// The one rule for "on a bound": within 1e-9 of the range (upper - lower) of a bound.
Bound at_bound(double value, const ScalarParam& s);
/// "lower", "upper" or "" (kNone).
const char* bound_name(Bound b);

/// A start of the solve and its cost.
struct Candidate {
    std::vector<double> x;
    double cost = 0;
};

/// The end point of one Ceres solve.
struct SolveOutcome {
    std::vector<double> x;
    ceres::Solver::Summary summary;
};

/// What every stage needs: the options, the parameter map, the residual and the thread count.
struct FitContext {
    const FitOptions& options;
    std::shared_ptr<const ParameterMap> map;
    CostOptions cost;
    int threads = 1;
    /// The stratum coordinates (reduction.h) of the working set `*coords_of`, kept by
    /// reduce_work for the next reduction of the same set (the scoring set and the screen).
    mutable std::vector<StratumCoords> work_coords;
    mutable const std::vector<brdf::Sample>* coords_of = nullptr;
    /// The scoring set of the starts (a stratified reduction of the working set, or the working
    /// set itself when it is not larger) and its prepared samples (no robust loss): filled by
    /// starting_points, shared by the screen and, when it is the whole working set, by the main
    /// solve (prepare_work), so that its geometry is computed once.
    mutable const std::vector<brdf::Sample>* score_set = nullptr;
    mutable std::shared_ptr<PreparedSamples> score_ps;
    /// The reduction that score_set points to, when it is not the working set itself.
    mutable std::vector<brdf::Sample> score_reduction;
};

using Clock = std::chrono::steady_clock;

/// Appends a stage to the solver record (iterations: the stage's own, summed over its solves).
void record_stage(SolverInfo& solver,
                  const std::string& name,
                  std::size_t samples,
                  const ceres::Solver::Summary& last,
                  Clock::time_point since,
                  int iterations);

// --- initialisation.cpp ----------------------------------------------------------------------

/// stratified_reduce of the working set `work` to `budget` samples (the whole set when it is not
/// larger); the half/difference transform of its samples is done once per set and kept in `ctx`.
std::vector<brdf::Sample> reduce_work(const FitContext& ctx,
                                      const std::vector<brdf::Sample>& work,
                                      std::size_t budget,
                                      std::uint64_t seed);

/// The starts of the solve, best first: data-driven candidates scored by their cost
/// (FitOptions::auto_init) or the template's values (an error when one is outside its bounds).
Expected<std::vector<Candidate>> starting_points(const FitContext& ctx,
                                                 const FitSpec& spec,
                                                 const std::vector<brdf::Sample>& work);

/// Short, loose solves from the best-scored starts on *ctx.score_set (starting_points: a small
/// stratified subset of the working set); those starts are then ranked by the cost they reach and
/// continue from where they stopped. Records the stage "screen". Does nothing with a single
/// candidate.
void screen_starts(const FitContext& ctx, std::vector<Candidate>& candidates, SolverInfo& solver);

/// The working set prepared for the main solve: the scoring set's prepared samples when they are
/// the same samples under the same loss, else a new preparation.
std::shared_ptr<PreparedSamples> prepare_work(const FitContext& ctx,
                                              const std::vector<brdf::Sample>& work);

// --- solve.cpp -------------------------------------------------------------------------------

/// The samples prepared for a solve, with the robust loss of the options.
std::shared_ptr<PreparedSamples> prepare(const FitContext& ctx,
                                         const std::vector<brdf::Sample>& samples);

/// Levenberg-Marquardt (Ceres) on the normal-equation form of the prepared samples. With
/// hold_bounds, free parameters that start on a bound are held there (the polish after a reduced
/// solve: the reduction already put them there).
SolveOutcome solve(const FitContext& ctx,
                   const std::shared_ptr<const PreparedSamples>& ps,
                   std::vector<double> x0,
                   int max_iterations,
                   double tolerance = 1e-12,
                   bool hold_bounds = false);

/// The main solve on `work` from the best start; when it does not converge, from the next ones
/// (at most three). Records the stage `stage_name`.
SolveOutcome main_solve(const FitContext& ctx,
                        const std::shared_ptr<const PreparedSamples>& ps_work,
                        const std::vector<brdf::Sample>& work,
                        const std::vector<Candidate>& candidates,
                        const std::string& stage_name,
                        SolverInfo& solver);

/// Polish on all samples (bounded) after a reduced solve, then relative-noise reweighting at the
/// model when the data carry sigmas; `best` moves to each usable end point. `ps_used` is prepared
/// on `used` when empty.
void refine(const FitContext& ctx,
            const std::vector<brdf::Sample>& used,
            bool reduced,
            std::shared_ptr<PreparedSamples>& ps_used,
            SolveOutcome& best,
            SolverInfo& solver);

int iterations_of(const ceres::Solver::Summary& s);
bool all_finite(const std::vector<double>& x);

// --- uncertainties.cpp -----------------------------------------------------------------------

/// Fills sigma / identifiable of the free parameters at the solution x of the prepared samples
/// (the rules are documented at the definition). `on_bound[k]`: free scalar k ended on a bound.
void uncertainties(const PreparedSamples& ps,
                   int threads,
                   const std::vector<double>& x,
                   bool with_sigma,
                   const std::vector<bool>& on_bound,
                   std::vector<FittedParameter>& params,
                   std::vector<std::string>& not_identifiable,
                   std::optional<double>* reduced_chi2,
                   ParameterCovariance* covariance);

// --- goodness.cpp ----------------------------------------------------------------------------

/// Each lobe's share of the model's reflectance summed (weighted, channel mean) over `samples`:
/// sum_i w_i mean_c lobe_l(i) / sum_i w_i mean_c model(i). All zero when the model is zero on
/// every sample (nothing to share).
std::vector<double> lobe_shares(const brdf::ModelD& model,
                                const std::vector<brdf::Sample>& samples);

/// Lobes whose share of the reflectance over `samples` is below 1e-3 ("lobes[0]"). With `ps`
/// prepared on the same samples, the lobes' values come from its geometry (no sines, cosines or
/// arctangents per sample; equal to eval_lobe's to rounding).
std::vector<std::string> vanished_lobes(const brdf::ModelD& model,
                                        const std::vector<brdf::Sample>& samples,
                                        const PreparedSamples* ps = nullptr);

/// evaluate_metrics (fit.h) from the prepared samples `ps` of the same `samples`: the model values
/// from the prepared geometry (no sines, cosines or arctangents per sample; equal to
/// eval_model's to rounding), cos theta_i and cos theta_h from its arrays. The plain
/// evaluate_metrics when `ps` holds other samples or no half vectors.
Metrics evaluate_metrics(const brdf::ModelD& model,
                         const std::vector<brdf::Sample>& samples,
                         double relative_floor,
                         const PreparedSamples& ps,
                         int threads);

/// Goodness of fit from the metrics (and the reduced chi-square when the data carry sigmas);
/// the rules are those documented at GoodnessOfFit (fit.h).
GoodnessOfFit judge(const Metrics& m,
                    std::optional<double> chi2,
                    std::size_t valid,
                    const brdf::ModelD& fitted,
                    bool f0_per_channel);

}  // namespace gonio::fitting::detail
