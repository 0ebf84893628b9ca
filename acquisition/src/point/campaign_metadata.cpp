// metadata.json of a point campaign, the end of a run and the stop rule's checks (campaign_runner.h).

#include "campaign_runner.h"

namespace gonio::acquisition::campaign_internal {

json Runner::read_metadata() const {
    json meta = json::object();
    if (auto old = read_text(path("metadata.json")); old) {
        try {
            meta = parse_json_checked(*old, path("metadata.json"));
        } catch (const JsonFailure& f) {
            say("metadata.json unreadable (" + f.message + "); written anew from the journal");
            meta = json::object();
        }
        if (!meta.is_object()) {
            meta = json::object();
        }
    }
    return meta;
}

void Runner::describe_campaign(json& meta, const Plan& plan) const {
    meta["sample"] = spec_.sample;
    meta["operator"] = spec_.operator_name;
    meta["notes"] = spec_.notes;
    meta["software"] = {{"name", "gonio"}, {"version", GONIO_VERSION_STRING}};
    meta["rig"] = {{"name", rig_.name}, {"description", json::parse(rig_.json)}};
    auto unreachable_of = [](const Plan& p) {
        json list = json::array();
        for (const UnreachableConfig& u : p.unreachable) {
            const auto c = brdf::to_canonical(u.wi, u.wo);
            list.push_back({{"theta_i_deg", c.theta_i / kDeg},
                            {"theta_r_deg", c.theta_r / kDeg},
                            {"delta_phi_deg", c.delta_phi / kDeg},
                            {"reason", u.reason}});
        }
        return list;
    };
    const json unreachable = unreachable_of(plan);
    if (vndf_pass_) {
        // The vndf plan's second pass, placed from the retro-reflection measurements.
        meta["vndf"] = {{"retro_measurements", vndf_ndf_.measured},
                        {"power_iterations", vndf_ndf_.ndf.iterations},
                        {"last_retro_theta_deg", vndf_ndf_.theta_last / kDeg},
                        {"configurations", vndf_pass_->plan.configs.size()},
                        {"file_nodes", vndf_pass_->layout.nodes.size()},
                        {"below_horizon", vndf_pass_->below_horizon},
                        {"unreachable", unreachable_of(vndf_pass_->plan)}};
    }
    meta["plan"] = {{"kind", plan.kind},
                    {"description", json::parse(spec_.json)},
                    {"configurations", plan.configs.size()},
                    {"naive_4d_grid", plan.naive_count},
                    {"outside_roi", plan.outside_roi},
                    {"unreachable", unreachable}};
    meta["calibration"] = {
        {"white_reflectance", white_.reflectance},
        {"white_cos_theta_i", white_.cos_theta_w},
        {"white_rate_counts_per_us", {white_.rate[0], white_.rate[1], white_.rate[2]}},
        {"white_rate_sigma", {white_.rate_sigma[0], white_.rate_sigma[1], white_.rate_sigma[2]}},
        {"method", "docs/calibration.md"},
        {"colour", dev_.filter_wheel ? "filter_wheel" : "mono"}};
}

void Runner::list_run(json& meta, const std::string& state) {
    if (!meta.contains("created")) {
        meta["created"] = iso_time(started_, false);
    }
    if (!meta.contains("runs")) {
        meta["runs"] = json::array();
    }
    const bool running = state == "running";
    // A run is told apart by its start time and its process id (two runs may start within one
    // second).
    const long pid = static_cast<long>(::getpid());
    const std::string started = iso_time(started_, false);
    auto is_this_run = [&](const json& r) {
        return r.is_object() && r.value("started", "") == started && r.contains("pid") &&
               r["pid"].is_number_integer() && r["pid"].get<long>() == pid;
    };
    json run = {{"started", started},
                {"pid", pid},
                {"ended", running ? json(nullptr) : json(iso_time(now_s(), false))},
                {"state", state},
                {"measured", result_.measured_now}};
    if (!meta["runs"].is_array()) {
        meta["runs"] = json::array();
    }
    for (json& old : meta["runs"]) {
        // A run still marked "running" that is not this one never wrote its end: the process was
        // killed (kill -9, power cut, crash). Its measurements are in the journal.
        if (old.is_object() && old.value("state", "") == "running" && !is_this_run(old)) {
            old["state"] = "killed";
            old["ended"] =
                "unknown: the process stopped without writing its end (killed or power "
                "cut); its finished measurements are in journal.log";
        }
    }
    record_run(meta, run, running);
    // The run in progress is the last element while it lasts.
    if (!meta["runs"].empty() && is_this_run(meta["runs"].back()) &&
        meta["runs"].back().value("state", "") == "running") {
        meta["runs"].back() = run;
    } else {
        meta["runs"].push_back(run);
    }
}

void Runner::campaign_totals(json& meta, const std::string& state) {
    meta["state"] = state;
    meta["measured"] = result_.measured_total;
    meta["pose_repeats"] = result_.pose_repeats;
    meta["pose_corrections"] = result_.pose_corrections;
    meta["device_outages"] = result_.outages;
    meta["planned"] = result_.planned_total;
    // The campaign's rig time: every run's (a killed run's as of its last metadata write).
    double total = 0;
    for (const json& r : meta["runs"]) {
        if (r.is_object() && r.contains("rig_time_s") && r["rig_time_s"].is_number()) {
            total += r["rig_time_s"].get<double>();
        }
    }
    meta["rig_time_s"] = total;
    result_.campaign_rig_time_s = total;
    prior_rig_time_s_ = total - result_.rig_time.total_s();
    if (!until_.is_null()) {
        meta["until"] = until_;
    }
}

void Runner::fit_plan_record(json& meta) const {
    if (spec_.plan_kind == "fit") {
        // Batches chosen by an earlier run stay as they were recorded.
        json batches = meta.contains("fit_plan") && meta["fit_plan"].is_object() &&
                               meta["fit_plan"].contains("batches") &&
                               meta["fit_plan"]["batches"].is_object()
                           ? meta["fit_plan"]["batches"]
                           : json::object();
        for (auto it = fit_batches_.begin(); it != fit_batches_.end(); ++it) {
            if (!batches.contains(it.key())) {
                batches[it.key()] = it.value();
            }
        }
        meta["fit_plan"] = {{"pool", fit_pool_.configs.size()}, {"batches", batches}};
    }
}

Expected<void> Runner::write_metadata(const std::string& state, const Plan& plan) {
    json meta = read_metadata();
    describe_campaign(meta, plan);
    list_run(meta, state);
    campaign_totals(meta, state);
    fit_plan_record(meta);
    return write_text_atomic(path("metadata.json"), meta.dump(2) + "\n");
}

void Runner::record_run(json& meta, json& run, bool running) {
    (void)meta;
    result_.rig_time = rig_time();
    const RigTime& t = result_.rig_time;
    run["rig_time_s"] = t.total_s();
    run["rig_time"] = {{"motion_s", t.motion_s},
                       {"settle_s", t.settle_s},
                       {"exposure_s", t.exposure_s},
                       {"readout_s", t.readout_s}};
    if (!running) {
        run["stopped"] = result_.stopped;
    }
    if (spec_.fly.enabled) {
        run["fly"] = {{"sweeps", result_.sweeps},
                      {"swept", result_.swept},
                      {"standing", result_.standing},
                      {"missed_triggers", fly_missed_},
                      {"saturated_frames", fly_saturated_},
                      {"moving_frames", session_ ? session_->moving_frames() : 0},
                      {"moving_exposure_s", session_ ? session_->moving_exposure_s() : 0.0}};
    }
}

RigTime Runner::rig_time() const {
    RigTime t = clock_ ? clock_->spent() : RigTime{};
    if (session_) {
        t.exposure_s += session_->exposure_s_taken();
        t.readout_s +=
            static_cast<double>(session_->frames_taken()) * rig_.camera_readout_ms / 1000.0;
    }
    return t;
}

Expected<RunResult> Runner::finish(Outcome o, const std::string& msg, const Plan& plan) {
    result_.outcome = o;
    result_.message = msg;
    if (result_.stopped.empty()) {
        result_.stopped = o == Outcome::kCompleted     ? "plan end"
                          : o == Outcome::kInterrupted ? "interrupted"
                                                       : "fault";
    }
    const char* state = o == Outcome::kCompleted     ? "completed"
                        : o == Outcome::kInterrupted ? "interrupted"
                                                     : "paused";
    if (o != Outcome::kCompleted) {
        JournalRecord note;
        note.type = RecordType::kNote;
        note.text = std::string(state) + ": " + msg;
        note.time_s = now_s();
        (void)journal_->append(note);
    }
    auto n = write_campaign_dataset(dir_, campaign_rig_hours());
    if (!n) {
        return tl::unexpected(n.error());
    }
    if (o == Outcome::kCompleted && spec_.plan_kind == "vndf") {
        auto rep = write_vndf_bsdf(dir_);
        if (!rep) {
            return tl::unexpected(rep.error());
        }
        result_.message += "; RGL material file " + (fs::path(dir_) / kVndfBsdfName).string() +
                           ": " + std::to_string(rep->measured) + " of " +
                           std::to_string(rep->nodes) + " nodes measured, " +
                           std::to_string(rep->filled) + " from their nearest measured node, " +
                           std::to_string(rep->below_horizon) + " below the horizon";
    }
    if (auto m = write_metadata(state, plan); !m) {
        return tl::unexpected(m.error());
    }
    return result_;
}

Expected<bool> Runner::check_stop_rule(const Plan& plan) {
    since_check_ = 0;
    auto samples = campaign_samples(dir_, false, campaign_rig_hours());
    if (!samples) {
        return tl::unexpected(samples.error());
    }
    if (samples->size() < kMinCheckSamples) {
        return false;
    }
    std::vector<brdf::Sample> fit, holdout;
    split_holdout(*samples, &fit, &holdout);
    auto check = hooks_.fit_check(
        fit, holdout, brdf::common_relative_sigma(rig_.error_budget), !isotropic_plan(spec_));
    if (!check) {
        // A fit that fails (too few values for the model, say) is no verdict: measure on.
        say("until: no fit at " + std::to_string(samples->size()) +
            " values: " + check.error().message);
        return false;
    }
    std::string why;
    const bool held = rule_holds(rule_, *check, &why);
    const double rig_s = prior_rig_time_s_ + rig_time().total_s();
    char at[160];
    std::snprintf(at, sizeof at, "%zu measurements, rig time %.1f s", samples->size(), rig_s);
    say(std::string("until ") + spec_.until + ": " + (held ? "held" : "not yet") + " at " + at +
        ": " + why);
    until_ = {
        {"rule", format_stop_rule(rule_)},
        {"held", held},
        {"measurements", samples->size()},
        {"planned", plan.configs.size()},
        {"rig_time_s", rig_s},
        {"max_rel_sigma", check->max_rel_sigma},
        {"worst_parameter", check->worst},
        {"holdout_rms_z", check->holdout_rms_z},
        {"fitted", check->fitted},
        {"held_out", check->held_out},
        {"parameters", check->parameters},
        {"message", std::string(held ? "target held at " : "last check at ") + at + ": " + why}};
    if (held) {
        result_.target_reached = true;
        result_.stopped = "target reached";
        result_.until = until_["message"].get<std::string>();
    }
    // The metadata keeps the check (and this run's rig time) even if the process is killed next.
    if (auto m = write_metadata("running", plan); !m) {
        return tl::unexpected(m.error());
    }
    return held;
}

}  // namespace gonio::acquisition::campaign_internal
