#pragma once

// One acquisition job as a front end names it (`gonio acquire` options, a script): point or image
// mode, a new campaign, a resume or only the plan. The rules of which options a mode honours live
// here (find_conflict), and so do the set-up and resume rules of a campaign (start_point_campaign,
// start_image_rig): the command line fills a CampaignRequest, calls, prints.
//
// The embedded virtual rig is reached through EmbeddedRigStarter, which the caller supplies (the
// simulator lives above this library and is never named here).

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/image/image_campaign.h"
#include "gonio/acquisition/image/image_memory.h"
#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/shared/rig_config.h"
#include "gonio/base/error.h"

namespace gonio::acquisition {

enum class CampaignMode {
    kPoint,  ///< One configuration per frame, a journal, resumable (docs/operator-guide.md).
    kImage,  ///< A curved sample, thousands of samples per frame (docs/image-acquisition.md).
};

/// What to measure and how. Empty strings, zero numbers and false mean "not given"; each given
/// field is either honoured by the mode or refused by find_conflict().
struct CampaignRequest {
    CampaignMode mode = CampaignMode::kPoint;
    std::string campaign_file;  ///< campaign.json (point mode).
    std::string rig_path;       ///< Rig description (overrides the campaign's).
    std::string out_dir;        ///< Campaign folder (default: automatic under campaigns_dir).
    std::string resume_dir;     ///< Continue the campaign in this folder.
    std::string campaigns_dir;  ///< Parent of automatically named folders ("campaigns").
    std::string material;       ///< Virtual rig: named material.
    std::string brdf_path;      ///< Virtual rig: ground-truth model JSON or table.
    std::string scene;          ///< Point mode: region of interest.
    std::string sample;         ///< Sample name.
    std::string operator_name;  ///< Operator name.
    std::string plan_kind;      ///< Point mode: "uniform", "half-diff", "vndf" or "fit".
    int n_theta = 0;            ///< Point mode, uniform plan: polar angles.
    int n_dphi = 0;             ///< Point mode, uniform plan: azimuth differences.
    int adaptive = -1;          ///< Point mode: adaptive passes (-1 = the campaign's).
    /// Point mode: the anisotropic plan over (theta_i, phi_i, theta_o, phi_o) (plan.h,
    /// plan_anisotropic) with the grid of n_theta and n_dphi, no adaptive pass. Image mode: a
    /// turned sphere measured at several spins into the 4-D table `aniso_layout`
    /// (image_aniso.h).
    bool anisotropic = false;
    std::string symmetry;  ///< Point mode, anisotropic plan: "none", "mirror" or "2-fold".
    /// Point mode, vndf plan (0 = the description's): theta_i nodes of its RGL file, nodes per
    /// axis of the sample square, and (with anisotropic) incident azimuths.
    int vndf_theta_i = 0;
    int vndf_resolution = 0;
    int vndf_phi_i = 0;
    double time_scale = 0;       ///< Virtual rig: motion time scale (> 0 overrides the rig's).
    bool accept_drift = false;   ///< Point mode: take the lamp's level as the new baseline.
    bool plan_only = false;      ///< Print the plan and stop; nothing is measured or written.
    double coverage_target = 0;  ///< Image mode: fraction of the valid table bins.
    int max_frames = 0;          ///< Image mode: most light positions.
    /// Image mode: table bins (theta_h x theta_d x phi_d); all zero: from table_factor.
    TableLayout grid{0, 0, 0};
    /// Image mode on the virtual rig: size (px, square) of its default camera; 0 = image_size.
    /// Refused with a rig whose calibrated camera_model is the camera.
    int camera_px = 0;
    /// Image mode: grazing limit of the pixels (theta_i and theta_o), degrees; 0 = the exclusion
    /// rules' default (80). Never beyond the rig's geometry.max_theta_deg (an error names both).
    double max_theta_deg = 0;
    /// Image mode: take every frame in the wide view, leaving out the rig's zoomed camera
    /// placements (placement.h). Refused with a rig that has none and with anisotropic (which
    /// uses the wide view only).
    bool no_zoom = false;
    /// "[ADDR:]PORT" of the live page of the campaign (both modes). The front end serves it
    /// (`gonio acquire` starts a report::LiveServer and feeds it through the campaign's hooks);
    /// start_point_campaign and run_image_request do not.
    std::string serve;
    /// Point mode: the stop rule (point/stop_rule.h, "sigma=0.01[,holdout=2]"): fit between
    /// batches and stop when it holds. Kept in campaign.json, so a resume keeps it.
    std::string until;
    /// Point mode: fly scans (point/fly_plan.h): the arms measure while moving. Kept in
    /// campaign.json, so a resume keeps them. Refused in image mode, with the fit plan and with a
    /// rig that has a colour filter changer.
    bool fly = false;
    /// Point mode, fly scans: the largest arc one exposure may span, degrees (0 = 1 deg).
    double fly_smear_deg = 0;
    /// Image mode settings no command-line option gives (tests and scripts set them): the table
    /// resolution (90 / factor bins per angle; 1 = MERL), the virtual rig's default camera size
    /// and sub-pixel rays, and its noise seed.
    int table_factor = 3;
    int image_size = 256;
    bool perspective = false;  ///< Default camera: perspective at 0.5 m instead of telecentric.
    int supersample = 2;
    std::uint64_t seed = 1;
    /// Anisotropic image mode: the 4-D table (theta_h x phi_h x theta_d x phi_d).
    AnisoLayout aniso_layout;
};

/// An option the request gives that its mode cannot honour, with what it conflicts with. Both are
/// field keys ("resume_dir" -> option "resume", see option_key()), or "mode" for the mode itself,
/// or "isotropic_plan" for a plan that is not anisotropic.
struct RequestConflict {
    std::string option;
    std::string with;
    std::string rule;  ///< Why, in a few words.
};

/// The option name of a request field as written on a command line without the dashes and with
/// '-' ("resume_dir" -> "resume", "plan_only" -> "plan-only", "campaign_file" -> "campaign",
/// "operator_name" -> "operator", "brdf_path" -> "brdf", "rig_path" -> "rig", "out_dir" -> "out").
std::string option_key(const std::string& field);

/// The first option the mode refuses (none: every given option is honoured). Rules:
/// - point mode refuses coverage_target, max_frames, grid, camera_px, max_theta_deg and no_zoom
///   (image-mode options); no_zoom is refused with anisotropic (its frames are all wide);
/// - anisotropic excludes plan_kind (but the vndf and fit plans) and adaptive passes (adaptive >
///   0); symmetry needs anisotropic;
/// - the fit plan refuses n_theta, n_dphi and adaptive > 0 (it chooses from its own pool);
/// - image mode refuses the campaign file, scene, plan, n_theta, n_dphi, adaptive, symmetry, the
///   vndf plan's options,
///   accept_drift (point-mode plans, symmetry folds and drift checks), and grid with anisotropic
///   (the anisotropic campaign's table is 4-D);
/// - a resume reads everything from the folder (an image campaign: its settings and frame
///   journal): only accept_drift and serve go with it;
/// - plan_only prints the plan: nothing that only matters to a run (out, campaigns_dir,
///   material, brdf, time_scale, sample, operator, accept_drift, serve, until, fly,
///   fly_smear_deg) goes with it;
/// - the virtual rig's options (material, brdf, time_scale) need the embedded rig: a campaign
///   file names its own rig; material and brdf exclude each other;
/// - the vndf plan refuses n_theta, n_dphi (uniform-plan options), adaptive > 0 (it places its
///   own second pass) and scene (its RGL file needs every node);
/// - fly (and fly_smear_deg) is point mode's: image mode refuses it; fly_smear_deg needs fly.
std::optional<RequestConflict> find_conflict(const CampaignRequest& request);

/// An option the rig description cannot honour (read without starting anything): point mode, fly
/// with a rig that has a colour filter changer. Image mode:
/// camera_px with a rig whose calibrated camera_model is the camera, max_theta_deg beyond the
/// rig's geometry.max_theta_deg, no_zoom with a rig without zoomed camera placements. `with` is
/// "rig_path"; the rule names the rig and its limit. None when the description cannot be read (the
/// run reports that).
std::optional<RequestConflict> find_rig_conflict(const CampaignRequest& request);

// ---- the embedded virtual rig ------------------------------------------------------------

/// What the campaign needs from an in-process virtual rig.
class EmbeddedRig {
  public:
    virtual ~EmbeddedRig() = default;
    virtual std::string motor_address() const = 0;   ///< tcp://127.0.0.1:PORT
    virtual std::string camera_address() const = 0;  ///< gige://ADDRESS
    virtual std::string describe() const = 0;        ///< Sample, units, addresses.
    virtual std::string ground_truth() const = 0;    ///< The mounted sample's description.
    virtual bool isotropic_sample() const = 0;
};

struct EmbeddedRigOptions {
    std::string material;   ///< Named material (overrides the rig's "sim" section).
    std::string brdf_path;  ///< Model JSON or table (overrides material).
    double time_scale = 0;  ///< > 0 overrides the rig's.
    std::uint64_t seed = 0;
    /// Image mode: the camera on the detector arm images a sphere of the material.
    std::optional<CameraModel> sphere_camera;
    double sphere_radius_m = 0;
    int supersample = 2;  ///< Sub-pixel rays per axis of the sphere image.
};

/// Starts the virtual rig a rig description's "sim" section describes.
using EmbeddedRigStarter = std::function<Expected<std::unique_ptr<EmbeddedRig>>(
    const std::string& rig_json, const EmbeddedRigOptions& options)>;

// ---- point mode ----------------------------------------------------------------------------

/// The plan of a new point campaign (plan_only), without starting anything; `spec`, when given,
/// receives the campaign description it was built from.
Expected<Plan> plan_point_campaign(const CampaignRequest& request, CampaignSpec* spec = nullptr);

/// A point campaign ready to run: its folder exists (campaign.json, rig.json and the ground-truth
/// copy written) and its devices are open.
struct PointCampaign {
    std::string dir;
    RigConfig rig;  ///< With the addresses the embedded rig serves.
    std::unique_ptr<EmbeddedRig> embedded;
    RigDevices devices;
    bool resumed = false;
};

/// Sets up a new campaign or a resume. Before a new folder is created everything is checked:
/// description, plan, scene, rig, ground truth and devices reachable; until then nothing is
/// written. A resume reads only the folder (a virtual rig's ground truth included). `log`
/// receives the virtual rig's description and the folder (may be null).
Expected<std::unique_ptr<PointCampaign>> start_point_campaign(const CampaignRequest& request,
                                                              const EmbeddedRigStarter& start_rig,
                                                              std::FILE* log);

// ---- image mode ----------------------------------------------------------------------------

/// The image rig: the devices opened through their addresses, and the embedded virtual rig
/// serving them when the description has a "sim" section (null otherwise).
struct ImageRig {
    RigConfig rig;  ///< With the addresses the virtual rig serves.
    CameraModel camera;
    std::unique_ptr<EmbeddedRig> embedded;
    RigDevices dev;
    PoseCheckLog pose_log;
};

struct ImageRigOptions {
    /// Rig description (data/rigs/sim-image.json when empty); its "camera_model", when present,
    /// is the camera, else (virtual rig only) the default image camera of image_size /
    /// perspective.
    std::string rig_path;
    std::string material = "red-plastic";  ///< Virtual rig: ground truth by name.
    std::string brdf_path;                 ///< Or a model JSON / table file (takes precedence).
    int image_size = 256;                  ///< Default camera sensor size (square), px.
    bool camera_px_given = false;  ///< image_size was asked for (refused with a camera_model).
    bool perspective = false;      ///< Default camera: perspective at 0.5 m instead of telecentric.
    int supersample = 2;
    double time_scale = 0;
    std::uint64_t seed = 1;
};

/// Reads the rig description and the camera model (no device is touched).
Expected<std::pair<RigConfig, CameraModel>> image_rig_description(const ImageRigOptions& options,
                                                                  bool* embedded);

/// Reads the rig description and the camera model, starts the virtual rig with the sphere of the
/// ground truth when the description has a "sim" section, and opens the devices (camera: Mono16,
/// full sensor, the rig's capture gain).
Expected<std::unique_ptr<ImageRig>> start_image_rig(const ImageRigOptions& options,
                                                    const EmbeddedRigStarter& start_rig);

/// Capture function over the rig's devices (make_device_capture): the light arm, the detector arm
/// at `detector_arm_rad` (both read back around every exposure), the lamp shutter, the filter
/// wheel coils and the reference changer; with `spin`, the sample holder's spin axis too (read
/// back with the arms). `rig` must outlive it.
CaptureFn image_rig_capture(ImageRig& rig, double detector_arm_rad, bool spin = false);

/// The settings of an image campaign for a request and its rig (defaults: coverage target 0.55,
/// at most 200 frames), without touching a device: what --plan-only prints.
struct ImagePlan {
    ImageCampaignConfig config;
    bool embedded = false;  ///< The rig description asks for the embedded virtual rig.
    std::string rig_name;
};
Expected<ImagePlan> plan_image_campaign(const CampaignRequest& request);

/// What an image campaign run did.
struct ImageCampaignRun {
    std::string dir;        ///< Where its outputs were written.
    std::string journal;    ///< Its frame journal (image_journal.h), inside `dir`.
    bool resumed = false;   ///< A resume of the campaign in `dir`.
    std::string sample;     ///< Sample name (request.sample, else the ground truth's name).
    bool embedded = false;  ///< Served by the embedded virtual rig.
    std::string rig_name;
    std::string motor_address;
    std::string camera_address;
    ImageCampaignConfig config;
    std::optional<ImageCampaignResult> result;
    PoseCheckLog poses;
};

/// The hooks of a front end into an image campaign run; each may be empty.
struct ImageRunHooks {
    /// Once the rig answers and the folder is known, before anything is written: an error ends
    /// the run with nothing written (a live page whose address is in use, for one).
    std::function<Expected<void>(const ImageCampaignRun&)> started;
    ImageProgressFn progress;
    ImageStateFn state;
    /// Wraps the capture function (to show the frames on a live page).
    std::function<CaptureFn(CaptureFn)> wrap_capture;
};

/// The memory an image request's work needs (image_memory.h), without touching a device or a
/// file of the campaign: the prediction alone for `plan_only`, else the campaign (a resume with
/// its folder's settings and the frames its journal holds). Fails where the request itself would
/// (an unreadable rig description, a bad table).
Expected<ImageMemoryEstimate> estimate_image_request_memory(const CampaignRequest& request);

/// estimate_image_request_memory() against the memory budget (base/limits.h, --max-memory):
/// "the image campaign needs about 2.9 GiB (program ..., pixels ..., ...) of memory, above the
/// limit of 2 GiB (...)". An estimate that cannot be made is no refusal (the work reports why).
Expected<void> check_image_request_memory(const CampaignRequest& request);

/// Runs an image campaign, new or resumed, journaled so that a campaign ended by a crash or a
/// kill resumes where it stopped:
/// - refuses a conflict (find_conflict), a bad table resolution and work whose memory estimate
///   (check_image_request_memory) is above the budget, before the folder exists;
/// - a resume (request.resume_dir) takes every setting from the folder's image_campaign.json;
/// - starts the rig (start_image_rig with the ground truth, time scale and seed), refuses an
///   anisotropic virtual sample unless the request is anisotropic (the table is isotropic) and an
///   anisotropic request on a rig without a spin axis, calls hooks.started;
/// - a new campaign refuses a folder that already holds one, creates it and writes its settings
///   (and the ground truth's file, copied in, so that a resume reads only the folder);
/// - runs the campaign on the folder's frames.journal and writes its outputs into the folder
///   with the sample, operator, rig, addresses and pose checks in its metadata.
/// The run is returned whether or not the coverage target was met (result->target_met).
Expected<ImageCampaignRun> run_image_request(const CampaignRequest& request,
                                             const EmbeddedRigStarter& start_rig,
                                             const ImageRunHooks& hooks);

/// The same with a `started` that cannot fail and a progress report only.
Expected<ImageCampaignRun> run_image_request(
    const CampaignRequest& request,
    const EmbeddedRigStarter& start_rig,
    const std::function<void(const ImageCampaignRun&)>& started = {},
    const ImageProgressFn& progress = {});

/// Whether `dir` holds an image campaign (its image_campaign.json): how a resume tells the modes
/// apart.
bool is_image_campaign_dir(const std::string& dir);

/// The folder of a new image campaign: request.out_dir, else "image-<name>-<n>" under
/// request.campaigns_dir (the current folder when empty), the first n not in use.
std::string image_campaign_dir(const CampaignRequest& request, const std::string& name);

}  // namespace gonio::acquisition
