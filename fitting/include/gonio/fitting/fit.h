#pragma once

// Fits an analytic model (brdf/model.h) to a dataset with Ceres: validity filtering, optional
// stratified reduction, data-driven initialisation with a seeded multi-start, a bounded solve,
// uncertainties and error metrics on all valid samples.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model.h"
#include "gonio/fitting/spec.h"

namespace gonio::fitting {

/// One scalar of the fitted model.
struct FittedParameter {
    std::string name;  ///< "lobes[0].alpha_x", "diffuse[1]", "lobes[0].fresnel.f0" (shared)
    double value = 0;
    std::optional<double> sigma;  ///< One-sigma uncertainty; empty when fixed or not identifiable.
    bool free = false;
    bool identifiable = true;
    /// "lower" or "upper" when a free parameter ended on (within 1e-9 of the range of) a bound:
    /// the optimum lies at or beyond the bound, the value is the bound's, not a free estimate.
    std::string at_bound;
};

/// Log residuals log(1 + m cos_i) - log(1 + d cos_i) of the samples whose half-vector angle lies in
/// [theta_h_lo_deg, theta_h_hi_deg): their mean (a systematic offset shows there) and RMSE.
struct BandResidual {
    double theta_h_lo_deg = 0;
    double theta_h_hi_deg = 0;
    std::size_t count = 0;
    brdf::Rgbd mean_log = brdf::Rgbd::Zero();
    brdf::Rgbd log_rmse = brdf::Rgbd::Zero();
};

/// Error of a model against data, per channel, over a set of samples.
struct Metrics {
    brdf::Rgbd rmse = brdf::Rgbd::Zero();      ///< sqrt(mean((m - d)^2)), 1/sr.
    brdf::Rgbd rel_rmse = brdf::Rgbd::Zero();  ///< sqrt(mean(((m - d) / (d + relative_floor))^2)).
    brdf::Rgbd log_rmse = brdf::Rgbd::Zero();  ///< sqrt(mean((log(1+m cos_i) - log(1+d cos_i))^2)).
    /// Median of |m - d| / d over the samples whose value is above its noise (d > 2 sigma, sigma
    /// the sample's own or, without one, the noise the dataset implies,
    /// brdf/values_below_zero.h): the relative error of f itself, with no floor and no
    /// 1 + f cos, so that a dark channel's error counts as much as a bright one's (log(1 + f cos)
    /// is nearly absolute for f cos << 1). 0 when no sample is above its noise.
    brdf::Rgbd median_rel = brdf::Rgbd::Zero();
    /// Log residuals by theta_h band (edges 0, 2, 5, 10, 20, 40, 90 degrees); empty bands omitted.
    std::vector<BandResidual> bands;
};

/// The headline of a fit, one of three states decided channel by channel on measures that see a
/// dark channel as well as a bright one (docs/fitting-guide.md, "Goodness of fit").
enum class Verdict {
    kRepresents,        ///< No channel shows a visible misfit.
    kVisibleMisfit,     ///< Usable, with a visible misfit in the channels it names.
    kDoesNotRepresent,  ///< A misfit far beyond the noise: that model's best, not the material.
};

/// "represents", "visible-misfit", "does-not-represent" (the report's goodness.verdict).
const char* to_string(Verdict v);
/// Parses to_string's names.
Expected<Verdict> parse_verdict(const std::string& name);

/// Whether the model represents the data (docs/fitting-guide.md, "Goodness of fit").
struct GoodnessOfFit {
    /// The one headline: the worst state of any channel (and of the chi-square).
    Verdict verdict = Verdict::kRepresents;
    /// The headline in words, naming the channels and figures that decide it: "represents these
    /// data", "usable, with a visible misfit in channel b (median relative error 0.091 above
    /// 0.05)", "does not represent these data: channel b (median relative error 0.21 above 0.15)".
    std::string headline = "represents these data";
    /// Sum of squared normalised residuals / (3 N - p) when the data carry sigmas, else empty.
    std::optional<double> reduced_chi_square;
    /// False when the misfit is far beyond measurement noise (a misfit; a converged misfit is
    /// still the best that model can do and is written with this verdict):
    ///  - a channel's log RMSE above 0.3 (or not finite);
    ///  - a channel's median relative error |m - d| / d above 0.15 (or not finite);
    ///  - in a theta_h band holding at least 1 % of the samples, a channel's mean log residual
    ///    beyond +-0.3 (or not finite);
    ///  - a reduced chi-square not finite, or above 10 while the worst channel's log RMSE is above
    ///    0.02. Above 10 with a log RMSE of at most 0.02 it is a warning only: the stated sigmas
    ///    are then smaller than the systematic errors of the data or the model, and the misfit is
    ///    too small to matter.
    bool represents = true;
    /// Each names the figure and the threshold: the cases above, and the visible misfits that do
    /// not make a fit unusable (a log RMSE above 0.15, a median relative error above 0.05, a
    /// band's mean log residual beyond +-0.15, a reduced chi-square above 2).
    std::vector<std::string> warnings;
    std::string suggestion;  ///< What to try instead (empty when the fit is good).
};

/// One solve of the fit (screening, reduction, polish, reweighting).
struct StageInfo {
    std::string name;  ///< "screen", "reduced", "polish", "reweight 1", ...
    std::size_t samples = 0;
    int iterations = 0;
    std::string termination;
    double time_s = 0;
    double final_cost = 0;
};

struct SampleCounts {
    std::size_t input = 0;      ///< Rows read (valid + rejected).
    std::size_t valid = 0;      ///< Rows that passed validation.
    std::size_t used = 0;       ///< Samples in the solve (after reduction).
    std::size_t rejected = 0;   ///< Rows rejected while reading or by validation here.
    std::size_t reference = 0;  ///< Drift-reference re-measurements (flag bit 2): not BRDF samples.
    std::size_t saturated = 0;  ///< Saturated samples (flag bit 0): lower bounds, left out.
    std::vector<std::size_t> rejected_lines;  ///< First 100 rejected line numbers.
};

/// Mirrors ceres::Solver::Summary.
struct SolverInfo {
    int iterations = 0;       ///< Sum over every stage.
    std::string termination;  ///< "CONVERGENCE", "NO_CONVERGENCE", "FAILURE", "USER_SUCCESS", ...
    std::string message;
    bool converged = false;  ///< The solves converged (the polish may stop at its bound).
    /// Converged, finite and the model represents the data (GoodnessOfFit::represents): only then
    /// are the parameters a result.
    bool usable = false;
    double wall_time_s = 0;   ///< The whole fit: validation, reduction, start, solve, metrics.
    double solve_time_s = 0;  ///< The Ceres solves alone (coarse and full).
    double initial_cost = 0;
    double final_cost = 0;
    int starts = 0;  ///< Multi-start candidates scored.
    std::vector<StageInfo> stages;
};

/// The covariance of the free parameters that have a sigma (FittedParameter::sigma), in the order
/// of `names`, row-major (names.size() squared values); empty when no sigma was computed. What
/// propagates the fit's uncertainty to a prediction: var f(x) = j^T C j, j = df/dp at x.
struct ParameterCovariance {
    std::vector<std::string> names;
    std::vector<double> matrix;
};

/// One candidate of an automatic model choice and its standing.
struct RankedModel {
    std::string name;
    int parameters = 0;    ///< Free scalars (a table's nodes included).
    double log_rmse = 0;   ///< Channel mean, on all valid samples.
    double criterion = 0;  ///< BIC on all valid samples (lower is better).
    /// Ranked: finite, and converged or stopped by the ranking's iteration bound.
    bool converged = false;
};

/// How an automatic model choice (`--model auto`) came to its model: every candidate ranked.
struct AutoChoice {
    std::string chosen;                ///< The winner's name (the first of the ranking).
    std::string criterion;             ///< How the ranking was made.
    std::vector<RankedModel> ranking;  ///< Best first.
    /// Candidates rejected early as hopeless, not fitted (fit_auto).
    std::vector<std::string> rejected;
};

struct FitResult {
    brdf::ModelD model;
    std::vector<FittedParameter> parameters;
    ParameterCovariance covariance;
    std::vector<std::string> not_identifiable;
    /// Free parameters that ended on a bound ("lobes[0].alpha_x (upper bound 1.5)").
    std::vector<std::string> at_bounds;
    /// Lobes whose share of the fitted reflectance over the samples of the solve is below 1e-3:
    /// the fit has in effect dropped them ("lobes[0]").
    std::vector<std::string> vanished_lobes;
    Metrics metrics;  ///< On all valid samples, even when the solve used a reduction.
    GoodnessOfFit goodness;
    /// How the sigmas were obtained: "sandwich (HC0)" without sigma columns, "inverse J^T J,
    /// relative sigmas reweighted at the model (IRLS), scaled by max(1, reduced chi-square)" with.
    std::string covariance_method;
    SampleCounts samples;
    ResidualForm residual = ResidualForm::kLog;
    LossKind loss = LossKind::kNone;
    SolverInfo solver;
    std::string data;                          ///< Dataset source.
    std::optional<brdf::ModelD> ground_truth;  ///< Set by callers that know it (benchmarks, tests).
    /// Set when the model was chosen by fit_auto: the ranking that chose it.
    std::optional<AutoChoice> automatic;

    /// True when the solve converged: only then are the parameters a result.
    bool usable() const { return solver.usable; }
};

/// Runs the fit. Coarse to fine: when the samples of the solve number more than twice
/// FitOptions::coarse_samples, the candidates and the main solve work on a stratified reduction
/// to about coarse_samples, and the result is then polished on all samples for at most
/// FitOptions::polish_iterations iterations. Errors (returned): no valid sample, an
/// inconsistent spec (a parameter of a lobe that does not exist, bounds lo > hi, a start value
/// outside its bounds). A solve that ran but did not converge is returned as a FitResult with
/// solver.usable == false.
Expected<FitResult> fit(const brdf::Dataset& data, const FitSpec& spec);

struct AutoFitResult {
    FitResult best;                    ///< The winner, polished on all samples.
    std::string chosen;                ///< Its name.
    std::vector<RankedModel> ranking;  ///< Best first.
    std::string criterion;             ///< How the ranking was made.
    /// Candidates rejected early as hopeless, not fitted: a two-lobe candidate of another family
    /// than GGX when GGX's second lobe did not lower GGX's criterion.
    std::vector<std::string> rejected;
};

/// Ranks the candidates by the Bayesian information criterion of the log residuals on all valid
/// samples,
///   BIC = n log(RSS / n) + p log(n),  n = 3 x valid samples,
/// (Schwarz 1978, Gaussian likelihood with the variance profiled out), each candidate fitted on
/// a stratified set of at most 1000 of the valid samples (their weights kept) with at most 40
/// iterations (20 for a second lobe or a Student-t lobe), and returns the winner fitted to convergence on all samples from its ranking
/// optimum. Shared starts: the first candidate (one isotropic GGX lobe) is fitted on the ranking
/// set with its own starts and seeds every other analytic candidate (widths mapped, single
/// start); a tabulated candidate extracts its table by power iteration on the ranking set (and on
/// all samples when it wins). A two-lobe candidate of another family than GGX is rejected
/// early, not fitted, when GGX's second lobe did not lower GGX's criterion (AutoFitResult::
/// rejected). The winner's structure with RGB-varying roughness is then tried once (kept when BIC
/// prefers it and the log RMSE drops by 1e-4). Error when no candidate converges.
Expected<AutoFitResult> fit_auto(const brdf::Dataset& data,
                                 const std::vector<std::pair<std::string, FitSpec>>& candidates);

/// The candidate families of `gonio fit --model auto`: GGX, Beckmann, Blinn-Phong and Student-t
/// with Lambert and a scalar Schlick Fresnel with an RGB scale, one lobe, GGX and Student-t
/// with two lobes, GGX and Beckmann with V-groove shadowing ("ggx v-groove", "beckmann
/// v-groove"), and the tabulated NDF by power iteration (power_iteration.h; its table's nodes
/// count as parameters of the criterion).
std::vector<std::pair<std::string, FitSpec>> auto_candidates(const FitOptions& options);

/// An automatic choice as `gonio fit` prints it: "model auto: " and the criterion, the candidates
/// ranked (rank, model, parameters, log RMSE, BIC; "(did not converge)" after one that did not),
/// the candidates rejected early, and "chosen: NAME"; one line each.
std::string format_auto_choice(const AutoChoice& choice);

/// What to try after a misfit of `fitted`: the families, lobes and options it did not use (never
/// one it used). Empty after `--model auto` (`auto_tried`), which ranked every family: what is
/// left then is the measurement itself as a table (batch::table_alternative).
/// `f0_per_channel`: the fit had a Schlick f0 per channel (`--fresnel schlick-rgb`).
std::string suggest_after(const brdf::ModelD& fitted, bool f0_per_channel, bool auto_tried);

/// The headline of a verdict with its named findings ("channel b (median relative error 0.091
/// above 0.05)").
std::string headline_of(Verdict v, const std::string& named);

/// Metrics of `model` against the valid samples of `data`.
Metrics evaluate_metrics(const brdf::ModelD& model,
                         const std::vector<brdf::Sample>& samples,
                         double relative_floor);

/// Names of the scalar parameters of `spec`, in the order of FitResult::parameters.
std::vector<std::string> parameter_names(const FitSpec& spec);

}  // namespace gonio::fitting
