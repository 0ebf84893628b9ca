#pragma once

// Steps 1 and 2 of an image campaign (image_campaign.h): the white reference's calibration
// constants and the sample sphere, captured or read back from the journal's set-up record.

#include <optional>
#include <string>

#include "gonio/acquisition/image/image_journal.h"
#include "hdr_capture.h"

namespace gonio::acquisition::detail {

/// The set-up of `result` (calibration, spheres, their captures): from the journal when it holds
/// one (its layout, kind and detector arm must match the configuration), else captured with the
/// light at `front` and recorded in the journal when there is one.
Expected<void> set_up_campaign(Rig& rig,
                               const ImageCampaignConfig& cfg,
                               std::optional<ImageJournal>& journal,
                               const std::string& journal_path,
                               double front,
                               ImageCampaignResult* result);

}  // namespace gonio::acquisition::detail
