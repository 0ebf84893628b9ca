#pragma once

// The virtual rig's instrument: the errors a real gonioreflectometer adds to what its encoders and
// lamp settings say, drawn once from the rig's error budget (brdf/rig_error_budget.h) with a seed,
// and then per move and per exposure from counters, so that a campaign run twice with one seed
// sees the same instrument and the same scatter:
// - each arm's zero offset and the tilt of its rotation axis (fixed for the instrument), and a
//   fresh repeatability error after every move of the arm;
// - the lamp: a fluctuation per exposure and a linear drift with rig time (its rate drawn once);
// - stray light, an added radiance; the detector's non-linearity lives in the sensor model.

#include <cstdint>

#include "gonio/brdf/coords.h"
#include "gonio/brdf/rig_error_budget.h"

namespace gonio::sim {

/// A standard normal number from (seed, stream, n) alone (splitmix64 words, Box-Muller): the same
/// arguments give the same number in any order of calls.
double seeded_normal(std::uint64_t seed, std::uint64_t stream, std::uint64_t n);

enum class Arm {
    kLight,     ///< the light arm
    kDetector,  ///< the detector arm
};

class InstrumentErrors {
  public:
    InstrumentErrors(const brdf::RigErrorBudget& budget, std::uint64_t seed);

    const brdf::RigErrorBudget& budget() const { return budget_; }
    /// The arm's true angle (radians) when its encoder reads `angle_rad` after its `move`-th move.
    double arm_angle(Arm arm, double angle_rad, std::uint64_t move) const;
    /// The arm's true direction in the world frame (rig_geometry.h): the direction at the true
    /// angle, turned out of the arm plane by the tilt of the arm's axis (a rotation about W_y).
    brdf::Vec3d arm_direction(Arm arm, double angle_rad, std::uint64_t move) const;
    /// Lamp irradiance factor of exposure n (1, 2, ...) at `hours` of rig time:
    /// (1 + drift_rate * hours) (1 + fluctuation * z_n).
    double lamp_factor(std::uint64_t exposure, double hours) const;
    /// The drawn drift rate, relative change per hour.
    double drift_rate_per_hour() const { return drift_rate_; }
    /// The drawn zero offset and axis tilt of an arm, radians.
    double zero_offset_rad(Arm arm) const { return zero_[static_cast<int>(arm)]; }
    double axis_tilt_rad(Arm arm) const { return tilt_[static_cast<int>(arm)]; }
    /// Stray radiance for a beam of irradiance E: stray_light * E / pi, W m^-2 sr^-1.
    double stray_radiance(double irradiance_w_m2) const;

  private:
    const brdf::ArmErrors& arm_budget(Arm arm) const;

    brdf::RigErrorBudget budget_;
    std::uint64_t seed_;
    double zero_[2] = {0, 0};
    double tilt_[2] = {0, 0};
    double drift_rate_ = 0;
};

}  // namespace gonio::sim
