// The runner's fly scans: a pass in sweeps, each sweep journaled as it starts and its frames as values once it ends (campaign_runner.h, fly_plan.h, fly_sweep.h).

#include "campaign_runner.h"

namespace gonio::acquisition::campaign_internal {

FlyLimits Runner::fly_limits() const {
    FlyLimits l;
    l.dyn = dyn_;
    l.range = lim_.range;
    l.readout_s = rig_.camera_readout_ms / 1000.0;
    l.min_exposure_s = rig_.capture.min_exposure_us * 1e-6;
    l.max_exposure_s = rig_.capture.max_exposure_us * 1e-6;
    return l;
}

namespace {

/// Motion time of the units from `start`: the moves into each, the sweeps' trapezoids, each
/// sweep run once per colour filter (`filters`) with the arm back at its lead-in in between.
double fly_motion_s(const std::vector<FlyUnit>& units,
                    const RigPosed& start,
                    const std::array<AxisDynamics, kNumAxes>& dyn,
                    int filters) {
    double t = 0;
    RigPosed at = start;
    for (const FlyUnit& u : units) {
        t += move_time(at, u.sweep.stand, dyn);
        at = u.sweep.stand;
        if (!u.standing) {
            const double d = std::abs(u.sweep.to - u.sweep.from);
            const AxisDynamics& a = dyn[u.sweep.axis];
            t += filters * trapezoid_time(d, u.sweep.speed, a.accel) +
                 (filters - 1) * trapezoid_time(d, a.speed, a.accel);
            set_axis_angle(&at, u.sweep.axis, u.sweep.to);
        }
    }
    return t;
}

}  // namespace

std::optional<Expected<RunResult>> Runner::measure_fly_pass(
    int pass,
    const std::vector<const PlannedConfig*>& pending,
    const std::vector<RigPosed>& poses,
    const Plan& plan,
    std::string* pause) {
    const std::vector<FlyUnit> units = plan_fly_units(poses, current_, spec_.fly, fly_limits());
    std::size_t sweeps = 0, swept = 0;
    for (const FlyUnit& u : units) {
        sweeps += !u.standing;
        swept += u.standing ? 0 : u.sweep.members.size();
    }
    const double planned_s = fly_motion_s(units, current_, dyn_, dev_.filter_wheel ? 3 : 1);
    say("pass " + std::to_string(pass) + ": " + std::to_string(pending.size()) +
        " to measure; fly scans: " + std::to_string(sweeps) + " sweeps through " +
        std::to_string(swept) + " configurations, " + std::to_string(pending.size() - swept) +
        " standing; motion time planned " + format_duration(planned_s));
    const std::size_t done_before = done_.size();
    Progress progress(hooks_.out, done_before + pending.size(), done_before, planned_s);
    std::vector<std::size_t> standing;
    for (const FlyUnit& u : units) {
        if (u.standing) {
            standing.insert(standing.end(), u.sweep.members.begin(), u.sweep.members.end());
            continue;
        }
        if (auto end = before_measurement(plan, pause, &progress)) {
            return end;
        }
        if (auto end = fly_sweep(pass, u.sweep, pending, poses, plan, &progress, &standing)) {
            return end;
        }
    }
    // What no sweep measured, in one scheduled tour after the sweeps.
    std::vector<RigPosed> stand_poses;
    for (std::size_t k : standing) {
        stand_poses.push_back(poses[k]);
    }
    ScheduleOptions so;
    so.budget_s = spec_.schedule_budget_s;
    const Schedule sch = schedule(stand_poses, current_, dyn_, so);
    for (std::size_t q : sch.order) {
        if (auto end = before_measurement(plan, pause, &progress)) {
            return end;
        }
        const std::size_t k = standing[q];
        ++result_.standing;
        if (auto end = measure_standing(pass, *pending[k], poses[k], plan, pause, &progress)) {
            return end;
        }
    }
    progress.finish("pass " + std::to_string(pass) + " complete");
    return std::nullopt;
}

Expected<RigPosed> Runner::start_sweep(int pass,
                                       const Sweep& sw,
                                       const std::vector<const PlannedConfig*>& pending) {
    JournalRecord r;
    r.text = "configurations:";
    for (std::size_t k : sw.members) {
        r.text += " " + std::to_string(pending[k]->index);
    }
    r.type = RecordType::kSweep;
    r.pass = pass;
    r.index = static_cast<std::uint32_t>(result_.sweeps);
    RigPosed end = sw.stand;
    set_axis_angle(&end, sw.axis, sw.to);
    r.pose_deg = pose_deg(sw.stand);
    r.has_path = true;
    r.path_start_deg = pose_deg(sw.stand);
    r.path_end_deg = pose_deg(end);
    r.speed_deg_per_s = sw.speed / kDeg;
    r.exposure_us = sw.max_exposure_s * 1e6;
    r.time_s = now_s();
    if (auto a = journal_->append(r); !a) {
        return tl::unexpected(a.error());
    }
    if (auto m = move_to(sw.stand); !m) {
        return tl::unexpected(m.error());
    }
    return read_pose();
}

Expected<JournalRecord> Runner::fly_record(int pass,
                                           const PlannedConfig& c,
                                           const Sweep& sw,
                                           const RigPosed& stood,
                                           const std::vector<const FlyFrame*>& f) {
    const double a0 = f[0]->latch_deg[0] * kDeg;
    const double a1 = f[0]->latch_deg[1] * kDeg;
    const double lo = std::min(sw.from, sw.to);
    const double hi = std::max(sw.from, sw.to);
    if (!(std::isfinite(a0) && std::isfinite(a1) && std::min(a0, a1) >= lo - 1e-3 &&
          std::max(a0, a1) <= hi + 1e-3)) {
        return make_error(
            "the drive latched the exposure at " + std::to_string(f[0]->latch_deg[0]) + " .. " +
            std::to_string(f[0]->latch_deg[1]) + " deg, outside the sweep: measured standing");
    }
    SignalRate rate;
    for (std::size_t q = 0; q < f.size(); ++q) {
        for (int e = 0; e < 2; ++e) {
            if (!(std::abs(f[q]->latch_deg[e] - f[0]->latch_deg[e]) <= kColourPathToleranceDeg)) {
                return make_error(
                    "the colours' exposures were latched on different paths: "
                    "measured standing");
            }
        }
        auto r = session_->rate_of(f[q]->frame);
        if (!r) {
            return tl::unexpected(r.error());
        }
        if (r->saturated) {
            ++fly_saturated_;
            return make_error("saturated at the sweep's exposure: measured standing (HDR)");
        }
        // Behind filter q its colour (a monochrome rig: the one frame's value in all three).
        for (std::size_t ch = 0; ch < 3; ++ch) {
            if (f.size() == 1 || ch == q) {
                rate.rate[ch] = r->rate[ch];
                rate.sigma[ch] = r->sigma[ch];
            }
        }
        rate.exposure_us = std::max(rate.exposure_us, r->exposure_us);
        rate.pixels = q == 0 ? r->pixels : std::min(rate.pixels, r->pixels);
    }
    RigPosed p0 = stood, p1 = stood, mid = stood;
    set_axis_angle(&p0, sw.axis, a0);
    set_axis_angle(&p1, sw.axis, a1);
    set_axis_angle(&mid, sw.axis, 0.5 * (a0 + a1));
    Shot s;
    s.pose = mid;
    s.rate = rate;
    std::tie(s.wi, s.wo) = brdf::rig_forward(mid);
    auto v = rate_to_brdf(white_, rate.rate, rate.sigma, s.wi.z());
    if (!v) {
        return tl::unexpected(v.error());
    }
    JournalRecord r = record_of(RecordType::kMeasurement, s, *v);
    r.pass = pass;
    r.index = c.index;
    r.flags |= c.flags;
    r.weight = c.weight;
    r.has_path = true;
    r.path_start_deg = pose_deg(p0);
    r.path_end_deg = pose_deg(p1);
    return r;
}

SweepTrigger Runner::sweep_trigger(int axis) const {
    const std::optional<bool>& pc = rig_.axes[axis].position_compare;
    const bool hardware = pc ? *pc : dev_.axes[axis]->has_position_compare();
    return hardware ? SweepTrigger::kPositionCompare : SweepTrigger::kPolled;
}

Expected<std::vector<SweepFrames>> Runner::sweep_filters(const Sweep& sw,
                                                         const RigPosed& stood,
                                                         const std::vector<double>& targets_deg) {
    const int filters = dev_.filter_wheel ? 3 : 1;
    std::vector<SweepFrames> out;
    double next_us = std::numeric_limits<double>::infinity();
    for (int c = 0; c < filters; ++c) {
        if (dev_.filter_wheel) {
            if (c > 0) {
                if (auto m = move_to(stood); !m) {
                    return tl::unexpected(m.error());
                }
            }
            if (auto f = dev_.filter_wheel->set_filter(c); !f) {
                return tl::unexpected(f.error());
            }
        }
        double exposure_us = fly_exposure_us_;
        auto frames = run_sweep(*dev_.axes[sw.axis],
                                *session_,
                                sw,
                                targets_deg,
                                &exposure_us,
                                std::chrono::milliseconds(rig_.move_timeout_ms),
                                sweep_trigger(sw.axis));
        if (!frames) {
            return tl::unexpected(frames.error());
        }
        clock_->sweep(sw.axis, sw.to - sw.from, sw.speed);
        current_ = stood;
        set_axis_angle(&current_, sw.axis, sw.to);
        next_us = std::min(next_us, exposure_us);
        out.push_back(std::move(*frames));
    }
    fly_exposure_us_ = next_us;
    return out;
}

std::vector<const FlyFrame*> Runner::member_frames(const std::vector<SweepFrames>& per_filter,
                                                   std::size_t k) {
    std::vector<const FlyFrame*> out;
    for (const SweepFrames& sf : per_filter) {
        for (const FlyFrame& f : sf.frames) {
            if (f.member == k) {
                out.push_back(&f);
                break;
            }
        }
    }
    if (out.size() != per_filter.size()) {
        out.clear();
    }
    return out;
}

std::optional<Expected<RunResult>> Runner::fly_sweep(
    int pass,
    const Sweep& sw,
    const std::vector<const PlannedConfig*>& pending,
    const std::vector<RigPosed>& poses,
    const Plan& plan,
    Progress* progress,
    std::vector<std::size_t>* standing) {
    auto stood = start_sweep(pass, sw, pending);
    std::vector<double> targets_deg;
    for (std::size_t k : sw.members) {
        targets_deg.push_back(axis_angle(poses[k], sw.axis) / kDeg);
    }
    if (fly_exposure_us_ <= 0) {
        fly_exposure_us_ = sw.max_exposure_s * 1e6 / 8;
    }
    auto frames = stood ? sweep_filters(sw, *stood, targets_deg)
                        : Expected<std::vector<SweepFrames>>(tl::unexpected(stood.error()));
    ++result_.sweeps;
    if (!frames) {
        // The standing measurements that follow retry, wait out outages or pause.
        note("fly sweep " + std::to_string(result_.sweeps) + " failed (" + frames.error().message +
             "): its configurations are measured standing");
        if (auto p = read_pose(); p) {
            current_ = *p;
        }
        *standing = sw.members;
        return std::nullopt;
    }
    for (std::size_t k = 0; k < sw.members.size(); ++k) {
        const std::size_t i = sw.members[k];
        const std::vector<const FlyFrame*> f = member_frames(*frames, k);
        if (f.empty()) {
            ++fly_missed_;
            standing->push_back(i);
            continue;
        }
        auto r = fly_record(pass, *pending[i], sw, *stood, f);
        if (!r) {
            standing->push_back(i);
            continue;
        }
        if (auto a = journal_->append(*r); !a) {
            return Expected<RunResult>(tl::unexpected(a.error()));
        }
        done_.insert({pass, r->index});
        ++since_reference_;
        ++result_.measured_now;
        ++result_.swept;
        result_.measured_total = done_.size();
        progress->step();
        publish_measurement(*r);
        if (auto end = after_measurement(plan, progress)) {
            return end;
        }
    }
    return std::nullopt;
}

}  // namespace gonio::acquisition::campaign_internal
