#pragma once

// The error budget of a gonioreflectometer: the instrument's own contributions to the uncertainty
// of a BRDF value beside the detector's shot and read noise, as the rig description states them
// ("error_budget", docs/error-budget.md). Both ends read the same description: the virtual rig
// draws its instrument from these standard uncertainties (a lamp that fluctuates and drifts, arms
// whose zero, axis and repeatability are off, stray light, a non-linear detector) and acquisition
// states the uncertainty of every value from them (the measurement equation's sensitivity
// coefficients times these terms, added in quadrature).
//
// Every term is a standard uncertainty (k = 1). The "reference" profile is sized so that a matte
// sample's combined relative uncertainty is about 0.25 % (0.5 % at k = 2), the expanded
// uncertainty published for national-laboratory goniospectrometers; "quiet" is the detector alone.

#include <string>

#include "gonio/base/error.h"

namespace gonio::brdf {

/// One arm's angular terms, degrees (standard uncertainties).
struct ArmErrors {
    /// Scatter of the arm's angle from one move to the next (a fresh draw after every move).
    double repeatability_deg = 0;
    /// Error of the arm's zero (index) position: a fixed offset of every angle.
    double zero_offset_deg = 0;
    /// Tilt of the arm's rotation axis from the vertical of the arm plane: the arm's direction
    /// leaves the plane by up to this angle (misalignment).
    double axis_tilt_deg = 0;
};

struct RigErrorBudget {
    /// "reference", "quiet", or "custom" (an object that changes a profile's terms).
    std::string profile = "reference";
    /// Relative scatter of the lamp's irradiance from one exposure to the next.
    double lamp_fluctuation = 0;
    /// Relative change of the lamp's irradiance per hour of rig time (a linear drift whose rate
    /// the virtual rig draws with this standard deviation).
    double lamp_drift_per_hour = 0;
    ArmErrors light_arm;
    ArmErrors detector_arm;
    /// Stray light reaching the detector, as a fraction of the radiance of a perfect diffuser at
    /// normal incidence (E / pi): a BRDF offset of stray_light / (pi cos theta_i), 1/sr.
    double stray_light = 0;
    /// Detector non-linearity: the response is x (1 + nonlinearity (x - 1/2)) for a signal x in
    /// units of the full scale; the relative error of a ratio of two signals is at most this.
    double nonlinearity = 0;
};

/// The profile sized from a published instrument (docs/error-budget.md gives the budget).
RigErrorBudget reference_error_budget();
/// No instrument terms (the detector's noise only).
RigErrorBudget quiet_error_budget();

/// The "error_budget" of a rig description (its JSON text): absent, the reference profile; a
/// string names a profile; an object {"profile": NAME, "lamp": {"fluctuation", "drift_per_hour"},
/// "light_arm"/"detector_arm": {"repeatability_deg", "zero_offset_deg", "axis_tilt_deg"},
/// "stray_light", "nonlinearity"} changes the named profile's terms (reference when not named).
/// Errors name `source` and the key ("rig.json: error_budget.lamp.fluctuation = -1 ...").
Expected<RigErrorBudget> read_error_budget(const std::string& rig_json, const std::string& source);

/// Combined angular standard uncertainty of one arm's direction, radians.
double arm_direction_sigma_rad(const ArmErrors& arm);

/// The relative standard uncertainty of a BRDF value that the budget's relative terms give
/// (lamp fluctuation in the value's exposure and in the white reference's, the drift over
/// `hours_since_white` of rig time, the non-linearity), added in quadrature.
double relative_sigma(const RigErrorBudget& b, double hours_since_white);

/// The relative standard uncertainty common to every value of a campaign: the white reference's
/// exposure (its lamp fluctuation) and the non-linearity between its level and the sample's. A
/// fit's amplitudes (diffuse albedo, lobe scale) carry it whole however many values there are.
double common_relative_sigma(const RigErrorBudget& b);

/// The BRDF offset stray light gives at incidence cos_theta_i (> 0), 1/sr.
double stray_light_brdf(const RigErrorBudget& b, double cos_theta_i);

}  // namespace gonio::brdf
