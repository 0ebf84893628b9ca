#pragma once

// The uncertainty a point campaign states for each BRDF value: the detector's noise (from the
// pixel statistics of its exposures, already in the sample's sigma) and the instrument's terms of
// the rig description's error budget (brdf/rig_error_budget.h, docs/error-budget.md), added in
// quadrature:
//   u^2 = u_detector^2 + (f u_rel)^2 + u_stray^2 + (s u_dir)^2
// with u_rel the budget's relative terms (lamp fluctuation twice, drift over the rig time since
// the white reference, non-linearity), u_stray = stray_light / (pi cos theta_i), s the BRDF's
// slope with respect to the directions and u_dir the two arms' direction uncertainties in
// quadrature. The slope is estimated from the measured values themselves: the largest difference
// quotient |f_j - f_i| / d_ij over the configuration's nearest measured neighbours.

#include <vector>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/rig_error_budget.h"

namespace gonio::acquisition {

/// Neighbours a slope is estimated from.
inline constexpr int kSlopeNeighbours = 4;

/// Distance between two configurations, radians: the angle between the incident directions and
/// the angle between the outgoing directions in quadrature. With `isotropic` the azimuth of
/// incidence and the sign of the azimuth difference do not count (both pairs are turned to
/// phi_i = 0 and mirrored to phi_o >= 0), and light and detector may be exchanged (reciprocity).
double configuration_distance(const brdf::Sample& a, const brdf::Sample& b, bool isotropic);

/// Per channel: the largest |f_j - f_i| / d_ij over the kSlopeNeighbours nearest samples j of
/// sample i (1/sr per radian); zero without neighbours.
std::vector<brdf::Rgbd> brdf_slopes(const std::vector<brdf::Sample>& samples, bool isotropic);

/// Adds the budget's terms to every sample's sigma (its detector noise).
void add_error_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      bool isotropic,
                      std::vector<brdf::Sample>* samples);

}  // namespace gonio::acquisition
