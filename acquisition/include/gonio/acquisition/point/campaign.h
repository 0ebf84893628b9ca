#pragma once

// A measurement campaign: its description (campaign.json), its folder (the description and the rig
// description as used, the journal, the dataset CSV, the JSON sidecar), and the runner that turns
// the plan into journal records, resumable after any stop.

#include <atomic>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/plans/plan_fit.h"
#include "gonio/acquisition/plans/plan_vndf.h"
#include "gonio/acquisition/plans/schedule.h"
#include "gonio/acquisition/point/calibration.h"
#include "gonio/acquisition/point/fit_pass.h"
#include "gonio/acquisition/point/fly_plan.h"
#include "gonio/acquisition/point/rig_clock.h"
#include "gonio/acquisition/point/stop_rule.h"
#include "gonio/acquisition/shared/rig_config.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {

/// campaign.json (docs/operator-guide.md).
struct CampaignSpec {
    std::string sample = "sample";  ///< Material or sample name (the folder name uses it).
    std::string operator_name;
    std::string notes;
    std::string rig;    ///< Rig description path (relative to the campaign file).
    std::string scene;  ///< Optional scene (ROI) path.
    /// "uniform", "half-diff", "vndf", "anisotropic" or "fit".
    std::string plan_kind = "uniform";
    UniformGridSpec uniform;
    HalfDiffSpec half_diff;
    /// The vndf plan (plan_vndf.h): pass 0 retro-reflection, pass 1 the VNDF-warped nodes built
    /// from it; the campaign ends by writing dataset.bsdf. No scene, no adaptive pass.
    VndfSpec vndf;
    AnisotropicGridSpec anisotropic;  ///< plan_kind "anisotropic" (no adaptive passes).
    /// The fit-driven plan (plan_fit.h): pass 0 its space-filling first batch, each later pass a
    /// batch chosen from the fit of the passes before it, up to its budget. No adaptive pass.
    FitPlanSpec fit;
    bool adaptive = false;
    int adaptive_passes = 1;
    RefineSpec refine;
    int drift_every = 50;  ///< Re-measure the drift reference every N measurements (0 = never).
    double drift_threshold = 0.05;  ///< Relative change that pauses the campaign.
    double drift_theta_i_deg = 30;  ///< Drift reference configuration on the sample.
    double drift_theta_r_deg = 30;
    double drift_delta_phi_deg = 90;
    double schedule_budget_s = 0.5;
    /// The stop rule (stop_rule.h: "sigma=0.01,holdout=2"); empty: the whole plan is measured.
    std::string until;
    /// Fly scans (fly_plan.h): the arms measure while moving; kept in campaign.json, so a resume
    /// keeps them.
    FlySpec fly;
    std::string json;  ///< The JSON text.
};

/// Whether the campaign's plan treats the sample as isotropic (every plan but the anisotropic one
/// and the fit-driven plan over anisotropic candidates).
bool isotropic_plan(const CampaignSpec& spec);

/// The default campaign (no description given): `sample` measured on a uniform grid of 7 polar x 5
/// azimuth-difference values up to 75 deg, one adaptive pass of 30, drift check every 40.
CampaignSpec default_campaign_spec(const std::string& sample);

Expected<CampaignSpec> parse_campaign_spec(const std::string& json_text, const std::string& source);
Expected<CampaignSpec> read_campaign_spec(const std::string& path);
std::string campaign_spec_json(const CampaignSpec& spec);

/// Builds the plan of pass 0 (grid, then scene ROI, then reachability; the vndf plan: its
/// retro-reflection pass).
Expected<Plan> build_plan(const CampaignSpec& spec, const RigConfig& rig);

/// "2026-11-22T01-02-03_<sample>" under `parent`, unique (a suffix is added if it exists).
std::string auto_campaign_dir(const std::string& parent, const std::string& sample);

/// Creates the folder with campaign.json and rig.json (the descriptions used, so that a resume
/// needs nothing else). Refuses a folder that already holds a campaign.
Expected<void> create_campaign_dir(const std::string& dir,
                                   const CampaignSpec& spec,
                                   const RigConfig& rig);

enum class Outcome {
    kCompleted,    ///< Every configuration measured.
    kInterrupted,  ///< Stopped on request (Ctrl-C) after finishing a measurement.
    kPaused,       ///< Stopped by a device fault after the retries, or by lamp drift.
};

struct RunResult {
    Outcome outcome = Outcome::kCompleted;
    std::string message;
    std::size_t measured_now = 0;    ///< Measurements taken by this run.
    std::size_t measured_total = 0;  ///< Plan configurations in the journal.
    std::size_t planned_total = 0;
    /// Exposures measured again because an axis moved during them (another client, a stall, a
    /// lost step): positions are read back before and after each exposure.
    std::size_t pose_repeats = 0;
    /// Axes found away from their target before an exposure and moved back first.
    std::size_t pose_corrections = 0;
    /// Device outages waited out (the campaign paused and resumed on its own).
    std::size_t outages = 0;
    /// Why this run stopped: "plan end", "target reached" (the stop rule held), "fault" (a device
    /// fault or lamp drift paused it) or "interrupted" (on request).
    std::string stopped;
    /// Rig time of this run (rig_clock.h), seconds, and of every run of the campaign so far.
    RigTime rig_time;
    double campaign_rig_time_s = 0;
    /// Fly scans: sweeps run, values measured while an arm moved, and configurations measured
    /// standing (no sweep partner, a saturated frame or a trigger the arm passed).
    std::size_t sweeps = 0;
    std::size_t swept = 0;
    std::size_t standing = 0;
    /// The stop rule held (stopped == "target reached"); `until` says which targets and when.
    bool target_reached = false;
    std::string until;
};

/// What the runner needs from its surroundings.
struct RunHooks {
    /// Set (e.g. by SIGINT) to stop after the current measurement.
    const std::atomic<bool>* stop = nullptr;
    /// Progress and messages go here; a terminal gets a redrawn progress bar.
    std::FILE* out = stdout;
    /// Without a reference changer: asks the operator to mount the white reference (true) or the
    /// sample (false) and waits. Null means no way to swap: the run errors.
    std::function<Expected<void>(bool white)> mount;
    /// Accept a drift found at resume: the drift reference is re-baselined and measurement goes on.
    bool accept_drift = false;
    /// Home axes that report not homed before the first move.
    bool home = true;
    /// While the devices do not answer (an outage longer than the bus's reconnect window), they
    /// are probed after this wait, doubling up to 8 times it; the campaign resumes on its own.
    double outage_probe_s = 1.0;
    /// An outage longer than this pauses the campaign for good (resume by hand).
    double max_outage_s = 3600;
    /// Called on the campaign thread after each measurement is in the journal: the sample (BRDF
    /// with sigma, 1/sr), the configurations measured so far and planned so far. It must return
    /// at once (hand the data over, never draw or wait): the next move waits for it.
    std::function<void(const brdf::Sample& sample, std::size_t measured, std::size_t planned)>
        on_measurement;
    /// Called on the campaign thread with the camera frame each measurement's exposure was set
    /// on (the white reference's and the drift checks' too), before the HDR merge. The same rule:
    /// hand it over and return.
    std::function<void(const devices::Frame& frame)> on_frame;
    /// The fit a campaign with a stop rule (CampaignSpec::until) runs between batches; a campaign
    /// with a rule and without it is refused.
    FitCheckFn fit_check;
    /// The fit the fit-driven plan chooses each batch from; without it every batch fills space
    /// (and the campaign says so).
    PlanFitFn plan_fit;
};

/// Runs (or resumes) the campaign in `dir` on the rig's devices until completed, interrupted or
/// paused. The journal makes it exact: a configuration in the journal is never measured again; one
/// not in it is measured. Errors are for conditions that prevent starting (unreadable folder,
/// corrupt journal, unreachable drift reference).
Expected<RunResult> run_campaign(const std::string& dir, RigDevices& dev, const RunHooks& hooks);

/// Rebuilds dataset.csv from the journal (atomically replaced). Reference re-measurements are
/// included with kFlagReference. Each value's sigma adds the rig's error budget (rig.json, the
/// drift over `rig_hours` of rig time) to its detector noise (stated_uncertainty.h).
Expected<std::size_t> write_campaign_dataset(const std::string& dir, double rig_hours = 0);

/// The values of a campaign's journal (measurements, and the drift references when
/// `references`) in journal order, with the stated uncertainty of write_campaign_dataset.
Expected<std::vector<brdf::Sample>> campaign_samples(const std::string& dir,
                                                     bool references,
                                                     double rig_hours = 0);

/// The file name of a vndf campaign's RGL material file, beside dataset.csv.
constexpr const char* kVndfBsdfName = "dataset.bsdf";

/// The second pass of a vndf campaign from the retro-reflection measurements in its journal (pass
/// 0): the NDF, the layout and its configurations. Deterministic for a given journal, so a resume
/// rebuilds the same pass.
Expected<VndfLayout> vndf_second_pass(const std::string& dir,
                                      const CampaignSpec& spec,
                                      const RigConfig& rig,
                                      VndfNdf* ndf = nullptr);

/// Writes dataset.bsdf of a vndf campaign from its journal (pass 1 measurements; several of one
/// configuration are averaged). Returns what was stored.
Expected<VndfFileReport> write_vndf_bsdf(const std::string& dir);

}  // namespace gonio::acquisition
