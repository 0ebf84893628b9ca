#pragma once

// Steps 3 to 5 of an image campaign (image_campaign.h): the candidate poses and their predicted
// bins, the journal's frames merged, then frames until the coverage target or the stop rules.
// One loop for both kinds of campaign; what differs (the table, its coverage, the choice of the
// next pose, a frame's pixels and directions) is the campaign's path: isotropic (light positions
// and zoomed placements, the half/difference table) or anisotropic (light and spin, the 4-D
// table).

#include <optional>
#include <string>

#include "gonio/acquisition/image/image_journal.h"
#include "hdr_capture.h"

namespace gonio::acquisition::detail {

/// The frames of a set-up campaign (result's calibration and sphere known), from the front-light
/// position `front`: its anisotropic or isotropic path as the configuration asks.
Expected<void> run_frames(Rig& rig,
                          const ImageCampaignConfig& cfg,
                          std::optional<ImageJournal>& journal,
                          const std::string& journal_path,
                          double front,
                          const ImageProgressFn& progress,
                          const ImageStateFn& state,
                          ImageCampaignResult* result);

}  // namespace gonio::acquisition::detail
