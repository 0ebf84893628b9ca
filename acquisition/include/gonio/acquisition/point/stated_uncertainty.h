#pragma once

// The uncertainty a campaign states for each BRDF value (a point campaign here; an image
// campaign's bins: image/bin_uncertainty.h): the detector's noise (from the
// pixel statistics of its exposures, already in the sample's sigma) and the instrument's terms of
// the rig description's error budget (brdf/rig_error_budget.h, docs/error-budget.md), added in
// quadrature:
//   u^2 = u_detector^2 + (f u_rel)^2 + u_stray^2 + (s u_dir)^2
// with u_rel the budget's relative terms (lamp fluctuation twice, drift over the rig time since
// the white reference, non-linearity), u_stray = stray_light / (pi cos theta_i), s the BRDF's
// slope with respect to the directions and u_dir the two arms' direction uncertainties in
// quadrature. The slope is estimated from the measured values themselves: the largest difference
// quotient |f_j - f_i| / d_ij over the configuration's nearest measured neighbours (a point
// campaign: its kSlopeNeighbours nearest configurations; an image campaign's table: the rows of
// the neighbouring bins, image/bin_uncertainty.h). Both state their values' uncertainty through
// the add_error_budget below that takes the slopes.

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

/// Configurations closer than this (radians) are one configuration measured again.
inline constexpr double kSameConfiguration = 1e-6;

/// Per channel: the largest |f_j - f_i| / d_ij over the samples j in `near` (indices into
/// `samples`) other than i and at a distance d_ij > kSameConfiguration (a repeat of the same
/// configuration, a drift reference, says nothing of the slope); zero without any.
brdf::Rgbd largest_difference_quotient(const std::vector<brdf::Sample>& samples,
                                       std::size_t i,
                                       const std::vector<std::size_t>& near,
                                       bool isotropic);

/// Per channel: largest_difference_quotient over the kSlopeNeighbours nearest samples j of sample
/// i (1/sr per radian). O(n^2): the point campaign's few hundred configurations.
std::vector<brdf::Rgbd> brdf_slopes(const std::vector<brdf::Sample>& samples, bool isotropic);

/// The two arms' direction uncertainties in quadrature, radians (u_dir above).
double budget_direction_sigma(const brdf::RigErrorBudget& budget);

/// Adds the budget's terms to every sample's sigma (its detector noise, or a bin's standard
/// error), with `slopes[i]` the BRDF's slope at sample i (1/sr per radian, one per sample). The
/// quiet budget leaves every sigma as it is.
void add_error_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      const std::vector<brdf::Rgbd>& slopes,
                      std::vector<brdf::Sample>* samples);

/// The same with the slopes of brdf_slopes() (computed only when the arms' terms are not zero).
void add_error_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      bool isotropic,
                      std::vector<brdf::Sample>* samples);

}  // namespace gonio::acquisition
