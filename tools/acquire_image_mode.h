#pragma once

// `gonio acquire --mode image`: the command's side of an image-mode campaign. The campaign itself
// (rig start-up, folder, settings, journal, resume, outputs) is acquisition::run_image_request;
// this serves the live page through its hooks and prints the progress and the summary.

#include <string>

#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/devices/camera.h"
#include "gonio/report/image.h"

namespace gonio::tools {

/// Width of the camera frames the live page shows, px (a frame narrower than this is shown at its
/// own size).
constexpr int kLiveFrameWidth = 480;

/// A camera frame as the live page shows it: 8-bit grey, box-averaged down to at most `max_width`
/// px wide (aspect kept), each pixel sqrt((counts - black) / (saturation - black)) clamped to
/// [0, 1] (a display gamma that keeps the dim parts of a linear frame visible; saturated pixels
/// white). Frames that are not 16-bit or float are converted as they are.
report::Image live_frame_picture(const devices::Frame& frame, int max_width);

/// The caption of such a picture: `what` (the pose, filter or role of the frame), the frame's id,
/// exposure and size, and how its counts are shown.
std::string live_frame_description(const devices::Frame& frame,
                                   const report::Image& picture,
                                   const std::string& what);

/// Runs an image campaign (new or resumed) for the request and prints its progress and summary;
/// with `serve_port` >= 0 (0: a free port) serves its live page at serve_host. Returns the exit
/// status: 0 success, 1 failure with the error printed or the coverage target not met.
int run_acquire_image_mode(const acquisition::CampaignRequest& request,
                           const std::string& serve_host,
                           int serve_port);

/// Prints the plan of an image campaign (request.plan_only): table, coverage target and the light
/// arm's range, without touching a device. Returns the exit status (0, or 1 with the error).
int print_image_plan(const acquisition::CampaignRequest& request);

}  // namespace gonio::tools
