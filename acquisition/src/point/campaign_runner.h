#pragma once

// What the sources of a point campaign (campaign.h) share: the runner's class and small helpers.
// The implementation is split by job: campaign_spec.cpp (the description and the folder),
// campaign_dataset.cpp (the dataset and the vndf plan's files from the journal), runner.cpp (the
// passes), runner_devices.cpp (moves, exposures, the white reference and drift checks),
// fly_runner.cpp (fly scans) and campaign_metadata.cpp (metadata.json, the stop rule's checks).

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/point/capture_session.h"
#include "gonio/acquisition/point/fit_sweeps.h"
#include "gonio/acquisition/point/fly_sweep.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/acquisition/point/progress.h"
#include "gonio/acquisition/point/stated_uncertainty.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/dataset.h"
#include "gonio/version.h"

namespace gonio::acquisition::campaign_internal {

using brdf::kPi;
using brdf::RigPosed;
using brdf::Vec3d;
using nlohmann::json;
namespace fs = std::filesystem;

inline constexpr double kDeg = kPi / 180.0;

inline double now_s() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

inline std::string iso_time(double t, bool for_path) {
    const std::time_t tt = static_cast<std::time_t>(t);
    std::tm tm{};
    gmtime_r(&tt, &tm);
    char buf[40];
    std::strftime(buf, sizeof buf, for_path ? "%Y-%m-%dT%H-%M-%S" : "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

inline Expected<std::string> read_text(const std::string& path) {
    return read_input_file(path, kMaxJsonBytes);
}

inline Expected<void> write_text_atomic(const std::string& path, const std::string& text) {
    return write_file_atomic(path, text);
}

inline double luminance(const brdf::Rgbd& v) {
    return (v[0] + v[1] + v[2]) / 3;
}

inline std::array<double, 4> pose_deg(const RigPosed& p) {
    return {p.light / kDeg, p.detector / kDeg, p.tilt / kDeg, p.spin / kDeg};
}

/// Why fly scans refuse a rig with a colour filter changer whose arms trigger by polling.
inline constexpr const char* kFlyColourRule =
    "fly scans behind a colour filter changer need the arms' position compare (one sweep per "
    "filter, each frame triggered at the same encoder position, so that the three colours share "
    "one path): this rig's arm axes say \"position_compare\": false (use a rig whose arms have "
    "it, e.g. data/rigs/sim4.json, or one without \"filter_wheel\", or measure standing)";

/// Largest difference between the latched paths of one configuration's colour frames that still
/// counts as one path: five steps of the finest shipped profile (1000 steps/deg).
inline constexpr double kColourPathToleranceDeg = 0.005;

/// The vndf plan's second pass from the retro-reflection measurements among `records`.
Expected<VndfLayout> vndf_pass_from_records(const std::vector<JournalRecord>& records,
                                            const CampaignSpec& spec,
                                            const RigConfig& rig,
                                            VndfNdf* ndf_out);

class Runner {
  public:
    Runner(std::string dir, RigDevices& dev, const RunHooks& hooks)
        : dir_(std::move(dir)), dev_(dev), hooks_(hooks) {}

    Expected<RunResult> run();

  private:
    std::string path(const char* name) const { return (fs::path(dir_) / name).string(); }
    void say(const std::string& s) const {
        if (hooks_.out) {
            std::fprintf(hooks_.out, "%s\n", s.c_str());
            std::fflush(hooks_.out);
        }
    }
    bool stop_requested() const { return hooks_.stop && hooks_.stop->load(); }

    Expected<RigPosed> read_pose();
    Expected<void> move_to(const RigPosed& p);
    Expected<void> home_if_needed();
    /// Moves and measures with bounded retries; a drive alarm pauses at once.
    struct Shot {
        RigPosed pose;  ///< As read back from the axes.
        Vec3d wi, wo;
        SignalRate rate;
    };
    Expected<Shot> attempt(const RigPosed& target, const std::string& what, std::string* pause);
    Expected<Shot> measure_once(const RigPosed& target, const std::string& what);
    Expected<SignalRate> expose();
    /// The axes whose positions differ between `a` and `b` by more than the pose tolerance, in
    /// words ("sample spin 12.000 -> 15.500 deg"); empty when none.
    std::string pose_change(const RigPosed& a, const RigPosed& b) const;
    void note(const std::string& text);
    /// Waits (probing with back-off) until every axis answers again; an error when stopped on
    /// request or when the outage lasts longer than hooks_.max_outage_s.
    Expected<void> wait_for_devices(const std::string& what, const std::string& cause);
    Expected<void> white_calibration(std::string* pause);
    /// Measures the drift reference; sets *pause on drift beyond the threshold.
    Expected<void> drift_check(bool baseline, std::string* pause);
    JournalRecord record_of(RecordType type, const Shot& s, const BrdfValue& v) const;
    Expected<void> write_metadata(const std::string& state, const Plan& plan);
    // The stages of write_metadata().
    /// metadata.json as an earlier write left it (an object; empty when missing or unreadable).
    json read_metadata() const;
    /// The sample, the software, the rig, the plan (and the vndf plan's second pass), the
    /// calibration.
    void describe_campaign(json& meta, const Plan& plan) const;
    /// This run in runs[] (its state and rig time), earlier runs still marked running as killed.
    void list_run(json& meta, const std::string& state);
    /// The campaign's state, counts, rig time over every run and the stop rule's last check.
    void campaign_totals(json& meta, const std::string& state);
    /// The fit-driven plan's pool and batches (those an earlier run chose kept as recorded).
    void fit_plan_record(json& meta) const;
    /// This run's rig time, its stop reason and the stop rule's state into the metadata.
    void record_run(json& meta, json& run, bool running);
    Expected<RunResult> finish(Outcome o, const std::string& msg, const Plan& plan);
    /// This run's rig time so far: the clock's moves, the session's exposures and readouts.
    RigTime rig_time() const;
    /// Rig hours of the whole campaign so far (earlier runs and this one).
    double campaign_rig_hours() const { return (prior_rig_time_s_ + rig_time().total_s()) / 3600; }
    /// Fits the values so far against the stop rule; true when it holds.
    Expected<bool> check_stop_rule(const Plan& plan);

    // The stages of run(), in order.
    /// The campaign's description, rig and plan from its folder; the journal opened and the run
    /// listed in metadata.json.
    Expected<Plan> load_campaign();
    /// The state the journal holds: measurements done, the white reference, the drift baseline.
    /// Returns whether the white reference was measured.
    bool replay_journal();
    void say_plan(const Plan& plan) const;
    /// Homing, the pose read back, the camera prepared, the white reference and the drift
    /// baseline when needed; an error is the reason to pause.
    Expected<void> prepare_devices(bool have_white, std::string* pause);
    /// The configurations of a pass: 0 the plan, then the vndf plan's second pass or an adaptive
    /// refinement (everything derived from the journal, so a resume rebuilds the same passes).
    Expected<Plan> pass_plan(int pass, const Plan& plan);
    Plan adaptive_pass(int pass) const;
    /// The fit-driven plan's batch `pass` (>= 1) from the journal; empty at the budget.
    Plan fit_batch(int pass);
    /// The pass's configurations not yet measured, solved in plan order for continuity.
    void pending_poses(int pass,
                       const Plan& pp,
                       std::vector<const PlannedConfig*>* pending,
                       std::vector<RigPosed>* poses) const;
    /// Measures a pass in scheduled order; a value when the run ends within it (stopped,
    /// paused, or a journal that cannot be written).
    std::optional<Expected<RunResult>> measure_pass(int pass,
                                                    const Plan& pp,
                                                    const Plan& plan,
                                                    std::string* pause);
    /// After each measurement: the stop rule checked every check_every_ measurements; a value
    /// when it holds or its check fails.
    std::optional<Expected<RunResult>> after_measurement(const Plan& plan, Progress* progress);
    /// Before the passes (a resume) or after them: the stop rule on what the journal holds.
    std::optional<Expected<RunResult>> rule_on_journal(const Plan& plan);
    /// One configuration measured and journaled.
    Expected<JournalRecord> measure_config(int pass,
                                           const PlannedConfig& c,
                                           const RigPosed& pose,
                                           std::string* pause,
                                           bool* journal_failed);
    void publish_measurement(const JournalRecord& r) const;
    std::string completion_summary() const;
    /// Before each measurement (or sweep): a stop on request, the drift check when due; a value
    /// when the run ends there.
    std::optional<Expected<RunResult>> before_measurement(const Plan& plan,
                                                          std::string* pause,
                                                          Progress* progress);
    /// One configuration measured standing with the pass's bookkeeping (progress, live page,
    /// stop rule); a value when the run ends there.
    std::optional<Expected<RunResult>> measure_standing(int pass,
                                                        const PlannedConfig& c,
                                                        const RigPosed& pose,
                                                        const Plan& plan,
                                                        std::string* pause,
                                                        Progress* progress);

    // Fly scans (fly_plan.h, fly_sweep.h).
    FlyLimits fly_limits() const;
    /// A pass measured in sweeps, then in one scheduled tour what no sweep measured (no sweep
    /// partner, a saturated frame, a missed trigger); a value when the run ends within it.
    std::optional<Expected<RunResult>> measure_fly_pass(int pass,
                                                        const std::vector<const PlannedConfig*>& c,
                                                        const std::vector<RigPosed>& poses,
                                                        const Plan& plan,
                                                        std::string* pause);
    /// Runs one sweep and journals its values; `standing` receives the members (indices into
    /// the pass's pending list) left to measure standing. A value when the run ends within it.
    std::optional<Expected<RunResult>> fly_sweep(int pass,
                                                 const Sweep& sw,
                                                 const std::vector<const PlannedConfig*>& c,
                                                 const std::vector<RigPosed>& poses,
                                                 const Plan& plan,
                                                 Progress* progress,
                                                 std::vector<std::size_t>* standing);
    /// The sweep's start in the journal (its configurations' plan indices listed), then the arm
    /// at its lead-in; the pose read back there.
    Expected<RigPosed> start_sweep(int pass,
                                   const Sweep& sw,
                                   const std::vector<const PlannedConfig*>& pending);
    /// The journal record of a frame taken during a sweep from pose `stood` (the arm's angle
    /// replaced by its latched path); an error when the frame is no value (saturated, a latch
    /// outside the sweep).
    Expected<JournalRecord> fly_record(int pass,
                                       const PlannedConfig& c,
                                       const Sweep& sw,
                                       const RigPosed& stood,
                                       const std::vector<const FlyFrame*>& f);
    /// How the sweeps of arm `axis` are triggered: the rig's axes[].position_compare, else
    /// whether the drive has one.
    SweepTrigger sweep_trigger(int axis) const;
    /// The sweep from its lead-in (where the arm stands at pose `stood`), once per colour filter
    /// behind a filter changer (the arm back at the lead-in between), else once; all at one
    /// exposure, carried to the next sweep as its brightest colour's level.
    Expected<std::vector<SweepFrames>> sweep_filters(const Sweep& sw,
                                                     const RigPosed& stood,
                                                     const std::vector<double>& targets_deg);
    /// The frames of member k of each filter's sweep (empty when some filter missed it).
    static std::vector<const FlyFrame*> member_frames(const std::vector<SweepFrames>& per_filter,
                                                      std::size_t k);

    std::string dir_;
    RigDevices& dev_;
    RunHooks hooks_;
    CampaignSpec spec_;
    RigConfig rig_;
    RigLimits lim_;
    std::array<AxisDynamics, kNumAxes> dyn_;
    std::optional<Journal> journal_;
    std::optional<CaptureSession> session_;
    WhiteCalibration white_;
    RigPosed current_;
    std::size_t since_reference_ = 0;
    std::optional<JournalRecord> baseline_;
    RunResult result_;
    double started_ = 0;
    /// The vndf plan's second pass once placed (metadata.json lists it).
    std::optional<VndfLayout> vndf_pass_;
    VndfNdf vndf_ndf_;
    std::optional<RigClock> clock_;
    /// Rig seconds of the campaign's earlier runs (metadata.json).
    double prior_rig_time_s_ = 0;
    StopRule rule_;
    std::size_t since_check_ = 0;
    std::size_t check_every_ = 0;
    /// The stop rule's last check, for metadata.json (null before the first).
    json until_ = nullptr;
    /// The fit-driven plan's pool (reachable, within the scene) and its batches for metadata.json
    /// (by pass: when chosen, from what, why).
    Plan fit_pool_;
    /// With fly scans, the fit plan's pool is its sweep lines' frames (fit_sweeps.h).
    std::optional<FitSweepPool> fit_lines_;
    json fit_batches_ = json::object();
    /// (pass, index) of every measurement in the journal.
    std::set<std::pair<int, std::uint32_t>> done_;
    std::size_t planned_total_ = 0;
    /// Fly scans: the auto exposure carried from frame to frame (microseconds; 0 before the
    /// first), and frames that gave no value (the arm passed the trigger, or saturated).
    double fly_exposure_us_ = 0;
    std::size_t fly_missed_ = 0;
    std::size_t fly_saturated_ = 0;
};

}  // namespace gonio::acquisition::campaign_internal
