#pragma once

// The fit-driven plan (`gonio acquire --plan fit`): a campaign that starts with a small
// space-filling batch, fits between batches and chooses each next batch from a pool of candidate
// configurations by what it is expected to teach per second of rig time:
// - where the model's predictive uncertainty is largest: the fit's covariance C propagated to a
//   candidate through the Jacobian j of ln f (the luminance) with respect to the free parameters,
//   var ln f = j^T C j;
// - where the residuals show the model failing: the excess of the squared log residuals of the
//   nearby measurements over their noise (a misfit region is measured more, not avoided);
// - plus a space-filling share (farthest point from everything measured or chosen), so that no
//   region is never looked at.
// A candidate's expected information is 1/2 ln(1 + (var ln f + misfit) / s^2), s the relative
// noise of a measurement; it is divided by the candidate's rig seconds (the exposure its
// predicted signal needs, settle and readout). The batch is chosen greedily: after each choice
// the covariance is updated as if that measurement had been taken (a rank-one update), and the
// misfit around it counts as explained, so a batch spreads over what is unknown. Everything is a
// function of its inputs (ties go to the lower pool index): a resumed campaign rebuilds the same
// batch from the same journal.

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "gonio/acquisition/plans/plan.h"

namespace gonio::acquisition {

/// The fit-driven plan's settings (campaign.json "plan": {"kind": "fit", ...}).
struct FitPlanSpec {
    int first = 16;    ///< Configurations of the first, space-filling batch.
    int batch = 8;     ///< Configurations of every later batch.
    int budget = 120;  ///< Most configurations the campaign measures.
    double space_share =
        0.25;                  ///< Share of a later batch chosen to fill space (> 0: at least one).
    double theta_max = 1.309;  ///< rad (75 deg): the pool's largest polar angle.
    /// The pool spans (theta_i, phi_i, theta_o, phi_o) (anisotropic samples, the spin axis turns
    /// the sample) instead of the isotropic (theta_i, theta_r, delta_phi).
    bool anisotropic = false;
    SampleSymmetry symmetry = SampleSymmetry::kNone;
};

/// Checks the ranges (first >= 1, batch >= 1, budget >= first, space_share in [0, 1]).
Expected<void> check_fit_plan_spec(const FitPlanSpec& spec);

/// The pool of candidates: isotropic, a uniform grid of 16 polar x 12 azimuth-difference values
/// and the half/difference grid of 16 x 12 x 8 (dense near the specular direction), without
/// duplicates; anisotropic, the anisotropic grid of 8 polar x 7 azimuth-difference steps and, for
/// each of its incident directions, the view directions whose half vector lies 0, 2, 5 and 10 deg
/// from the normal at 8 azimuths. Indices are positions in the pool. Reachability and a scene's
/// ROI are applied by the caller.
Expected<Plan> fit_plan_pool(const FitPlanSpec& spec);

/// Where a configuration lies for distances: the light, view and half-vector directions (9
/// values), an isotropic configuration turned to phi_i = 0 with its view azimuth folded to
/// [0, pi]; `swapped` is the same with light and view exchanged (reciprocity).
struct PlanFeatures {
    std::array<double, 9> direct{};
    std::array<double, 9> swapped{};
};
PlanFeatures plan_features(const PlannedConfig& c);
/// The smaller Euclidean distance of the two orderings (about the angle, radians, for nearby
/// configurations).
double feature_distance(const PlanFeatures& a, const PlanFeatures& b);

/// A measurement as the chooser sees it.
struct MeasuredForPlan {
    PlanFeatures where;
    double log_residual = 0;  ///< ln(value / prediction) of the luminance (0 without a fit).
    double rel_sigma = 0;     ///< The value's relative standard uncertainty.
};

/// What the fit of the values so far says about the candidates (the front end computes it).
struct FitView {
    int parameters = 0;              ///< P, the free parameters with a sigma.
    std::vector<double> covariance;  ///< P x P, row-major.
    std::vector<double> jacobian;    ///< Candidates x P: d ln f / d p at each candidate.
    std::vector<double> predicted;   ///< Candidates: predicted luminance, 1/sr.
};

/// One candidate: its place and its rig seconds.
struct CandidateForPlan {
    PlanFeatures where;
    double cost_s = 1;
    bool available = true;  ///< False once measured (or chosen): never chosen again.
};

struct FitChoiceOptions {
    int count = 8;
    double space_share = 0.25;
    double length_scale = 0.12;  ///< Kernel width of the misfit around a measurement (radians).
};

/// Why a configuration was chosen.
enum class ChoiceReason { kVariance, kMisfit, kSpace };
const char* to_string(ChoiceReason r);

struct BatchChoice {
    std::vector<std::size_t> chosen;  ///< Indices into the candidates, in choice order.
    std::vector<ChoiceReason> reasons;
    std::vector<double> predictive_var;  ///< var ln f of each at its choice (0: space-filling).
    std::vector<double> misfit;          ///< Its misfit variance at its choice.
};

/// The misfit variance at each candidate: the kernel-weighted mean (Gaussian of width
/// length_scale, one pseudo-measurement of no misfit added) of the measurements' excess squared
/// log residual max(0, r^2 - s^2).
std::vector<double> misfit_variance(const std::vector<CandidateForPlan>& candidates,
                                    const std::vector<MeasuredForPlan>& measured,
                                    double length_scale);

/// var ln f = j^T C j of a candidate with Jacobian row `j` under the P x P covariance `cov`.
double predictive_variance(const std::vector<double>& cov, const double* j, int p);

/// The covariance after one more measurement of relative variance s2 with Jacobian row j:
/// C - (C j)(C j)^T / (s2 + j^T C j) (the Kalman, or Sherman-Morrison, update).
void measured_update(std::vector<double>* cov, const double* j, int p, double s2);

/// Whether `fit` holds a covariance and a Jacobian row for each of `candidates` candidates.
bool fit_is_usable(const FitView* fit, std::size_t candidates);

/// The next batch. Without a fit (`fit` null, or no parameter) every configuration fills space.
/// `noise_rel_var` is s^2. Chooses at most the available candidates.
BatchChoice choose_batch(const std::vector<CandidateForPlan>& candidates,
                         const std::vector<MeasuredForPlan>& measured,
                         const FitView* fit,
                         double noise_rel_var,
                         const FitChoiceOptions& options);

/// `count` candidates by farthest point from the measured ones and each other (the first batch:
/// from the pool's first candidate).
std::vector<std::size_t> space_filling(const std::vector<CandidateForPlan>& candidates,
                                       const std::vector<MeasuredForPlan>& measured,
                                       int count);

}  // namespace gonio::acquisition
