#pragma once

// The rig description (JSON, data/rigs/*.json; schema in docs/operator-guide.md): each axis's role,
// connection, drive profile, limits and motion; the camera; the light shutter; the optional
// reference changer; the geometry limits; the capture settings; the white reference.

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gonio/acquisition/image/placement.h"
#include "gonio/acquisition/point/capture.h"
#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/base/error.h"
#include "gonio/brdf/rig_error_budget.h"
#include "gonio/devices/axis.h"
#include "gonio/devices/camera.h"
#include "gonio/devices/filter_wheel.h"

namespace gonio::acquisition {

struct AxisConfig {
    std::string name;     ///< Name in messages ("light arm").
    std::string address;  ///< tcp://127.0.0.1:PORT or rtu:/dev/ttyUSB0?baud=115200
    int unit = 1;
    std::string profile = "generic";
    devices::SoftLimits limits;
    devices::Motion motion;
    /// Fly scans: whether the drive's position compare output is wired to the camera's trigger
    /// input Line1 ("position_compare"; absent: whether the profile has the registers). false:
    /// the host polls the encoder and triggers in software.
    std::optional<bool> position_compare;
};

/// A Modbus coil that switches something (the lamp shutter, the reference changer).
struct CoilConfig {
    std::string address;
    int unit = 0;
    int coil = 0;
};

/// A zoomed camera placement of image mode (placement.h) and the coil that switches it in.
struct PlacementConfig {
    Placement placement;
    CoilConfig coil;
};

struct CaptureConfig {
    double target_fraction = 0.6;  ///< Auto exposure puts the ROI's 99th percentile here.
    /// Counts above this fraction of the range are treated as clipped: sensors leave the linear
    /// range (full well) before the digital maximum the frame reports.
    double linear_max_fraction = 0.85;
    double min_exposure_us = 20;
    double max_exposure_us = 200000;
    int max_brackets = 3;
    double bracket_ratio = 8;        ///< Exposure ratio between bracket steps.
    double hdr_low_fraction = 0.02;  ///< Bracket when the ROI's 1st percentile is below this.
    int dark_frames = 2;             ///< Frames averaged into a dark frame.
    double roi_fraction = 0.3;       ///< Side of the centred square ROI / min(width, height).
    double gain = 1;
    int timeout_ms = 5000;
};

struct RigConfig {
    std::string name;
    std::string source;  ///< Path it was read from.
    std::string json;    ///< The JSON text (kept in the campaign folder and the sidecar).
    std::array<AxisConfig, kNumAxes> axes;  ///< Indexed by AxisRole.
    std::string camera_address;
    /// Time to read one frame out of the camera ("camera": {"readout_ms"}), counted in the rig
    /// time of a campaign (0 when not given).
    double camera_readout_ms = 0;
    /// The instrument's error budget ("error_budget", brdf/rig_error_budget.h): the terms a
    /// point campaign adds to each value's stated uncertainty (the reference profile when absent).
    brdf::RigErrorBudget error_budget;
    CoilConfig shutter;
    std::optional<CoilConfig> reference_changer;  ///< Puts the white reference into the beam.
    /// Colour filter changer: the coils of the red, green and blue filters ("filter_wheel":
    /// {"address": ..., "filters": [{"unit", "coil"} x 3]}; the address defaults to the shutter's).
    /// Without it the detector is measured unfiltered once per configuration and r = g = b
    /// (monochrome dataset).
    std::optional<std::array<CoilConfig, 3>> filter_wheel;
    double blind_angle_deg = 5;
    double max_theta_deg = 85;
    double white_reflectance = 0.99;  ///< Hemispherical reflectance of the white standard.
    double white_theta_i_deg = 0;     ///< White-reference geometry (0/45 by default).
    double white_theta_o_deg = 45;
    NoiseModel noise;
    CaptureConfig capture;
    /// Image mode: radius of the sample (and white reference) sphere, metres
    /// ("image_sample": {"sphere_radius_m"}).
    double sphere_radius_m = 0.02;
    /// Image mode: zoomed camera placements ("placements": [{"name", "magnification",
    /// "offset_m": [x, y], "unit", "coil", "address"}], the address defaulting to the
    /// shutter's); none: the wide view only.
    std::vector<PlacementConfig> placements;
    int move_timeout_ms = 60000;
    int retries = 3;  ///< Attempts per measurement after a device error before pausing.
};

Expected<RigConfig> parse_rig_config(const std::string& json_text, const std::string& source);
Expected<RigConfig> read_rig_config(const std::string& path);

/// The same rig with its connections replaced: every axis, the shutter, the reference changer and
/// the filter wheel on `motor_address`; the camera at `camera_address` (empty keeps the value). The
/// JSON text is updated too.
RigConfig with_addresses(const RigConfig& rig,
                         const std::string& motor_address,
                         const std::string& camera_address);

RigLimits rig_limits(const RigConfig& rig);
std::array<AxisDynamics, kNumAxes> rig_dynamics(const RigConfig& rig);

/// The opened devices of a rig.
struct RigDevices {
    std::array<std::unique_ptr<devices::Axis>, kNumAxes> axes;
    std::unique_ptr<devices::Camera> camera;
    std::unique_ptr<devices::Light> shutter;
    std::unique_ptr<devices::Light> reference_changer;   ///< Null when the rig has none.
    std::unique_ptr<devices::FilterWheel> filter_wheel;  ///< Null when the rig has none.
    /// One coil per zoomed camera placement (RigConfig::placements), in their order.
    std::vector<std::unique_ptr<devices::Light>> placements;
};

/// Opens every device of the rig (nothing moves yet). The error names the device.
Expected<RigDevices> open_rig(const RigConfig& rig);

}  // namespace gonio::acquisition
