#pragma once

// `gonio acquire --mode image`: an image-mode campaign (a sphere of the material imaged by the
// camera on the detector arm) on the embedded virtual rig, writing the dataset CSV, the table, the
// coverage map and the metadata into a folder. The virtual rig (sim::SimRig with its sphere
// option) serves its motor controllers on Modbus TCP and its camera as a GigE Vision device on a
// loopback address of its own; the campaign opens them through the same path as a real rig
// (acquisition::open_rig) and captures through acquisition::make_device_capture. The subcommand
// parses its options into AcquireImageOptions and calls run_acquire_image_mode().

#include <cstdint>
#include <memory>
#include <string>

#include "gonio/acquisition/image_campaign.h"
#include "gonio/acquisition/rig_config.h"
#include "gonio/sim/sim_rig.h"
#include "gonio/sim/sphere_imaging.h"

namespace gonio::tools {

struct AcquireImageOptions {
    std::string out_dir;  ///< Output folder; empty: a new folder image-<material>-<n>.
    std::string material = "red-plastic";  ///< Ground truth by name (data/materials/).
    std::string brdf_path;                 ///< Or a model JSON / table file (takes precedence).
    /// Rig description (data/rigs/sim-image.json when empty); its "camera_model", when present,
    /// is the camera, else the default image camera of image_size / perspective.
    std::string rig_path;
    /// Fraction of the valid bins. What a sphere image can reach depends on its size in pixels
    /// (the smallest theta_h bins) and on the 80-degree limits: the default camera reaches about
    /// 60% of a 30 x 30 x 60 table.
    double coverage_target = 0.55;
    int max_frames = 200;
    int table_factor = 3;      ///< 1 = MERL 90 x 90 x 180, 2 = 45 x 45 x 90, 3 = 30 x 30 x 60
    int image_size = 256;      ///< Default camera sensor size (square), px.
    bool perspective = false;  ///< Default camera: perspective at 0.5 m instead of telecentric.
    int supersample = 2;       ///< Sub-pixel rays per axis of the simulated sphere image.
    double time_scale = 0;     ///< Virtual rig motion time scale (> 0 overrides the rig's).
    std::uint64_t seed = 1;
    bool quiet = false;
};

/// Runs the campaign and prints a summary; returns the process exit status (0 success, 1 failure
/// with the error printed or the coverage target not met).
int run_acquire_image_mode(const AcquireImageOptions& options);

/// The embedded image rig: the virtual rig serving its devices on loopback and the devices opened
/// through them.
struct ImageRig {
    acquisition::RigConfig rig;  ///< With the addresses the virtual rig serves.
    acquisition::CameraModel camera;
    std::unique_ptr<sim::SimRig> sim;
    acquisition::RigDevices dev;
    acquisition::PoseCheckLog pose_log;
};

/// The simulator's camera for a calibrated camera model (same intrinsics and pose).
sim::SphereCamera to_sphere_camera(const acquisition::CameraModel& camera);

/// Reads the rig description and the camera model, starts the virtual rig with the sphere of the
/// ground truth (options.material / brdf_path) and opens its devices (camera: Mono16, full sensor,
/// the rig's capture gain).
Expected<std::unique_ptr<ImageRig>> start_image_rig(const AcquireImageOptions& options);

/// Capture function over the rig's devices (acquisition::make_device_capture): the light arm,
/// the detector arm at `detector_arm_rad` (both read back around every exposure), the lamp
/// shutter, the filter wheel coils and the reference changer. `rig` must outlive it.
acquisition::CaptureFn image_rig_capture(ImageRig& rig, double detector_arm_rad);

}  // namespace gonio::tools
