// The campaign runner: the campaign loaded, the journal replayed, the passes measured in order, the end of the run (campaign_runner.h).

#include "campaign_runner.h"
#include "gonio/acquisition/point/fit_pass.h"

namespace gonio::acquisition::campaign_internal {

Expected<Plan> Runner::load_campaign() {
    auto spec = read_campaign_spec(path("campaign.json"));
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    spec_ = *spec;
    if (!spec_.scene.empty() && fs::path(spec_.scene).is_relative()) {
        spec_.scene = path(spec_.scene.c_str());
    }
    auto rig = read_rig_config(path("rig.json"));
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    rig_ = *rig;
    lim_ = rig_limits(rig_);
    dyn_ = rig_dynamics(rig_);
    clock_.emplace(dyn_, rig_.camera_readout_ms / 1000.0);
    if (spec_.fly.enabled) {
        for (AxisRole arm : {AxisRole::kLight, AxisRole::kDetector}) {
            const int a = static_cast<int>(arm);
            if (rig_.axes[a].position_compare.value_or(false) &&
                !dev_.axes[a]->has_position_compare()) {
                return make_error("rig axis \"" + rig_.axes[a].name +
                                  "\" says \"position_compare\": true, but its drive's register "
                                  "map has no position compare");
            }
            if (dev_.filter_wheel && sweep_trigger(a) == SweepTrigger::kPolled) {
                return make_error(kFlyColourRule);
            }
        }
    }
    if (!spec_.until.empty()) {
        auto rule = parse_stop_rule(spec_.until);
        if (!rule) {
            return tl::unexpected(rule.error());
        }
        rule_ = *rule;
        if (!hooks_.fit_check) {
            return make_error("the campaign stops by its rule (until " + spec_.until +
                              "), which needs a fit between batches; none was given");
        }
    }
    auto plan0 = build_plan(spec_, rig_);
    if (!plan0) {
        return tl::unexpected(plan0.error());
    }
    if (spec_.plan_kind == "fit") {
        if (spec_.fly.enabled) {
            auto lines = fit_sweep_pool(spec_.fit, spec_.fly, spec_.scene, rig_);
            if (!lines) {
                return tl::unexpected(lines.error());
            }
            fit_lines_ = std::move(*lines);
            fit_pool_ = fit_lines_->pool;
        } else {
            auto pool = fit_pool_for_rig(spec_.fit, spec_.scene, lim_);
            if (!pool) {
                return tl::unexpected(pool.error());
            }
            fit_pool_ = std::move(*pool);
        }
        if (!hooks_.plan_fit) {
            say("fit plan: no fit available; every batch fills space");
        }
    }
    auto jn = Journal::open(path("journal.log"));
    if (!jn) {
        return tl::unexpected(jn.error());
    }
    journal_.emplace(std::move(*jn));
    // The run is listed from its start, so a run that is killed still appears in runs[].
    if (auto m = write_metadata("running", *plan0); !m) {
        return tl::unexpected(m.error());
    }
    if (journal_->torn_tail()) {
        say("journal: the last record was cut short by the previous stop; its measurement will "
            "be repeated");
    }
    return plan0;
}

bool Runner::replay_journal() {
    bool have_white = false;
    for (const JournalRecord& r : journal_->records()) {
        switch (r.type) {
            case RecordType::kMeasurement:
                done_.insert({r.pass, r.index});
                ++since_reference_;
                break;
            case RecordType::kWhite:
                have_white = true;
                white_.reflectance = rig_.white_reflectance;
                white_.cos_theta_w = r.wi.z();
                white_.rate = r.rate;
                white_.rate_sigma = r.rate_sigma;
                break;
            case RecordType::kReference:
                since_reference_ = 0;
                if (!baseline_ || r.text == "baseline") {
                    baseline_ = r;
                }
                break;
            case RecordType::kNote:
            case RecordType::kSweep:
                break;
        }
    }
    result_.measured_total = done_.size();
    return have_white;
}

void Runner::say_plan(const Plan& plan) const {
    say("plan: " + plan.kind + ", " + std::to_string(plan.configs.size()) +
        " configurations (naive 4D grid of the same resolution: " +
        std::to_string(plan.naive_count) + ", reduction x" +
        std::to_string(plan.configs.empty() ? 0 : plan.naive_count / plan.configs.size()) + ")" +
        (plan.outside_roi ? ", " + std::to_string(plan.outside_roi) + " outside the scene's ROI"
                          : std::string()) +
        (plan.unreachable.empty() ? std::string()
                                  : ", " + std::to_string(plan.unreachable.size()) +
                                        " unreachable (first: " + plan.unreachable.front().reason +
                                        "; all listed in metadata.json)"));
    if (!done_.empty()) {
        say("resuming: " + std::to_string(done_.size()) + " measurements already in the journal");
    }
}

Expected<void> Runner::prepare_devices(bool have_white, std::string* pause) {
    if (hooks_.home) {
        if (auto h = home_if_needed(); !h) {
            return h;
        }
    }
    auto pose = read_pose();
    if (!pose) {
        return tl::unexpected(pose.error());
    }
    current_ = *pose;
    session_.emplace(dev_.camera.get(), dev_.shutter.get(), rig_.capture, rig_.noise);
    session_->set_frame_observer(hooks_.on_frame);
    if (auto p = session_->prepare(); !p) {
        return make_error("camera: " + p.error().message);
    }
    if (!have_white) {
        if (auto w = white_calibration(pause); !w) {
            return w;
        }
    }
    if (spec_.drift_every > 0) {
        const bool rebase = !baseline_ || hooks_.accept_drift;
        if (auto d = drift_check(rebase, pause); !d) {
            return d;
        }
    }
    return {};
}

Plan Runner::adaptive_pass(int pass) const {
    std::vector<std::pair<std::pair<int, std::uint32_t>, MeasuredPoint>> pts;
    for (const JournalRecord& r : journal_->records()) {
        if (r.type == RecordType::kMeasurement && r.pass < pass) {
            pts.push_back({{r.pass, r.index},
                           MeasuredPoint{brdf::to_canonical(r.wi, r.wo), luminance(r.value)}});
        }
    }
    std::sort(
        pts.begin(), pts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<MeasuredPoint> mp;
    for (const auto& p : pts) {
        mp.push_back(p.second);
    }
    Plan pp = plan_refine(mp, spec_.refine);
    if (!spec_.scene.empty()) {
        auto scene = read_scene(spec_.scene);
        if (scene) {
            apply_roi(*scene, &pp);
        }
    }
    remove_unreachable(lim_, &pp);
    return pp;
}

Plan Runner::fit_batch(int pass) {
    FitBatch b = fit_lines_
                     ? fit_next_sweeps(
                           journal_->records(), pass, *fit_lines_, spec_.fit, rig_, hooks_.plan_fit)
                     : fit_next_batch(
                           journal_->records(), pass, fit_pool_, spec_.fit, rig_, hooks_.plan_fit);
    if (!b.plan.configs.empty()) {
        say("fit plan, batch " + std::to_string(pass) + ": " +
            std::to_string(b.plan.configs.size()) + " configurations; " + b.note);
    }
    const std::string key = std::to_string(pass);
    if (!fit_batches_.contains(key) && !b.plan.configs.empty()) {
        // The batch as first chosen (a resume rebuilds the same one and keeps this record).
        fit_batches_[key] = {{"measured_before", b.measured_before},
                             {"rig_time_s", prior_rig_time_s_ + rig_time().total_s()},
                             {"configurations", b.plan.configs.size()},
                             {"fitted", b.fitted},
                             {"by_variance", b.by_variance},
                             {"by_misfit", b.by_misfit},
                             {"by_space", b.by_space},
                             {"sweeps", b.sweeps},
                             {"note", b.note}};
    }
    return std::move(b.plan);
}

Expected<Plan> Runner::pass_plan(int pass, const Plan& plan) {
    if (pass == 0) {
        return plan;
    }
    if (spec_.plan_kind == "fit") {
        Plan pp = fit_batch(pass);
        planned_total_ += pp.configs.size();
        return pp;
    }
    if (spec_.plan_kind != "vndf") {
        Plan pp = adaptive_pass(pass);
        planned_total_ += pp.configs.size();
        say("adaptive pass " + std::to_string(pass) + ": " + std::to_string(pp.configs.size()) +
            " configurations where the values change fastest");
        return pp;
    }
    VndfNdf ndf;
    auto layout = vndf_pass_from_records(journal_->records(), spec_, rig_, &ndf);
    if (!layout) {
        return tl::unexpected(layout.error());
    }
    vndf_ndf_ = ndf;
    vndf_pass_ = *layout;
    Plan pp = std::move(layout->plan);
    planned_total_ += pp.configs.size();
    say("vndf pass 1: NDF from " + std::to_string(ndf.measured) +
        " retro-reflection measurements (" + std::to_string(ndf.ndf.iterations) +
        " power iterations); " + std::to_string(pp.configs.size()) +
        " configurations in the VNDF-warped domain, " + std::to_string(pp.unreachable.size()) +
        " unreachable, " + std::to_string(layout->below_horizon) + " below the horizon");
    return pp;
}

void Runner::pending_poses(int pass,
                           const Plan& pp,
                           std::vector<const PlannedConfig*>* pending,
                           std::vector<RigPosed>* poses) const {
    RigPosed prev = current_;
    for (const PlannedConfig& c : pp.configs) {
        if (done_.count({pass, c.index})) {
            continue;
        }
        auto sol = solve(Target{c.wi, c.wo, c.isotropic, true}, lim_, dyn_, prev);
        if (!sol) {
            // remove_unreachable() already kept only reachable ones.
            continue;
        }
        pending->push_back(&c);
        poses->push_back(sol->pose);
        prev = sol->pose;
    }
}

Expected<JournalRecord> Runner::measure_config(int pass,
                                               const PlannedConfig& c,
                                               const RigPosed& pose,
                                               std::string* pause,
                                               bool* journal_failed) {
    auto s = attempt(
        pose, "configuration " + std::to_string(pass) + ":" + std::to_string(c.index), pause);
    if (!s) {
        return tl::unexpected(s.error());
    }
    auto v = rate_to_brdf(white_, s->rate.rate, s->rate.sigma, s->wi.z());
    if (!v) {
        return tl::unexpected(v.error());
    }
    JournalRecord r = record_of(RecordType::kMeasurement, *s, *v);
    r.pass = pass;
    r.index = c.index;
    r.flags |= c.flags;
    r.weight = c.weight;
    if (auto a = journal_->append(r); !a) {
        *journal_failed = true;
        return tl::unexpected(a.error());
    }
    done_.insert({pass, c.index});
    ++since_reference_;
    ++result_.measured_now;
    result_.measured_total = done_.size();
    return r;
}

void Runner::publish_measurement(const JournalRecord& r) const {
    if (!hooks_.on_measurement) {
        return;
    }
    hooks_.on_measurement(sample_of_record(r), done_.size(), planned_total_);
}

std::optional<Expected<RunResult>> Runner::measure_pass(int pass,
                                                        const Plan& pp,
                                                        const Plan& plan,
                                                        std::string* pause) {
    std::vector<const PlannedConfig*> pending;
    std::vector<RigPosed> poses;
    pending_poses(pass, pp, &pending, &poses);
    if (pending.empty()) {
        return std::nullopt;
    }
    if (spec_.fly.enabled) {
        return measure_fly_pass(pass, pending, poses, plan, pause);
    }
    ScheduleOptions so;
    so.budget_s = spec_.schedule_budget_s;
    const Schedule sch = schedule(poses, current_, dyn_, so);
    say("pass " + std::to_string(pass) + ": " + std::to_string(pending.size()) +
        " to measure; motion time planned " + format_duration(sch.planned_s) + ", raster order " +
        format_duration(sch.raster_s) + ", lower bound " + format_duration(sch.lower_bound_s));
    const std::size_t done_before = done_.size();
    Progress progress(hooks_.out, done_before + pending.size(), done_before, sch.planned_s);
    for (std::size_t q = 0; q < sch.order.size(); ++q) {
        if (auto end = before_measurement(plan, pause, &progress)) {
            return end;
        }
        const std::size_t k = sch.order[q];
        if (auto end = measure_standing(pass, *pending[k], poses[k], plan, pause, &progress)) {
            return end;
        }
    }
    progress.finish("pass " + std::to_string(pass) + " complete");
    return std::nullopt;
}

std::optional<Expected<RunResult>> Runner::measure_standing(int pass,
                                                            const PlannedConfig& c,
                                                            const RigPosed& pose,
                                                            const Plan& plan,
                                                            std::string* pause,
                                                            Progress* progress) {
    bool journal_failed = false;
    auto r = measure_config(pass, c, pose, pause, &journal_failed);
    if (!r) {
        if (journal_failed) {
            return Expected<RunResult>(tl::unexpected(r.error()));
        }
        progress->finish("paused");
        return finish(Outcome::kPaused, r.error().message, plan);
    }
    progress->step();
    publish_measurement(*r);
    return after_measurement(plan, progress);
}

std::optional<Expected<RunResult>> Runner::before_measurement(const Plan& plan,
                                                              std::string* pause,
                                                              Progress* progress) {
    if (stop_requested()) {
        progress->finish("stopped on request");
        return finish(Outcome::kInterrupted,
                      "stopped on request after " + std::to_string(result_.measured_now) +
                          " measurements; resume with --resume " + dir_,
                      plan);
    }
    if (spec_.drift_every > 0 && since_reference_ >= static_cast<std::size_t>(spec_.drift_every)) {
        if (auto d = drift_check(false, pause); !d) {
            progress->finish("paused");
            return finish(Outcome::kPaused, d.error().message, plan);
        }
    }
    return std::nullopt;
}

std::string Runner::completion_summary() const {
    std::string summary = "completed: " + std::to_string(done_.size()) + " configurations measured";
    if (result_.pose_repeats + result_.pose_corrections > 0) {
        summary += "; pose checks: " + std::to_string(result_.pose_repeats) +
                   " exposures repeated after an axis moved, " +
                   std::to_string(result_.pose_corrections) + " poses corrected before exposing";
    }
    if (result_.outages > 0) {
        summary += "; " + std::to_string(result_.outages) + " device outages waited out";
    }
    return summary;
}

std::optional<Expected<RunResult>> Runner::after_measurement(const Plan& plan, Progress* progress) {
    if (!rule_.active() || ++since_check_ < check_every_) {
        return std::nullopt;
    }
    auto held = check_stop_rule(plan);
    if (!held) {
        progress->finish("paused");
        return finish(Outcome::kPaused, held.error().message, plan);
    }
    if (*held) {
        progress->finish("target reached");
        return finish(Outcome::kCompleted, "target reached: " + result_.until, plan);
    }
    return std::nullopt;
}

std::optional<Expected<RunResult>> Runner::rule_on_journal(const Plan& plan) {
    auto held = check_stop_rule(plan);
    if (!held) {
        return finish(Outcome::kPaused, held.error().message, plan);
    }
    if (*held) {
        return finish(Outcome::kCompleted, "target reached: " + result_.until, plan);
    }
    return std::nullopt;
}

Expected<RunResult> Runner::run() {
    started_ = now_s();
    auto plan0 = load_campaign();
    if (!plan0) {
        return tl::unexpected(plan0.error());
    }
    const Plan& plan = *plan0;
    const bool have_white = replay_journal();
    say_plan(plan);
    std::string pause;
    if (auto d = prepare_devices(have_white, &pause); !d) {
        return finish(Outcome::kPaused, d.error().message, plan);
    }
    check_every_ = rule_.every > 0            ? static_cast<std::size_t>(rule_.every)
                   : spec_.plan_kind == "fit" ? static_cast<std::size_t>(spec_.fit.batch)
                                              : std::max<std::size_t>(8, plan.configs.size() / 10);
    if (rule_.active() && !done_.empty()) {
        // A resume checks the rule on what the journal holds before measuring anything more.
        if (auto end = rule_on_journal(plan)) {
            return std::move(*end);
        }
    }
    // Passes: 0 is the plan; each adaptive pass refines where the values measured so far change
    // fastest.
    planned_total_ = plan.configs.size();
    // The fit plan's passes are its batches, until its budget is measured.
    const int last_pass = spec_.plan_kind == "vndf"  ? 1
                          : spec_.plan_kind == "fit" ? spec_.fit.budget
                          : spec_.adaptive           ? spec_.adaptive_passes
                                                     : 0;
    for (int pass = 0; pass <= last_pass; ++pass) {
        auto pp = pass_plan(pass, plan);
        if (!pp) {
            return finish(Outcome::kPaused, pp.error().message, plan);
        }
        if (spec_.plan_kind == "fit" && pp->configs.empty()) {
            break;
        }
        result_.planned_total = planned_total_;
        if (auto end = measure_pass(pass, *pp, plan, &pause)) {
            return std::move(*end);
        }
    }
    result_.measured_total = done_.size();
    std::string summary = completion_summary();
    if (rule_.active()) {
        // The plan ended first: the last check says how far the targets were.
        auto held = check_stop_rule(plan);
        if (held && *held) {
            return finish(Outcome::kCompleted, "target reached: " + result_.until, plan);
        }
        summary += "; until " + spec_.until + ": target never reached, the plan ended (" +
                   (until_.is_null() ? std::string("no check could fit")
                                     : until_["message"].get<std::string>()) +
                   ")";
        if (!until_.is_null()) {
            until_["message"] =
                "target never reached: the plan ended; " + until_["message"].get<std::string>();
        }
    }
    return finish(Outcome::kCompleted, summary, plan);
}

}  // namespace gonio::acquisition::campaign_internal

namespace gonio::acquisition {

Expected<RunResult> run_campaign(const std::string& dir, RigDevices& dev, const RunHooks& hooks) {
    campaign_internal::Runner r(dir, dev, hooks);
    Expected<RunResult> res = r.run();
    if (!res) {
        // Nothing measured is lost (journal.log); say how to continue once the cause is fixed.
        return make_error(res.error().message + "\nThe campaign folder " + dir +
                          " is kept; after fixing the cause (e.g. free disk space), continue with: "
                          "gonio acquire --resume " +
                          dir);
    }
    return res;
}

}  // namespace gonio::acquisition
