#pragma once

// The batches of a fit-driven point campaign (plans/plan_fit.h) from its journal: pass 0 is the
// space-filling first batch of the pool; pass k >= 1 is chosen from the fit of every measurement
// of the passes before it (in (pass, index) order, with the stated uncertainty of the rig's error
// budget at zero rig hours), so that a resumed campaign rebuilds exactly the batch it was
// measuring. The fit itself is the front end's (acquisition needs no fitting library).

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "gonio/acquisition/plans/plan_fit.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/acquisition/shared/rig_config.h"
#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {

/// What the fit of the values so far gives the chooser.
struct PlanFit {
    FitView view;                     ///< Covariance, and Jacobian and prediction per candidate.
    std::vector<double> at_measured;  ///< Predicted luminance at each measured sample.
    std::string summary;              ///< The model and its parameters, for the record.
};

/// Fits `measured` (the default model of `gonio fit`; anisotropic lobes with `anisotropic`) and
/// evaluates the fit at every candidate.
using PlanFitFn = std::function<Expected<PlanFit>(const std::vector<brdf::Sample>& measured,
                                                  const std::vector<PlannedConfig>& candidates,
                                                  bool anisotropic)>;

/// The pool of a fit-driven campaign with its scene's ROI applied (when `scene` is given) and the
/// unreachable configurations set aside.
Expected<Plan> fit_pool_for_rig(const FitPlanSpec& spec,
                                const std::string& scene,
                                const RigLimits& limits);

/// The first batch: spec.first configurations of the pool by farthest point.
Plan fit_first_batch(const Plan& pool, const FitPlanSpec& spec);

/// One later batch and how it was chosen.
struct FitBatch {
    Plan plan;  ///< Configurations (index = pool index), empty at the budget.
    std::size_t measured_before = 0;
    bool fitted = false;  ///< Chosen from a fit (false: space-filling only).
    std::string note;     ///< What the fit said, or why there was none.
    int by_variance = 0, by_misfit = 0, by_space = 0;
    std::size_t sweeps = 0;  ///< Fly scans: the sweeps the batch was chosen as (0: points).
};

/// A journal record as a fit sample: its directions as spherical angles, its value, sigma, weight
/// and flags (its exposure path, where it has one, is the caller's to add).
brdf::Sample sample_of_record(const JournalRecord& r);

/// What a later batch is chosen from: the measurements of the passes before it, the fit of them
/// (none when missing or failing; FitBatch::note says why), the chooser's view of both, the
/// noise s^2 (the median relative variance of the values) and how many configurations the batch
/// holds (<= 0 at the budget).
struct FitBatchInputs {
    std::vector<JournalRecord> measured;
    std::optional<PlanFit> fit;
    std::vector<MeasuredForPlan> for_plan;
    std::vector<CandidateForPlan> candidates;
    double noise_rel_var = 1e-4;
    int count = 0;
};
FitBatchInputs fit_batch_inputs(const std::vector<JournalRecord>& records,
                                int pass,
                                const Plan& pool,
                                const FitPlanSpec& spec,
                                const RigConfig& rig,
                                const PlanFitFn& fit,
                                FitBatch* out);

/// The batch's counts by reason and its note from the choice.
void describe_batch(const FitBatchInputs& in, const BatchChoice& b, FitBatch* out);

/// Batch `pass` (>= 1) from the measurements of the passes before it in `records`. A missing or
/// failing fit falls back to space-filling and says so in `note`.
FitBatch fit_next_batch(const std::vector<JournalRecord>& records,
                        int pass,
                        const Plan& pool,
                        const FitPlanSpec& spec,
                        const RigConfig& rig,
                        const PlanFitFn& fit);

/// Rig seconds of measuring a candidate of predicted luminance `predicted` (1/sr) at incidence
/// cos_i, from the exposures the journal's measurements took: the exposure scales as
/// 1 / (f cos_i) (the median of exposure x f x cos_i over them), clamped to the exposures seen,
/// twice (an auto-exposure trial), plus the settle and readout of the rig. Without a prediction
/// the median exposure.
double candidate_cost_s(const std::vector<JournalRecord>& measured,
                        const RigConfig& rig,
                        double predicted,
                        double cos_i);

}  // namespace gonio::acquisition
