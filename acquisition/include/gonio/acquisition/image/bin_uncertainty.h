#pragma once

// The uncertainty an image campaign states for each row of its dataset (one per filled bin): the
// bin mean's standard error (image_binning.h; image_aniso.h for the 4-D table's rows) and the
// instrument's terms of the rig's error budget, added in quadrature by the same add_error_budget
// as a point campaign's values (point/stated_uncertainty.h, docs/error-budget.md):
// - the lamp: a frame's irradiance is common to every pixel of the frame, so its fluctuation does
//   not average down with the bin's pixel count; a bin states it as a point value does (the
//   frame's exposure and the white reference's). A bin fed by several frames averages their
//   fluctuations, for which the stated term takes no credit: an upper bound, exact for a bin of
//   one frame, which most bins are (a frame's light-to-camera angle fixes its theta_d row);
// - the drift over the campaign's rig time since its white reference (image_rig_hours);
// - the arms' angles through the BRDF's slope at the bin: the largest difference quotient to the
//   rows of the neighbouring bins, one step along each axis of the table (O(bins): the table's
//   grid gives every row its neighbours);
// - stray light and the detector's non-linearity, as for a point value.
// With the quiet budget every sigma is the row's standard error.

#include <cstdint>
#include <string>

#include "gonio/acquisition/image/image_aniso.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/rig_error_budget.h"

namespace gonio::acquisition {

struct ImageCampaignConfig;
struct ImageCampaignResult;

/// The table's dataset (BinnedTable::to_dataset) with the budget's terms in every sigma.
brdf::Dataset stated_dataset(const BinnedTable& table,
                             const std::string& source,
                             std::uint32_t min_count,
                             bool hdr,
                             const brdf::RigErrorBudget& budget,
                             double hours_since_white);

/// The 4-D table's dataset (AnisoTable::to_dataset) with the budget's terms in every sigma (the
/// slope over the configuration distance without the isotropic foldings).
brdf::Dataset stated_dataset(const AnisoTable& table,
                             const std::string& source,
                             std::uint32_t min_count,
                             bool hdr,
                             const brdf::RigErrorBudget& budget,
                             double hours_since_white);

/// The campaign's rig time since its white reference, hours: the exposures of every capture and
/// the moves between its frames' poses (kinematics.h: move_time with the configuration's axis
/// dynamics), resumed frames included.
double image_rig_hours(const ImageCampaignResult& result, const ImageCampaignConfig& config);

/// The campaign's dataset as written to dataset.csv: the 4-D table's for an anisotropic campaign,
/// else the half/difference table's, with the configuration's error budget over
/// image_rig_hours.
brdf::Dataset image_campaign_dataset(const ImageCampaignResult& result,
                                     const ImageCampaignConfig& config);

}  // namespace gonio::acquisition
