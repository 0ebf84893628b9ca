#pragma once

// The memory an image campaign needs, estimated from its configuration before any of it is
// allocated: `gonio acquire --mode image` refuses work above the memory budget (--max-memory)
// before its campaign folder exists. Each part bounds what the coverage prediction and the
// campaign hold at their peak:
// - program: the process itself (libraries; with a rig, its drivers and the virtual rig's servers);
// - pixels: the largest view's pixel list (sphere_pixel_bound() pixels of sizeof(SpherePixel))
//   and one tile of traced rays;
// - candidates: every candidate's predicted bins, held twice (the open list and all candidates).
//   The prediction streams over a candidate's pixels (image_planner.h), so a candidate holds at
//   most the valid bins of the theta_d rows one frame spans (or the view's pixels, if fewer):
//   this part is bounded by the table, not by the camera;
// - tables: the coverage maps and the prediction's marks; a run adds its binned table and the
//   dataset written at the end (with its stated uncertainty's working arrays);
// - frames (a run only): the camera's images (the virtual camera's render and sensor, transfer
//   and stream buffers, the averaged dark frames of each exposure) and one frame's per-pixel
//   samples (HDR signal per channel, the samples binned).

#include <string>

#include "gonio/acquisition/image/image_campaign.h"
#include "gonio/base/error.h"

namespace gonio::acquisition {

struct ImageMemoryEstimate {
    double program_bytes = 0;
    double pixel_bytes = 0;
    double candidate_bytes = 0;
    double table_bytes = 0;
    double frame_bytes = 0;
    std::size_t candidates = 0;  ///< Candidate light positions (or poses) of every view.

    double total() const {
        return program_bytes + pixel_bytes + candidate_bytes + table_bytes + frame_bytes;
    }
    /// The parts: "program 128 MiB, pixels 96 MiB, candidates 310 MiB for 1480 candidates, ...".
    std::string describe() const;
};

/// The estimate of the prediction alone (`plan_only`) or of a whole campaign. `virtual_supersample`
/// is the embedded virtual camera's sub-pixel rays per axis when it renders in this process (0
/// for a camera of its own). Fails where the prediction would (the camera does not see the sphere).
Expected<ImageMemoryEstimate> estimate_image_memory(const ImageCampaignConfig& cfg,
                                                    bool plan_only,
                                                    int virtual_supersample);

}  // namespace gonio::acquisition
