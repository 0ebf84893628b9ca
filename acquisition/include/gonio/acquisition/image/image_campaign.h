#pragma once

// An image-mode campaign: a sphere of the material on the sample holder, the camera on the
// detector arm, the light arm moved to the positions the coverage planner chooses; every pixel on
// the sphere becomes a BRDF sample binned into the half/difference table.
//
// Per light position and colour channel (filter):
// - HDR capture: the base exposure first; pixels at or above saturation_fraction of the frame's
//   saturation level are taken again at exposure / bracket_factor, up to max_brackets exposures
//   (as in P. Debevec, J. Malik, "Recovering High Dynamic Range Radiance Maps from Photographs",
//   SIGGRAPH 1997, with a linear sensor: each pixel from the longest unsaturated exposure).
//   Dark frames (shutter closed, dark_frames averaged) are cached per exposure and subtracted.
//   Signal s = (counts - dark) / exposure_us, variance from the linear sensor model (EMVA 1288):
//     var(counts) = (counts - black) / K_e + sigma_read^2 (1 + 1/N_dark) + 1/12
//   with K_e electrons per count, sigma_read the read noise in counts, divided by exposure^2.
// - Calibration against a white reference sphere of known Lambertian albedo rho (captured first,
//   same optics): its signal is s = C_c (rho / pi) cos(theta_i), so the per-channel constant
//   C_c = median over its pixels of s / ((rho / pi) cos(theta_i)) converts any later signal into
//   the BRDF: f = s / (C_c cos(theta_i)) [1/sr]. C_c lumps irradiance, optics and sensor gain.
// - Each usable pixel (not on the edge, not grazing, lit, unsaturated in every channel) gives
//   (wi, wo) in its local frame (sphere_geometry.h) and f with its model variance, added to the
//   Welford table (image_binning.h).
//
// Anisotropic samples (config.anisotropic; image_aniso.h, docs/image-acquisition.md): the sample is
// a turned sphere whose tangent field turns with the holder's spin. Each frame is a pose (light
// arm, spin) chosen by the 4-D coverage, every pixel outside the pole caps gives (wi, wo) in the
// material's frame (normal and tangent), binned into the 4-D table; the dataset keeps both
// azimuths. Calibration, silhouette, HDR and journal work as for isotropic samples.
//
// The devices are reached through a capture function (a light-arm move, a shutter state, a filter
// and an exposure in; a frame out), so that the same campaign runs on a real rig
// (make_device_capture) or on the simulator.

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/image_aniso.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/image/image_planner.h"
#include "gonio/acquisition/image/placement.h"
#include "gonio/acquisition/image/sphere_geometry.h"
#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/acquisition/shared/rig_config.h"
#include "gonio/base/error.h"
#include "gonio/brdf/rig_error_budget.h"
#include "gonio/devices/axis.h"
#include "gonio/devices/camera.h"

namespace gonio::acquisition {

/// What one capture needs from the rig.
struct CaptureRequest {
    double light_arm_rad = 0;  ///< Light arm position (rig_geometry.h angle).
    int channel = 1;           ///< Colour filter: 0 red, 1 green, 2 blue.
    double exposure_us = 0;
    bool shutter_open = true;  ///< False: dark frame.
    bool reference = false;    ///< True: the white reference sphere is in place of the sample.
    double spin_rad = 0;       ///< Sample holder spin (anisotropic campaigns; else 0).
    /// Camera placement: 0 the wide view, k the k-th of ImageCampaignConfig::placements.
    int placement = 0;
};

using CaptureFn = std::function<Expected<devices::Frame>(const CaptureRequest&)>;

struct ImageCampaignConfig {
    CameraModel camera;
    TableLayout layout = coarse_layout(2);
    double detector_arm_rad = 0;
    LightRange lights;
    double coverage_target = 0.9;  ///< Covered fraction of the valid bins that ends the campaign.
    int max_frames = 200;          ///< Light positions at most.
    std::uint32_t min_count = 1;   ///< Samples a bin needs to count as covered.
    /// The campaign also stops when the best light position would add fewer new bins than this
    /// fraction of the valid bins (diminishing returns: the rest are holes).
    double min_gain_fraction = 0.002;
    /// Next light: the nearest candidate adding at least this fraction of the best candidate's
    /// new bins (image_planner.h: next_light).
    double light_gain_fraction = 0.5;
    ExclusionRules rules;
    SilhouetteOptions silhouette;
    int plan_pixel_stride = 2;  ///< Pixel subsampling of the coverage prediction.

    double exposure_us = 20000;        ///< Base (longest) exposure.
    double min_exposure_us = 10;       ///< Bracketing never goes below this.
    double bracket_factor = 4;         ///< Exposure ratio between brackets, > 1.
    int max_brackets = 5;              ///< Exposures per channel and position at most.
    double saturation_fraction = 0.9;  ///< Of Frame::saturation_level (counts above black).
    int dark_frames = 4;               ///< Dark frames averaged per exposure.

    double electrons_per_count = 1;  ///< Sensor conversion gain at the gain used, e-/count.
    double read_noise_counts = 0;    ///< Read noise, counts.

    /// Anisotropic sample: a turned sphere measured at several spins into the 4-D table.
    bool anisotropic = false;
    AnisoLayout aniso_layout;
    SpinRange spins;                         ///< Spin positions the plan may use.
    double pole_rad = 10 * brdf::kPi / 180;  ///< Pole caps of the turned sphere left out.

    /// Zoomed camera placements (placement.h), from the rig description. Isotropic campaigns
    /// take their frames in the wide view until no wide light position adds the stop rule's
    /// share of the valid bins, then zoomed frames (light position and placement) chosen by the
    /// same coverage rule: a zoomed view's candidates are the light positions whose highlight
    /// it sees. Anisotropic campaigns use the wide view only. The white reference and the
    /// silhouette are always taken in the wide view.
    std::vector<Placement> placements;

    /// The rig's error budget (rig_error_budget.h), stated in every bin's sigma
    /// (bin_uncertainty.h); quiet unless the configuration comes from a rig description.
    brdf::RigErrorBudget error_budget = brdf::quiet_error_budget();
    /// The axes' speed, acceleration and settle time: the rig time the campaign's moves take.
    std::array<AxisDynamics, kNumAxes> dynamics{};

    double reference_albedo = 0.99;  ///< Lambertian albedo of the white reference sphere.
    double reference_max_theta = 60 * brdf::kPi / 180;  ///< Reference pixels used up to this angle.
    std::chrono::milliseconds capture_timeout{5000};
};

/// One light position of the campaign.
struct FrameRecord {
    double light_arm_rad = 0;
    double spin_rad = 0;  ///< Holder spin (anisotropic campaigns).
    int placement = 0;    ///< Camera placement (0: the wide view).
    PixelCounts counts;
    std::array<int, 3> exposures{};  ///< Exposures used per channel (1 = no bracketing).
    double coverage_after = 0;       ///< Covered fraction of the valid bins after this frame.
};

struct ImageCampaignResult {
    explicit ImageCampaignResult(const TableLayout& layout) : table(layout), coverage(layout) {}

    BinnedTable table;
    CoverageMap coverage;
    SphereGeometry sphere;
    SphereGeometry reference_sphere;
    std::array<double, 3> calibration{};  ///< C_c per channel, (counts/us) per (1/sr).
    PixelCounts counts;                   ///< Summed over frames.
    std::vector<FrameRecord> frames;
    std::vector<CoverageHole> holes;
    std::size_t reachable_bins = 0;
    bool target_met = false;
    std::string stop_reason;  ///< "coverage target met", "no light position adds enough bins", ...
    bool bracketed = false;   ///< Some pixel needed a shorter exposure.
    std::uint64_t captures = 0;      ///< Frames captured (dark frames included).
    double exposure_time_s = 0;      ///< Sum of exposure times (the shutter-open and dark frames).
    std::size_t resumed_frames = 0;  ///< Frames read back from the journal, not captured now.
    /// Anisotropic campaigns: the 4-D table and its coverage (then `coverage` is its isotropic
    /// projection and `table` stays empty).
    std::optional<AnisoTable> aniso_table;
    std::optional<AnisoCoverage> aniso_coverage;

    /// The campaign's own coverage: of the 4-D table for an anisotropic campaign, else of the
    /// half/difference table.
    double coverage_fraction() const;
    std::size_t valid_bins() const;
    std::size_t covered_bins() const;
    std::size_t filled_bins() const;
};

/// Campaign settings for a rig description and its calibrated camera: the white reference's
/// albedo, the sphere radius and the blind zone from the rig, the sensor's conversion gain and
/// read noise from its "noise" section (at the capture gain), the light arm's limits, the detector
/// arm at 0; the table layout (factor 1 = MERL 90 x 90 x 180, f = 90/f x
/// 90/f x 180/f), coverage target and frame limit as given.
ImageCampaignConfig image_campaign_config(const RigConfig& rig,
                                          const CameraModel& camera,
                                          int table_factor,
                                          double coverage_target,
                                          int max_frames);

/// Makes `cfg` an anisotropic campaign (file comment) with the 4-D table `layout`: the light
/// positions a quarter of a theta_d row apart in separation, the holder's spin over its axis
/// limits (at most one turn) in steps of half a phi_h bin, the stop rule's smallest gain a share
/// of the 4-D table's valid bins.
void make_anisotropic(ImageCampaignConfig* cfg, const RigConfig& rig, const AnisoLayout& layout);

/// The same for any table layout (theta_h x theta_d x phi_d bins); the light positions are a
/// quarter of a theta_d row apart in separation (at most 1 degree), the grazing limits the
/// exclusion rules' defaults, never beyond the rig's max_theta_deg.
ImageCampaignConfig image_campaign_config(const RigConfig& rig,
                                          const CameraModel& camera,
                                          const TableLayout& layout,
                                          double coverage_target,
                                          int max_frames);

/// What a campaign of this configuration reaches, predicted without capturing: the nominal sample
/// sphere (radius `silhouette.radius_m` at the rig origin, as the camera model sees it) replaces
/// the fitted one, every candidate light position's bins are predicted from the frame's per-pixel
/// geometry (image_planner.h: light_candidates), and the light positions are chosen by the
/// campaign's own rules (next_light with `light_gain_fraction`, stopping at the target, at
/// `max_frames`, or when the best position adds fewer than `min_gain_fraction` of the valid bins).
/// A campaign on the rig fills at most what is predicted here (pixels lost to saturation or
/// noise, and a fitted sphere slightly off the nominal one, are not predicted).
struct ImageCoveragePrediction {
    std::vector<double> light_arm_rad;       ///< Planned light positions, in order.
    std::vector<double> predicted_coverage;  ///< Covered fraction of the valid bins after each.
    std::size_t valid_bins = 0;
    std::size_t reachable_bins = 0;  ///< Valid bins some candidate position reaches.
    std::size_t covered_bins = 0;    ///< After the planned positions.
    std::size_t candidates = 0;      ///< Candidate light positions considered.
    std::size_t sphere_pixels = 0;   ///< Pixels on the sphere within the exclusion rules.
    bool target_met = false;
    std::string stop_reason;
    std::vector<CoverageHole> holes;  ///< Empty valid bins after the plan, by reason.
    double light_travel_rad = 0;      ///< Light-arm travel from the front-light position.
    /// Anisotropic campaigns: the holder's spin of each planned pose (with light_arm_rad) and
    /// its travel from 0; the bins and holes are then those of the 4-D table (holes: of its
    /// isotropic projection).
    std::vector<double> spin_rad;
    double spin_travel_rad = 0;
    /// The camera placement of each planned light position (0: the wide view), and how many
    /// were zoomed; candidates_zoomed of the candidates are zoomed views.
    std::vector<int> placement;
    std::size_t zoomed_frames = 0;
    std::size_t candidates_zoomed = 0;
};
Expected<ImageCoveragePrediction> predict_image_coverage(const ImageCampaignConfig& config);

/// Called after each light position: index, record.
using ImageProgressFn = std::function<void(std::size_t, const FrameRecord&)>;

/// Called on the campaign thread with the campaign so far (its table, coverage and frames): once
/// when the set-up is done (with a resumed journal's frames merged) and after each new light
/// position. It must return at once (hand the data over, never draw or wait for a reader): the
/// light arm waits for it.
using ImageStateFn = std::function<void(const ImageCampaignResult& so_far)>;

/// Runs the campaign (file comment). Errors from the capture function are returned with the
/// request that failed.
///
/// With a `journal_path` (image_journal.h) the campaign is journaled and resumable: the set-up
/// (calibration, spheres) is recorded once, each frame's binned samples are appended and fsynced
/// before the light arm moves on. A journal that already holds records is resumed: its set-up
/// replaces the reference and silhouette captures (its layout and detector arm must match the
/// configuration), its frames are merged into the table and their light positions are not planned
/// again; the campaign then continues where it stopped. Progress is reported for new frames only;
/// `state` (when given) sees the campaign so far after the set-up and after each new frame.
Expected<ImageCampaignResult> run_image_campaign(const CaptureFn& capture,
                                                 const ImageCampaignConfig& config,
                                                 const ImageProgressFn& progress = {},
                                                 const std::string& journal_path = {},
                                                 const ImageStateFn& state = {});

/// Writes the campaign's outputs into `dir` (created if missing): dataset.csv (one sample per
/// filled bin, dataset.h schema with sigma and flags), dataset.json (metadata: camera, sphere,
/// calibration, counts, lights, holes, `extra` merged in), table.binary (MERL layout 90 x 90 x 180)
/// or table.gtab (any other layout), coverage.png.
Expected<void> write_image_campaign(const std::string& dir,
                                    const ImageCampaignResult& result,
                                    const ImageCampaignConfig& config,
                                    const std::string& extra_json = "{}");

/// Pose checks of a device capture function: what was found and done.
struct PoseCheckLog {
    std::size_t repeats = 0;          ///< Exposures repeated because an arm moved during them.
    std::size_t corrections = 0;      ///< Arms found off target before an exposure and moved back.
    std::size_t capture_retries = 0;  ///< Captures taken again after a camera error.
    std::vector<std::string> notes;   ///< One line per repeat, correction or retry.
};

struct DeviceCaptureOptions {
    std::chrono::milliseconds move_timeout{60000};
    /// Mechanical settling after an arm reports in position, before its position is read back
    /// (the rig description's settle_ms; a physical time, not a wait for a state).
    std::chrono::milliseconds settle{0};
    /// The detector arm (carrying the camera), when the rig has one under control: moved to
    /// detector_arm_rad before the first capture and read back with the light arm.
    devices::Axis* detector_arm = nullptr;
    double detector_arm_rad = 0;
    /// Largest read-back difference of a standing arm that is not a move, degrees (the
    /// point-mode campaign's tolerance: ten steps of the finest shipped drive profile).
    double pose_tolerance_deg = 0.01;
    /// Consecutive repeats or corrections of one capture before it fails.
    int max_pose_repeats = 5;
    /// Frame wait beyond the exposure time (doubled at each retry after a camera error).
    std::chrono::milliseconds capture_timeout{5000};
    /// Captures taken again after a camera error (a lost frame, a timeout) before the error is
    /// returned (the rig description's "retries").
    int capture_retries = 3;
    /// Receives the counts and notes when given (must outlive the capture function).
    PoseCheckLog* log = nullptr;
    /// The sample holder's spin axis (anisotropic campaigns): moved to each request's spin_rad
    /// and read back with the arms. Without it a request with a spin is an error.
    devices::Axis* spin = nullptr;
    /// Switches the camera placement (0 the wide view, k the k-th zoomed placement) before an
    /// exposure; called only when the placement changes. Without it a request for a zoomed
    /// placement is an error.
    std::function<Expected<void>(int)> select_placement;
};

/// A capture function over real devices: moves the light arm (wait at most `move_timeout`), sets
/// the shutter and the exposure, selects the filter through `select_filter` (when given; else every
/// channel is the same monochrome measurement) and captures. Reference captures need the white
/// sphere mounted: `swap_target` is called with true before the first reference capture and with
/// false before the first sample capture (a prompt to the operator, or a sample changer).
///
/// Pose integrity (as the point-mode campaign): the arms' positions are read back before and after
/// each exposure. An arm found away from its target before the exposure is moved back; one that
/// moved during the exposure (another client, a stall, a lost step) makes the capture repeat. After
/// `max_pose_repeats` such repeats in a row the capture fails with an error naming the arm, its
/// target and the positions read back. A camera error is retried `capture_retries` times (after
/// the same pose checks) before it is returned.
CaptureFn make_device_capture(devices::Camera& camera,
                              devices::Light& light,
                              devices::Axis& light_arm,
                              std::function<Expected<void>(int)> select_filter,
                              std::function<Expected<void>(bool)> swap_target,
                              const DeviceCaptureOptions& options);

/// The same with the default options and `move_timeout`.
CaptureFn make_device_capture(devices::Camera& camera,
                              devices::Light& light,
                              devices::Axis& light_arm,
                              std::function<Expected<void>(int)> select_filter,
                              std::function<Expected<void>(bool)> swap_target,
                              std::chrono::milliseconds move_timeout);

}  // namespace gonio::acquisition
