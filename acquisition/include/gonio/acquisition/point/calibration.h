#pragma once

// Absolute calibration with a white reference (docs/calibration.md derives it). A diffuse standard
// of hemispherical reflectance rho (Lambertian: f_w = rho / pi) measured at incidence theta_w gives
// the signal rate r_w (dark-subtracted counts per microsecond at unit gain). The detector's counts
// are proportional to the radiance L = f E cos(theta_i) of the patch it sees, so for the sample,
// with the same lamp and detector:
//
//     f(wi, wo) = (r / r_w) * (rho / pi) * cos(theta_w) / cos(theta_i)            [1/sr]
//
// per channel. The uncertainty reported with f propagates the sample's rate uncertainty only:
// sigma_f = f sigma_r / r; the white reference's own uncertainty is a common scale factor of the
// whole dataset, recorded separately (WhiteCalibration::rate_sigma).

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::acquisition {

struct WhiteCalibration {
    double reflectance = 0.99;             ///< rho of the standard.
    double cos_theta_w = 1;                ///< Incidence on the standard.
    brdf::Rgbd rate = brdf::Rgbd::Zero();  ///< Signal rate on the standard, counts/us.
    brdf::Rgbd rate_sigma = brdf::Rgbd::Zero();
};

/// Checks a calibration: rates finite and > 0, reflectance in (0, 1], cos_theta_w in (0, 1].
Expected<void> validate(const WhiteCalibration& w);

struct BrdfValue {
    brdf::Rgbd value = brdf::Rgbd::Zero();  ///< 1/sr
    brdf::Rgbd sigma = brdf::Rgbd::Zero();
};

/// Converts a sample's signal rate to BRDF (formula above). cos_theta_i <= 0 (light at or below the
/// sample's horizon) has no BRDF: an error, never a division by zero.
Expected<BrdfValue> rate_to_brdf(const WhiteCalibration& w,
                                 const brdf::Rgbd& rate,
                                 const brdf::Rgbd& rate_sigma,
                                 double cos_theta_i);

}  // namespace gonio::acquisition
