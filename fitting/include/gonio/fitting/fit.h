#pragma once

// Fits an analytic model (brdf/model.h) to a dataset with Ceres: validity filtering, optional
// stratified reduction, data-driven initialisation with a seeded multi-start, a bounded solve,
// uncertainties and error metrics on all valid samples.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/error.h"
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

/// Error of a model against data, per channel, over a set of samples.
struct Metrics {
    brdf::Rgbd rmse = brdf::Rgbd::Zero();      ///< sqrt(mean((m - d)^2)), 1/sr.
    brdf::Rgbd rel_rmse = brdf::Rgbd::Zero();  ///< sqrt(mean(((m - d) / (d + relative_floor))^2)).
    brdf::Rgbd log_rmse = brdf::Rgbd::Zero();  ///< sqrt(mean((log(1+m cos_i) - log(1+d cos_i))^2)).
};

struct SampleCounts {
    std::size_t input = 0;     ///< Rows read (valid + rejected).
    std::size_t valid = 0;     ///< Rows that passed validation.
    std::size_t used = 0;      ///< Samples in the solve (after reduction).
    std::size_t rejected = 0;  ///< Rows rejected while reading or by validation here.
    std::vector<std::size_t> rejected_lines;  ///< First 100 rejected line numbers.
};

/// Mirrors ceres::Solver::Summary.
struct SolverInfo {
    int iterations = 0;
    std::string termination;  ///< "CONVERGENCE", "NO_CONVERGENCE", "FAILURE", "USER_SUCCESS", ...
    std::string message;
    bool usable = false;      ///< True only for CONVERGENCE: the parameters are a result.
    double wall_time_s = 0;   ///< The whole fit: validation, reduction, start, solve, metrics.
    double solve_time_s = 0;  ///< The Ceres solves alone (coarse and full).
    double initial_cost = 0;
    double final_cost = 0;
    int starts = 0;  ///< Multi-start candidates scored.
};

struct FitResult {
    brdf::ModelD model;
    std::vector<FittedParameter> parameters;
    std::vector<std::string> not_identifiable;
    /// Free parameters that ended on a bound ("lobes[0].alpha_x (upper bound 1.5)").
    std::vector<std::string> at_bounds;
    /// Lobes whose share of the fitted reflectance over the samples of the solve is below 1e-3:
    /// the fit has in effect dropped them ("lobes[0]").
    std::vector<std::string> vanished_lobes;
    Metrics metrics;  ///< On all valid samples, even when the solve used a reduction.
    SampleCounts samples;
    ResidualForm residual = ResidualForm::kLog;
    LossKind loss = LossKind::kNone;
    SolverInfo solver;
    std::string data;                          ///< Dataset source.
    std::optional<brdf::ModelD> ground_truth;  ///< Set by callers that know it (benchmarks, tests).

    /// True when the solve converged: only then are the parameters a result.
    bool usable() const { return solver.usable; }
};

/// Runs the fit. Errors (returned): no valid sample, an inconsistent spec (a parameter of a lobe
/// that does not exist, bounds lo > hi, a start value outside its bounds). A solve that ran but did
/// not converge is returned as a FitResult with solver.usable == false.
Expected<FitResult> fit(const brdf::Dataset& data, const FitSpec& spec);

/// Metrics of `model` against the valid samples of `data`.
Metrics evaluate_metrics(const brdf::ModelD& model,
                         const std::vector<brdf::Sample>& samples,
                         double relative_floor);

/// Names of the scalar parameters of `spec`, in the order of FitResult::parameters.
std::vector<std::string> parameter_names(const FitSpec& spec);

}  // namespace gonio::fitting
