#pragma once

// Rig kinematics with limits: which axis positions realise a target (wi, wo), choosing among the
// solutions the one that costs the least motion from the current pose, and why a target cannot be
// reached. The pure geometry (frames, forward, inverse) is in gonio/brdf/rig_geometry.h.

#include <array>
#include <string>

#include "gonio/base/error.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {

/// Axis roles in RigPose order.
enum class AxisRole {
    kLight,     ///< Light arm (rotation about the vertical world axis).
    kDetector,  ///< Detector arm (same axis as the light arm).
    kTilt,      ///< Sample tilt about the horizontal axis W_y.
    kSpin,      ///< Sample spin about its own normal.
};
constexpr int kNumAxes = 4;
const char* to_string(AxisRole r);

/// Soft range of one axis, radians.
struct AxisRange {
    double min = -brdf::kPi;
    double max = brdf::kPi;
};

/// Speed, acceleration and settle time of one axis (radians, seconds) for move-time estimates.
struct AxisDynamics {
    double speed = 0.35;  ///< rad/s (about 20 deg/s)
    double accel = 0.7;   ///< rad/s^2
    double settle_s = 0.05;
};

struct RigLimits {
    std::array<AxisRange, kNumAxes> range;
    /// Minimum angle between the arms: below it the detector shadows the lamp or the arms collide.
    double blind_angle = 0.0873;  ///< rad (5 deg)
    /// Largest polar angle measured (beyond it the projected sample no longer fills the detector
    /// ROI).
    double max_theta = 1.4835;  ///< rad (85 deg)
};

/// Time of a point-to-point move of distance d (>= 0) on a trapezoidal velocity profile with peak
/// speed v and acceleration a (symmetric deceleration): t = d/v + v/a when the cruise speed is
/// reached (d >= v^2/a), else the triangular profile t = 2 sqrt(d/a). d = 0 takes no time.
double trapezoid_time(double d, double speed, double accel);

/// A move's duration: the axes move in parallel, so the slowest axis's trapezoid decides, plus the
/// settle time of the slowest-settling axis that moved. No axis moving costs nothing.
double move_time(const brdf::RigPosed& a,
                 const brdf::RigPosed& b,
                 const std::array<AxisDynamics, kNumAxes>& dyn);

/// A target: directions in the sample frame. With `isotropic` only the canonical triple matters, so
/// the spin is left where it is and the pair may be rotated about the normal; with `reciprocal` the
/// light and detector may be exchanged.
struct Target {
    brdf::Vec3d wi;
    brdf::Vec3d wo;
    bool isotropic = true;
    bool reciprocal = true;
};

struct Solution {
    brdf::RigPosed pose;
    brdf::Vec3d wi;  ///< What the pose actually measures (forward kinematics), sample frame.
    brdf::Vec3d wo;
    bool swapped = false;  ///< Light and detector exchanged (reciprocity).
    double cost_s = 0;     ///< move_time from the current pose.
};

/// Solves a target against the limits. Candidates: both inverse solutions, the light/detector swap
/// when reciprocal, each arm and spin angle shifted by multiples of 2 pi into its range; the one
/// with the smallest move_time from `current` wins. The error explains the rule that every
/// candidate broke ("blind zone: arms 3.0 deg apart < 5.0 deg", "tilt 70.0 deg outside [-60, 60]").
Expected<Solution> solve(const Target& t,
                         const RigLimits& lim,
                         const std::array<AxisDynamics, kNumAxes>& dyn,
                         const brdf::RigPosed& current);

}  // namespace gonio::acquisition
