#pragma once

// The fit-driven plan with fly scans (`gonio acquire --plan fit --fly`): each batch is chosen as
// sweeps, not points.
//
// The pool is a set of sweep lines: the sample tilted by tau (the arm plane that far from the
// sample normal), the light arm standing at b, the detector arm turning through frames
// kFitSweepGapRad apart on one side of the light (beyond the blind zone, farther from the normal
// than the light, both directions within the plan's theta_max). Isotropy and the mirror
// symmetries of the rig make tau >= 0 and b >= 0 enough (b = 0 on one side only); reciprocity
// makes a light sweep, and a detector nearer the normal, the same lines. An anisotropic sample
// (FitPlanSpec::anisotropic) is measured at every azimuth: each line stands at one of the spins
// every 30 deg of a full turn (a half turn for a 2-fold sample), with the light on both sides of
// the normal (one side for a mirror-symmetric sample), and its frames keep both azimuths. The
// spin stands during a sweep (it turns directions along small circles, fly_plan.h): the azimuth
// is resolved by the choice among the spins' lines, each move to another spin counted in the
// sweep's rig seconds. Every frame is a candidate of the fit (plans/plan_fit.h); a candidate sweep
// is a run of consecutive frames of one line (a window), at most kMaxSweepFrames long.
//
// A batch is chosen greedily: the window of most expected information per second of rig time,
//   sum over its frames not yet measured of 1/2 ln(1 + (var ln f + misfit) / s^2)
//   / (move into it + settle + the sweep's trapezoid at the speed its smear allows + readouts),
// the move counted from where the previous sweep left the rig (the first from the last
// measurement in the journal); after each choice the covariance takes the rank-one update of each
// of its frames and their misfit counts as explained. Then the space-filling share: sweeps of
// kSpaceSweepFrames frames around the frame farthest from everything measured or chosen (the
// first batch is such sweeps of half its count each). Sweeps
// are added until the batch holds at least its count of configurations (never beyond the
// budget). Everything is a function of the journal, so a resume rebuilds the batch it was in.

#include <cstddef>
#include <string>
#include <vector>

#include "gonio/acquisition/plans/plan_fit.h"
#include "gonio/acquisition/point/fit_pass.h"
#include "gonio/acquisition/point/fly_plan.h"
#include "gonio/acquisition/shared/rig_config.h"

namespace gonio::acquisition {

/// Arm travel between two frames of a pool line: 2 deg, a fifth of the specular lobe's width at
/// GGX alpha 0.05 (about 10 deg of the view direction at its half maximum).
inline constexpr double kFitSweepGapRad = 2.0 * brdf::kPi / 180;
/// The longest candidate sweep, frames (46 deg of arm travel).
inline constexpr int kMaxSweepFrames = 24;
/// Frames of a space-filling sweep.
inline constexpr int kSpaceSweepFrames = 4;

/// One line of the fly pool.
struct SweepLine {
    int axis = static_cast<int>(AxisRole::kDetector);  ///< The moving arm.
    brdf::RigPosed stand;  ///< The pose of the first frame (spin 0 for an isotropic pool).
    std::vector<std::size_t> frames;  ///< Pool positions, in increasing arm angle.
    std::vector<double> angles;       ///< The moving arm's angle at each frame, rad.
    double speed = 0;                 ///< rad/s, by the smear rule (fly_plan.h).
    double ramp = 0;                  ///< Lead-in (and lead-out) travel, rad.
};

/// The fly pool: every frame as a configuration (index = position) and the lines through them.
struct FitSweepPool {
    Plan pool;
    std::vector<SweepLine> lines;
    std::vector<std::size_t> line_of;  ///< The line of each pool position.
    std::vector<std::size_t> step_of;  ///< Its position along the line.
    bool anisotropic = false;          ///< The lines stand at their spins (else at any).
    AxisRange spin_range;              ///< Where the spin axis may turn.
};

/// The rig's bounds on sweeps (axes, camera readout and exposures).
FlyLimits fly_limits_of(const RigConfig& rig);

/// The fly pool of a fit plan, isotropic or anisotropic: lines within the rig's limits (a frame it
/// cannot reach or outside the scene's ROI, when `scene` is given, splits its line). Errors: the
/// plan's settings out of range, an unreadable scene, no line at all.
Expected<FitSweepPool> fit_sweep_pool(const FitPlanSpec& spec,
                                      const FlySpec& fly,
                                      const std::string& scene,
                                      const RigConfig& rig);

/// What choose_sweeps needs besides the candidates.
struct SweepChoiceInput {
    const FitSweepPool* pool = nullptr;
    const std::vector<MeasuredForPlan>* measured = nullptr;
    const FitView* fit = nullptr;  ///< Null: every sweep fills space.
    double noise_rel_var = 1e-4;   ///< s^2
    brdf::RigPosed start;          ///< Where the rig stands before the batch.
    std::array<AxisDynamics, kNumAxes> dyn;
    double overhead_s = 0;                 ///< Per sweep: settle and the dark frames.
    double readout_s = 0;                  ///< Per frame.
    int space_frames = kSpaceSweepFrames;  ///< Frames of a space-filling sweep.
};

/// A batch of sweeps: the frames chosen (pool positions, sweep by sweep in arm order) and why.
struct SweepChoice {
    BatchChoice frames;
    std::size_t sweeps = 0;
    std::vector<double> score;  ///< Information per rig second of each information sweep.
};

/// The next batch: sweeps until at least `options.count` frames are chosen (each sweep's frames
/// at most what is left of `max_frames`).
SweepChoice choose_sweeps(const std::vector<CandidateForPlan>& candidates,
                          const SweepChoiceInput& in,
                          const FitChoiceOptions& options,
                          int max_frames);

/// Rig seconds of window [s, e] of `line` entered from `at` (at its nearer end): the move (an
/// anisotropic pool's spin turned to the line's, the nearer way within its range), the sweep's
/// trapezoid with its ramps, the overhead and the readouts of its frames.
double sweep_cost_s(const SweepLine& line,
                    std::size_t s,
                    std::size_t e,
                    const brdf::RigPosed& at,
                    const SweepChoiceInput& in,
                    brdf::RigPosed* exit_pose);

/// The first batch: spec.first frames in space-filling sweeps of max(kSpaceSweepFrames,
/// spec.first / 2) frames (two sweeps of 8 by default: each far move buys a longer sweep).
Plan fit_first_sweeps(const FitSweepPool& pool, const FitPlanSpec& spec);

/// Batch `pass` (>= 1) from the journal's measurements of the passes before it (fit_pass.h's
/// rules), chosen as sweeps.
FitBatch fit_next_sweeps(const std::vector<JournalRecord>& records,
                         int pass,
                         const FitSweepPool& pool,
                         const FitPlanSpec& spec,
                         const RigConfig& rig,
                         const PlanFitFn& fit);

}  // namespace gonio::acquisition
