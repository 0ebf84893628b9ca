#pragma once

// `gonio acquire --mode image`: an image-mode campaign (a sphere of the material imaged by the
// camera on the detector arm) on the embedded simulated rig, writing the dataset CSV, the table,
// the coverage map and the metadata into a folder. The subcommand parses its options into
// AcquireImageOptions and calls run_acquire_image_mode().

#include <cstdint>
#include <memory>
#include <string>

#include "gonio/acquisition/image_campaign.h"
#include "gonio/brdf/brdf.h"
#include "gonio/sim/sphere_render.h"

namespace gonio::tools {

struct AcquireImageOptions {
    std::string out_dir;  ///< Output folder; empty: a new folder image-<material>-<n>.
    std::string material = "red-plastic";  ///< Ground truth by name (data/materials/).
    std::string brdf_path;                 ///< Or a model JSON / table file (takes precedence).
    std::string rig_path;  ///< Rig description with a "camera_model"; empty: default.
    /// Fraction of the valid bins. What a sphere image can reach depends on its size in pixels
    /// (the smallest theta_h bins) and on the 80-degree limits: the default camera reaches about
    /// 60% of a 30 x 30 x 60 table.
    double coverage_target = 0.55;
    int max_frames = 200;
    int table_factor = 3;      ///< 1 = MERL 90 x 90 x 180, 2 = 45 x 45 x 90, 3 = 30 x 30 x 60
    int image_size = 256;      ///< Default camera sensor size (square), px.
    bool perspective = false;  ///< Default camera: perspective at 0.5 m instead of telecentric.
    std::uint64_t seed = 1;
    bool quiet = false;
};

/// Runs the campaign and prints a summary; returns the process exit status (0 success, 1 failure
/// with the error printed, 3 when the coverage target was not met).
int run_acquire_image_mode(const AcquireImageOptions& options);

/// The embedded simulated image rig: camera model, sphere scene and sensor.
struct SimulatedImageRig {
    acquisition::CameraModel camera;
    sim::SphereScene scene;
    std::unique_ptr<sim::SensorModel> sensor;
    sim::ExposureSettings settings;
    std::shared_ptr<const brdf::Brdf> sample;
    std::shared_ptr<const brdf::Brdf> reference;  ///< Lambertian white sphere, albedo 0.99.
};

/// A rig with the default camera (or `camera` when given a model), the sphere at the origin.
std::shared_ptr<SimulatedImageRig> make_simulated_image_rig(
    std::shared_ptr<const brdf::Brdf> sample,
    const acquisition::CameraModel* camera,
    int image_size,
    bool perspective,
    std::uint64_t seed);

/// Capture function rendering the rig's sphere (or the white reference) through its sensor.
acquisition::CaptureFn simulated_capture(std::shared_ptr<SimulatedImageRig> rig);

/// Campaign settings matching the simulated rig (sensor noise figures, exposures).
acquisition::ImageCampaignConfig simulated_campaign_config(const SimulatedImageRig& rig,
                                                           int table_factor,
                                                           double coverage_target,
                                                           int max_frames);

}  // namespace gonio::tools
