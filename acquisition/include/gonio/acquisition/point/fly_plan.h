#pragma once

// Fly scans (docs/operator-guide.md, "Fly scans"): a pass's configurations turned into sweeps.
//
// A sweep is a run of planned configurations that one arm (light or detector) reaches while the
// three other axes stand: their solved poses differ in that arm's angle alone. The arm turns at a
// constant speed from a lead-in before the first configuration to a lead-out after the last; a
// frame is triggered as the arm's encoder passes each configuration, so that mid-exposure falls
// on it, and the drive latches where the exposure started and ended (Axis::exposure_latch_deg).
// An arm turning about a fixed axis moves its direction along a great circle at constant angular
// speed, the path the fit models (brdf/exposure_path.h); the sample's tilt and spin turn
// directions along small circles and are never swept.
//
// Speed: an exposure of t at speed v spans v t of the arm's travel (the smear). The sweep's speed
// is the largest that keeps
//   - v <= the arm's own speed (and the campaign's fly.speed_deg_per_s when given);
//   - a frame (its longest exposure t_max = smear / v, then its readout r) within half the time
//     between two configurations g / v: smear / v + r <= g / (2 v), i.e. v <= (g / 2 - smear) / r
//     (the other half is left to the trigger's latency), where g is the smallest gap between
//     neighbouring configurations of the sweep;
// and each frame's exposure is then at most t_max = smear / v (within the camera's range). A
// configuration whose frame saturates, or whose trigger the arm passed before the camera was
// ready, is measured afterwards standing (the stop-and-go measurement with its HDR brackets).

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/base/error.h"

namespace gonio::acquisition {

/// The fly-scan settings of a campaign (campaign.json "fly"; `gonio acquire --fly`).
struct FlySpec {
    bool enabled = false;
    /// Largest arc one exposure may span, degrees (the smear). The fit models the exposure's path
    /// mean, so the smear costs no bias; it bounds the sweep's speed for a given exposure.
    double max_smear_deg = 1.0;
    /// Highest sweep speed, degrees per second (0: the arm's own speed).
    double speed_deg_per_s = 0;
};

/// A reason `spec` is not usable (the field and the rule), or empty.
std::string fly_spec_problem(const FlySpec& spec);

/// One sweep: `axis` (kLight or kDetector) from `from` to `to` (radians, lead-in to lead-out) at
/// `speed` (rad/s), the other axes at `stand`; `members` index the pass's pending poses in the
/// order the arm reaches them.
struct Sweep {
    int axis = 1;
    std::vector<std::size_t> members;
    brdf::RigPosed stand;  ///< The pose at the lead-in (the moving axis at `from`).
    double from = 0;
    double to = 0;
    double speed = 0;           ///< rad/s
    double max_exposure_s = 0;  ///< smear / speed, within the camera's range.
    double smear_rad = 0;       ///< The smear bound the speed was chosen for.
};

/// A unit of a fly pass: a sweep, or one configuration measured standing (sweep.members holds
/// it alone and `standing` is set).
struct FlyUnit {
    Sweep sweep;
    bool standing = false;
};

/// What the sweeps are bounded by: the rig's axes and camera.
struct FlyLimits {
    std::array<AxisDynamics, kNumAxes> dyn;
    std::array<AxisRange, kNumAxes> range;
    double readout_s = 0;
    double min_exposure_s = 20e-6;
    double max_exposure_s = 0.2;
};

/// Poses that differ in one arm's angle by less than this are one configuration of the arm's
/// sweep apart (and the three other axes within it count as standing): a tenth of a step of the
/// coarsest shipped drive profile.
inline constexpr double kFlySameAxisRad = 1e-6;

/// The pass's pending poses turned into units in visiting order from `start`: sweeps of two or
/// more poses (largest first when a pose could join several), the rest standing; then ordered by
/// nearest entry (a sweep entered at the nearer of its ends, run in that direction). A sweep whose
/// lead-in or lead-out leaves its arm's range is measured standing.
std::vector<FlyUnit> plan_fly_units(const std::vector<brdf::RigPosed>& poses,
                                    const brdf::RigPosed& start,
                                    const FlySpec& spec,
                                    const FlyLimits& lim);

/// The speed of a sweep whose neighbouring configurations are at least `gap_rad` apart (rad/s),
/// and the longest exposure it allows (seconds), by the rule at the top of this file.
struct SweepSpeed {
    double speed = 0;
    double max_exposure_s = 0;
};
SweepSpeed sweep_speed(double gap_rad, int axis, const FlySpec& spec, const FlyLimits& lim);

/// The arm's angle of a pose (axis kLight or kDetector).
double axis_angle(const brdf::RigPosed& p, int axis);
void set_axis_angle(brdf::RigPosed* p, int axis, double rad);

}  // namespace gonio::acquisition
