// The runner's device work: poses read back, moves, exposures with their checks and retries, outages waited out, the white reference and the drift checks (campaign_runner.h).

#include "campaign_runner.h"

namespace gonio::acquisition::campaign_internal {

Expected<RigPosed> Runner::read_pose() {
    double v[kNumAxes];
    for (int k = 0; k < kNumAxes; ++k) {
        auto p = dev_.axes[k]->position_deg();
        if (!p) {
            return tl::unexpected(p.error());
        }
        v[k] = *p * kDeg;
    }
    return RigPosed{v[0], v[1], v[2], v[3]};
}

Expected<void> Runner::home_if_needed() {
    for (int k = 0; k < kNumAxes; ++k) {
        auto st = dev_.axes[k]->status();
        if (!st) {
            return tl::unexpected(st.error());
        }
        if (st->state == devices::AxisState::kAlarm) {
            return make_error("axis \"" + dev_.axes[k]->name() + "\" in alarm (code " +
                              std::to_string(st->alarm_code) +
                              "): clear the cause, then reset the drive");
        }
        if (!st->homed) {
            say("homing axis \"" + dev_.axes[k]->name() + "\"");
            if (auto at = dev_.axes[k]->position_deg(); at) {
                clock_->home(k, *at * kDeg);
            }
            if (auto h = dev_.axes[k]->home(std::chrono::milliseconds(rig_.move_timeout_ms)); !h) {
                return h;
            }
        }
    }
    return {};
}

Expected<void> Runner::move_to(const RigPosed& p) {
    const double target[kNumAxes] = {p.light, p.detector, p.tilt, p.spin};
    const double cur[kNumAxes] = {current_.light, current_.detector, current_.tilt, current_.spin};
    bool moved[kNumAxes] = {false, false, false, false};
    for (int k = 0; k < kNumAxes; ++k) {
        if (std::abs(target[k] - cur[k]) < 1e-7) {
            continue;
        }
        if (auto r = dev_.axes[k]->start_move(target[k] / kDeg); !r) {
            return r;
        }
        moved[k] = true;
    }
    double settle_ms = 0;
    for (int k = 0; k < kNumAxes; ++k) {
        if (!moved[k]) {
            continue;
        }
        if (auto r = dev_.axes[k]->wait_done(std::chrono::milliseconds(rig_.move_timeout_ms)); !r) {
            return r;
        }
        settle_ms = std::max(settle_ms, rig_.axes[k].motion.settle_ms);
    }
    // Mechanical settling after the drives report in position (a physical time, not a wait for
    // a state that could be polled).
    if (settle_ms > 0) {
        std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(settle_ms));
    }
    clock_->move(current_, p);
    current_ = p;
    return {};
}

/// Largest difference between two position read-backs of a standing axis that is not a move:
/// ten steps of the finest shipped profile (1000 steps/deg), well above the rounding of a target
/// to a step.
constexpr double kPoseToleranceDeg = 0.01;
/// A pose that keeps moving during exposures this many times in a row pauses the campaign.
constexpr int kMaxPoseRepeats = 5;

std::string Runner::pose_change(const RigPosed& a, const RigPosed& b) const {
    const auto da = pose_deg(a);
    const auto db = pose_deg(b);
    std::string out;
    for (int k = 0; k < kNumAxes; ++k) {
        if (std::abs(db[k] - da[k]) > kPoseToleranceDeg) {
            char buf[160];
            std::snprintf(buf,
                          sizeof buf,
                          "%s%s %.4f -> %.4f deg",
                          out.empty() ? "" : ", ",
                          dev_.axes[k]->name().c_str(),
                          da[k],
                          db[k]);
            out += buf;
        }
    }
    return out;
}

void Runner::note(const std::string& text) {
    say(text);
    JournalRecord n;
    n.type = RecordType::kNote;
    n.text = text;
    n.time_s = now_s();
    (void)journal_->append(n);
}

Expected<SignalRate> Runner::expose() {
    if (!dev_.filter_wheel) {
        // Monochrome detector: one unfiltered measurement, the same value in r, g and b.
        return session_->measure();
    }
    // Colour through the filter changer: one full (auto-exposed, HDR, dark-subtracted)
    // measurement per filter; channel c of the result is the rate behind filter c.
    SignalRate out;
    for (int c = 0; c < 3; ++c) {
        if (auto f = dev_.filter_wheel->set_filter(c); !f) {
            return tl::unexpected(f.error());
        }
        auto rate = session_->measure();
        if (!rate) {
            return tl::unexpected(rate.error());
        }
        out.rate[c] = rate->rate[c];
        out.sigma[c] = rate->sigma[c];
        out.saturated = out.saturated || rate->saturated;
        out.hdr = out.hdr || rate->hdr;
        out.exposure_us = std::max(out.exposure_us, rate->exposure_us);
        out.pixels = c == 0 ? rate->pixels : std::min(out.pixels, rate->pixels);
    }
    return out;
}

Expected<Runner::Shot> Runner::measure_once(const RigPosed& target, const std::string& what) {
    // Pose integrity: the positions are read back before and after each exposure. An axis found
    // away from its target is moved back first; one that moved during the exposure (another
    // client, a stall, a lost step) makes the measurement repeat. Both are journalled and counted;
    // neither reaches the dataset.
    for (int repeat = 0;; ++repeat) {
        if (auto m = move_to(target); !m) {
            return tl::unexpected(m.error());
        }
        auto before = read_pose();
        if (!before) {
            return tl::unexpected(before.error());
        }
        if (const std::string off = pose_change(target, *before); !off.empty()) {
            ++result_.pose_corrections;
            note("pose check: before the exposure of " + what + " the axes were off target (" +
                 off + "); moved back");
            current_ = *before;  // So that move_to commands every axis that is off.
            if (repeat >= kMaxPoseRepeats) {
                return make_error("pose check: the axes do not stay on target for " + what + " (" +
                                  off + ")");
            }
            continue;
        }
        auto rate = expose();
        if (!rate) {
            return tl::unexpected(rate.error());
        }
        auto after = read_pose();
        if (!after) {
            return tl::unexpected(after.error());
        }
        if (const std::string moved = pose_change(*before, *after); !moved.empty()) {
            ++result_.pose_repeats;
            note("pose check: an axis moved during the exposure of " + what + " (" + moved +
                 "); the measurement is repeated");
            current_ = *after;
            if (repeat >= kMaxPoseRepeats) {
                return make_error("pose check: axes keep moving during the exposures of " + what +
                                  " (" + moved + ")");
            }
            continue;
        }
        Shot s;
        s.rate = *rate;
        s.pose = *before;
        const auto [wi, wo] = brdf::rig_forward(*before);
        s.wi = wi;
        s.wo = wo;
        return s;
    }
}

Expected<void> Runner::wait_for_devices(const std::string& what, const std::string& cause) {
    ++result_.outages;
    note("devices unreachable during " + what + " (" + cause +
         "): the campaign is paused and resumes on its own when they answer again (Ctrl-C "
         "stops it with its state saved)");
    const double t0 = now_s();
    double wait_s = hooks_.outage_probe_s;
    while (!stop_requested()) {
        std::this_thread::sleep_for(std::chrono::duration<double>(wait_s));  // Probe pacing.
        bool all = true;
        for (int k = 0; k < kNumAxes && all; ++k) {
            all = static_cast<bool>(dev_.axes[k]->status());
        }
        const double down_s = now_s() - t0;
        if (all) {
            char buf[120];
            std::snprintf(buf, sizeof buf, "devices answer again after %.1f s: resuming", down_s);
            note(buf);
            return {};
        }
        if (down_s > hooks_.max_outage_s) {
            return make_error("devices unreachable for more than " +
                              std::to_string(static_cast<long>(hooks_.max_outage_s)) +
                              " s during " + what + " (" + cause +
                              "); the campaign is paused with its state saved");
        }
        wait_s = std::min(2 * wait_s, 8 * hooks_.outage_probe_s);
    }
    return make_error("stopped on request while the devices were unreachable during " + what);
}

Expected<Runner::Shot> Runner::attempt(const RigPosed& target,
                                       const std::string& what,
                                       std::string* pause) {
    std::string last;
    for (int a = 0; a <= rig_.retries; ++a) {
        auto s = measure_once(target, what);
        if (s) {
            return s;
        }
        last = s.error().message;
        // A drive alarm is a safety stop: never retried automatically. A device that does not
        // answer (an outage longer than the bus's reconnect window) is waited for.
        bool unreachable = false;
        for (int k = 0; k < kNumAxes && !unreachable; ++k) {
            auto st = dev_.axes[k]->status();
            unreachable = !st;
            if (st && st->state == devices::AxisState::kAlarm) {
                *pause = "axis \"" + dev_.axes[k]->name() + "\" raised alarm code " +
                         std::to_string(st->alarm_code) + " during " + what + " (" + last +
                         "); the campaign is paused with its state saved: clear the cause, reset "
                         "the drive, then resume";
                return make_error(*pause);
            }
        }
        if (unreachable) {
            if (auto w = wait_for_devices(what, last); !w) {
                *pause = w.error().message;
                return tl::unexpected(w.error());
            }
            if (auto p = read_pose(); p) {
                current_ = *p;
            }
            session_->clear_dark_cache();
            --a;  // The outage is not a failed attempt.
            continue;
        }
        say("device error during " + what + " (attempt " + std::to_string(a + 1) + "/" +
            std::to_string(rig_.retries + 1) + "): " + last);
        // The position is unknown after a failed move: read it back before the next attempt.
        if (auto p = read_pose(); p) {
            current_ = *p;
        }
        session_->clear_dark_cache();
    }
    *pause = "device fault during " + what + " after " + std::to_string(rig_.retries + 1) +
             " attempts: " + last + "; the campaign is paused with its state saved";
    return make_error(*pause);
}

JournalRecord Runner::record_of(RecordType type, const Shot& s, const BrdfValue& v) const {
    JournalRecord r;
    r.type = type;
    r.wi = s.wi;
    r.wo = s.wo;
    r.pose_deg = pose_deg(s.pose);
    r.value = v.value;
    r.sigma = v.sigma;
    r.rate = s.rate.rate;
    r.rate_sigma = s.rate.sigma;
    r.exposure_us = s.rate.exposure_us;
    r.time_s = now_s();
    if (s.rate.saturated) {
        r.flags |= brdf::kFlagSaturated;
    }
    if (s.rate.hdr) {
        r.flags |= brdf::kFlagHdr;
    }
    return r;
}

Expected<void> Runner::white_calibration(std::string* pause) {
    char reflectance[32];
    std::snprintf(reflectance, sizeof reflectance, "%.4g", rig_.white_reflectance);
    say(std::string("white reference: measuring (reflectance ") + reflectance + ")");
    auto mount = [&](bool white) -> Expected<void> {
        if (dev_.reference_changer) {
            return dev_.reference_changer->set_shutter_open(white);
        }
        if (hooks_.mount) {
            return hooks_.mount(white);
        }
        return make_error("the rig has no reference changer and no operator prompt is available");
    };
    if (auto m = mount(true); !m) {
        return m;
    }
    const Vec3d wi = brdf::spherical_to_cartesian(rig_.white_theta_i_deg * kDeg, 0.0);
    const Vec3d wo = brdf::spherical_to_cartesian(rig_.white_theta_o_deg * kDeg, kPi);
    auto sol = solve(Target{wi, wo, true, true}, lim_, dyn_, current_);
    if (!sol) {
        (void)mount(false);
        return make_error("white reference geometry unreachable: " + sol.error().message);
    }
    auto s = attempt(sol->pose, "the white reference", pause);
    if (auto m = mount(false); !m) {
        return m;
    }
    if (!s) {
        return tl::unexpected(s.error());
    }
    WhiteCalibration w;
    w.reflectance = rig_.white_reflectance;
    w.cos_theta_w = s->wi.z();
    w.rate = s->rate.rate;
    w.rate_sigma = s->rate.sigma;
    if (s->rate.saturated) {
        return make_error(
            "white reference saturated at the shortest exposure: lower the lamp "
            "power or the gain");
    }
    if (auto v = validate(w); !v) {
        return v;
    }
    BrdfValue bv;
    bv.value = brdf::Rgbd::Constant(w.reflectance / kPi);
    JournalRecord r = record_of(RecordType::kWhite, *s, bv);
    if (auto a = journal_->append(r); !a) {
        return a;
    }
    white_ = w;
    return {};
}

Expected<void> Runner::drift_check(bool baseline, std::string* pause) {
    const Vec3d wi = brdf::spherical_to_cartesian(spec_.drift_theta_i_deg * kDeg, 0.0);
    const Vec3d wo = brdf::spherical_to_cartesian(spec_.drift_theta_r_deg * kDeg,
                                                  spec_.drift_delta_phi_deg * kDeg);
    // An anisotropic sample reads differently at every spin: its reference is held at one spin,
    // the directions fixed in the sample's frame, so that only the lamp can change the reading.
    const bool isotropic =
        isotropic_plan(spec_) && !(spec_.plan_kind == "vndf" && spec_.vndf.phi_i_count >= 2);
    auto sol = solve(Target{wi, wo, isotropic, true}, lim_, dyn_, current_);
    if (!sol) {
        return make_error("drift reference configuration unreachable: " + sol.error().message);
    }
    auto s = attempt(sol->pose, "the drift reference", pause);
    if (!s) {
        return tl::unexpected(s.error());
    }
    auto v = rate_to_brdf(white_, s->rate.rate, s->rate.sigma, s->wi.z());
    if (!v) {
        return tl::unexpected(v.error());
    }
    JournalRecord r = record_of(RecordType::kReference, *s, *v);
    r.flags |= brdf::kFlagReference;
    r.text = baseline ? "baseline" : "check";
    if (auto a = journal_->append(r); !a) {
        return a;
    }
    since_reference_ = 0;
    if (baseline || !baseline_) {
        baseline_ = r;
        return {};
    }
    const double v0 = luminance(baseline_->value);
    const double v1 = luminance(r.value);
    const double rel = v0 > 0 ? std::abs(v1 / v0 - 1) : 0;
    const double noise = (v0 > 0 && v1 > 0)
                             ? std::hypot(luminance(baseline_->sigma) / v0, luminance(r.sigma) / v1)
                             : 0;
    if (rel > spec_.drift_threshold && rel > 3 * noise) {
        char buf[400];
        std::snprintf(buf,
                      sizeof buf,
                      "lamp drift: the reference configuration (theta_i %.0f, theta_r %.0f, "
                      "delta_phi %.0f deg) reads %.4g 1/sr against %.4g at the baseline (%+.1f%%, "
                      "threshold %.1f%%). The campaign is paused with its state saved: check the "
                      "lamp, then resume (add --accept-drift to take the current level as the new "
                      "baseline)",
                      spec_.drift_theta_i_deg,
                      spec_.drift_theta_r_deg,
                      spec_.drift_delta_phi_deg,
                      v1,
                      v0,
                      100 * (v1 / v0 - 1),
                      100 * spec_.drift_threshold);
        *pause = buf;
        return make_error(*pause);
    }
    return {};
}

}  // namespace gonio::acquisition::campaign_internal
