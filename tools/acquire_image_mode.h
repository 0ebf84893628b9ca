#pragma once

// `gonio acquire --mode image`: prints the run of acquisition::run_image_request (the campaign,
// its rig set-up and its rules live in gonio::acquisition; the embedded virtual rig comes from
// embedded_rig.h) and maps its outcome to an exit status.

#include "gonio/acquisition/campaign_request.h"

namespace gonio::tools {

/// Runs the campaign (or prints its plan for request.plan_only) and prints a summary; returns the
/// process exit status (0 success, 1 failure with the error printed or the coverage target not
/// met).
int run_acquire_image_mode(const acquisition::CampaignRequest& request);

}  // namespace gonio::tools
