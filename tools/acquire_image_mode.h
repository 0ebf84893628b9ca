#pragma once

// `gonio acquire --mode image`: an image-mode campaign (a sphere of the material imaged by the
// camera on the detector arm), writing the dataset CSV, the table, the coverage map and the
// metadata into a folder. With a rig description that has a "sim" section (the default,
// data/rigs/sim-image.json) the embedded virtual rig (sim::SimRig with its sphere option) serves
// its motor controllers on Modbus TCP and its camera as a GigE Vision device on a loopback address
// of its own; without one, the description's devices are used at their addresses (a real rig, or
// a virtual rig served elsewhere). Either way the campaign opens them through the same path as a
// point-mode campaign (acquisition::open_rig) and captures through
// acquisition::make_device_capture. The subcommand parses its options into AcquireImageOptions and
// calls run_acquire_image_mode().

#include <cstdint>
#include <memory>
#include <string>

#include "embedded_rig.h"
#include "gonio/acquisition/campaign_request.h"
#include "gonio/acquisition/image_campaign.h"
#include "gonio/acquisition/rig_config.h"
#include "gonio/devices/camera.h"
#include "gonio/report/image.h"
#include "gonio/sim/sim_rig.h"
#include "gonio/sim/sphere_imaging.h"

namespace gonio::tools {

struct AcquireImageOptions {
    std::string out_dir;  ///< Output folder; empty: a new folder image-<material>-<n>.
    std::string material = "red-plastic";  ///< Ground truth by name (data/materials/).
    std::string brdf_path;                 ///< Or a model JSON / table file (takes precedence).
    /// Rig description (data/rigs/sim-image.json when empty); its "camera_model", when present,
    /// is the camera, else (virtual rig only) the default image camera of image_size /
    /// perspective. With a "sim" section the embedded virtual rig serves it (ground truth:
    /// material / brdf_path); without one its devices are opened at their addresses.
    std::string rig_path;
    /// Fraction of the valid bins. What a sphere image can reach depends on its size in pixels
    /// (the smallest theta_h bins) and on the 80-degree grazing limits: the default
    /// camera reaches about 60% of a 30 x 30 x 60 table.
    double coverage_target = 0.55;
    int max_frames = 200;
    int table_factor = 3;  ///< 1 = MERL 90 x 90 x 180, 2 = 45 x 45 x 90, 3 = 30 x 30 x 60
    /// Table bins (theta_h x theta_d x phi_d); all zero: from table_factor.
    acquisition::TableLayout grid{0, 0, 0};
    /// Continue the campaign in this folder (its image_campaign.json and frames.journal); the
    /// options above are then read from the folder.
    std::string resume_dir;
    int image_size = 256;      ///< Default camera sensor size (square), px.
    bool perspective = false;  ///< Default camera: perspective at 0.5 m instead of telecentric.
    int supersample = 2;       ///< Sub-pixel rays per axis of the simulated sphere image.
    double time_scale = 0;     ///< Virtual rig motion time scale (> 0 overrides the rig's).
    std::uint64_t seed = 1;
    bool quiet = false;
    std::string sample;         ///< Sample name in the metadata (default: the ground truth's name).
    std::string operator_name;  ///< Operator name in the metadata (none when empty).
    std::string campaigns_dir;  ///< Parent of an automatically named folder (current folder).
    /// Live page of the campaign (report::LiveServer) at serve_host:serve_port once the folder is
    /// known; not served when serve_port < 0 (0: a free port). Its URL is printed before the
    /// first capture.
    std::string serve_host = "127.0.0.1";
    int serve_port = -1;
};

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

/// Runs the campaign and prints a summary; returns the process exit status (0 success, 1 failure
/// with the error printed or the coverage target not met). The folder holds, from the start, the
/// campaign's settings (image_campaign.json, the ground-truth file copied beside it) and its frame
/// journal (frames.journal, acquisition/image_journal.h), so that an interrupted campaign resumes
/// with `resume_dir`.
int run_acquire_image_mode(const AcquireImageOptions& options);

/// The options of an image-mode request (acquisition::find_conflict already passed): the fields
/// the request gives replace the defaults.
AcquireImageOptions image_options(const acquisition::CampaignRequest& request);

/// Prints the plan of an image campaign (request.plan_only): table, coverage target and the light
/// arm's range, without touching a device. Returns the exit status (0, or 1 with the error).
int print_image_plan(const acquisition::CampaignRequest& request);

/// The image rig: the devices opened through their addresses, and the embedded virtual rig
/// serving them when the description asks for it (null otherwise).
struct ImageRig {
    acquisition::RigConfig rig;  ///< With the addresses the virtual rig serves.
    acquisition::CameraModel camera;
    std::unique_ptr<sim::SimRig> sim;
    acquisition::RigDevices dev;
    acquisition::PoseCheckLog pose_log;
};

/// Reads the rig description and the camera model, starts the virtual rig with the sphere of the
/// ground truth (options.material / brdf_path) when the description has a "sim" section, and opens
/// the devices (camera: Mono16, full sensor, the rig's capture gain).
Expected<std::unique_ptr<ImageRig>> start_image_rig(const AcquireImageOptions& options);

/// Capture function over the rig's devices (acquisition::make_device_capture): the light arm,
/// the detector arm at `detector_arm_rad` (both read back around every exposure), the lamp
/// shutter, the filter wheel coils and the reference changer. `rig` must outlive it.
acquisition::CaptureFn image_rig_capture(ImageRig& rig, double detector_arm_rad);

}  // namespace gonio::tools
