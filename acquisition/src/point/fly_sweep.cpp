#include "gonio/acquisition/point/fly_sweep.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace gonio::acquisition {

namespace {

constexpr double kDeg = brdf::kPi / 180;
using Clock = std::chrono::steady_clock;

/// Polls the arm until its encoder passes `trigger_deg` going `dir`: its position then, NaN when
/// the move ended first. An alarm, a device error or the deadline is an error.
Expected<double> wait_until_passed(devices::Axis& axis,
                                   double trigger_deg,
                                   double dir,
                                   Clock::time_point deadline) {
    for (;;) {
        auto st = axis.status();
        if (!st) {
            return tl::unexpected(st.error());
        }
        if (dir * (st->position_deg - trigger_deg) >= 0) {
            return st->position_deg;
        }
        if (st->state == devices::AxisState::kAlarm) {
            return make_error("axis \"" + axis.name() + "\" raised alarm code " +
                              std::to_string(st->alarm_code) + " during a fly-scan sweep");
        }
        if (st->state != devices::AxisState::kMoving) {
            return std::numeric_limits<double>::quiet_NaN();
        }
        if (Clock::now() > deadline) {
            return make_error("axis \"" + axis.name() + "\": the fly-scan sweep did not reach " +
                              std::to_string(trigger_deg) + " deg within the move timeout");
        }
    }
}

/// Where member k's frame is too late: half the way to the next member, and no later than an
/// exposure of `span_deg` ending where the arm starts to slow down.
double late_limit_deg(const Sweep& s,
                      const std::vector<double>& targets_deg,
                      std::size_t k,
                      double span_deg,
                      double accel_deg_per_s2) {
    const double dir = s.to > s.from ? 1.0 : -1.0;
    const double speed_deg = s.speed / kDeg;
    const double cruise_end = s.to / kDeg - dir * speed_deg * speed_deg / (2 * accel_deg_per_s2);
    double limit = cruise_end - dir * span_deg;
    if (k + 1 < targets_deg.size()) {
        const double half_way = 0.5 * (targets_deg[k] + targets_deg[k + 1]);
        limit = dir > 0 ? std::min(limit, half_way) : std::max(limit, half_way);
    }
    return limit;
}

/// The frames of a sweep whose arm is at its lead-in at the sweep's speed.
Expected<SweepFrames> sweep_frames(devices::Axis& axis,
                                   CaptureSession& session,
                                   const Sweep& s,
                                   const std::vector<double>& targets_deg,
                                   double* exposure_us,
                                   std::chrono::milliseconds timeout) {
    const double dir = s.to > s.from ? 1.0 : -1.0;
    const double max_us = s.max_exposure_s * 1e6;
    // The first frame starts from the last frame's exposure (a level at the target keeps it),
    // on the ladder and within the sweep's bound.
    const CaptureConfig& c = session.config();
    double t = next_fly_exposure_us(
        session, *exposure_us, c.target_fraction / c.linear_max_fraction, max_us);
    if (auto e = session.set_moving_exposure(t); !e) {
        return tl::unexpected(e.error());
    }
    if (auto m = axis.start_move(s.to / kDeg); !m) {
        return tl::unexpected(m.error());
    }
    const Clock::time_point deadline = Clock::now() + timeout;
    SweepFrames out;
    const double accel = axis.motion().accel_deg_per_s2;
    for (std::size_t k = 0; k < s.members.size(); ++k) {
        const double span_deg = s.speed / kDeg * t * 1e-6;
        auto at = wait_until_passed(axis, targets_deg[k] - dir * 0.5 * span_deg, dir, deadline);
        if (!at) {
            return tl::unexpected(at.error());
        }
        if (!std::isfinite(*at)) {
            for (; k < s.members.size(); ++k) {
                out.missed.push_back(k);  // the move ended before these triggers
            }
            break;
        }
        if (dir * (*at - late_limit_deg(s, targets_deg, k, span_deg, accel)) > 0) {
            out.missed.push_back(k);
            continue;
        }
        auto f = session.grab_moving();
        if (!f) {
            return tl::unexpected(f.error());
        }
        auto latch = axis.exposure_latch_deg();
        if (!latch) {
            return tl::unexpected(latch.error());
        }
        auto level = session.level_of(*f);
        if (!level) {
            return tl::unexpected(level.error());
        }
        out.frames.push_back(FlyFrame{k, std::move(*f), *latch});
        const double hf =
            level->saturated > 0 ? std::max(level->high_fraction, 1.0) : level->high_fraction;
        t = next_fly_exposure_us(session, t, hf, max_us);
        if (auto e = session.set_moving_exposure(t); !e) {
            return tl::unexpected(e.error());
        }
    }
    *exposure_us = t;
    if (auto w = axis.wait_done(timeout); !w) {
        return tl::unexpected(w.error());
    }
    return out;
}

/// The frames the camera streams while the arm runs to the sweep's lead-out, at most `n`: until
/// all came, or the move ended and none came for the capture timeout since. An alarm, a device
/// error or the deadline is an error.
Expected<std::vector<devices::Frame>> collect_line_frames(devices::Axis& axis,
                                                          CaptureSession& session,
                                                          const Sweep& s,
                                                          std::size_t n,
                                                          double exposure_us,
                                                          std::chrono::milliseconds timeout) {
    if (auto m = axis.start_move(s.to / kDeg); !m) {
        return tl::unexpected(m.error());
    }
    const Clock::time_point deadline = Clock::now() + timeout;
    const auto wait = std::chrono::milliseconds(50 + static_cast<int>(exposure_us / 1000));
    const auto grace = std::chrono::milliseconds(session.config().timeout_ms);
    std::optional<Clock::time_point> ended;
    std::vector<devices::Frame> frames;
    while (frames.size() < n) {
        if (auto f = session.next_line_frame(wait)) {
            frames.push_back(std::move(*f));
            continue;
        }
        auto st = axis.status();
        if (!st) {
            return tl::unexpected(st.error());
        }
        if (st->state == devices::AxisState::kAlarm) {
            return make_error("axis \"" + axis.name() + "\" raised alarm code " +
                              std::to_string(st->alarm_code) + " during a fly-scan sweep");
        }
        const Clock::time_point now = Clock::now();
        if (st->state != devices::AxisState::kMoving && !ended) {
            ended = now;
        }
        if ((ended && now - *ended > grace) || now > deadline) {
            break;
        }
    }
    if (auto w = axis.wait_done(timeout); !w) {
        return tl::unexpected(w.error());
    }
    return frames;
}

/// Member k of each frame: by order when every pulse's frame came, else by the camera's frame ids
/// counted from `id0` (the last frame before the sweep); a frame that fits neither is dropped.
std::vector<std::size_t> frame_members(const std::vector<devices::Frame>& frames,
                                       std::size_t pulses,
                                       std::uint64_t id0) {
    std::vector<std::size_t> out;
    for (std::size_t j = 0; j < frames.size(); ++j) {
        if (frames.size() == pulses) {
            out.push_back(j);
            continue;
        }
        // GigE Vision block ids run 1..65535 and wrap past 0.
        std::int64_t d =
            static_cast<std::int64_t>(frames[j].frame_id) - static_cast<std::int64_t>(id0);
        if (d <= 0 && id0 != 0) {
            d += 65535;
        }
        out.push_back(id0 != 0 && d >= 1 && static_cast<std::size_t>(d) <= pulses
                          ? static_cast<std::size_t>(d - 1)
                          : pulses);  // no member
    }
    return out;
}

/// The frames of a sweep triggered by the drive's position compare, the arm at its lead-in at the
/// sweep's speed; the exposure set for the whole sweep.
Expected<SweepFrames> compare_sweep_frames(devices::Axis& axis,
                                           CaptureSession& session,
                                           const Sweep& s,
                                           const std::vector<double>& targets_deg,
                                           double t,
                                           std::chrono::milliseconds timeout) {
    const double dir = s.to > s.from ? 1.0 : -1.0;
    const double span_deg = s.speed / kDeg * t * 1e-6;
    std::vector<double> triggers;
    for (double g : targets_deg) {
        triggers.push_back(g - dir * 0.5 * span_deg);
    }
    if (auto a = axis.arm_position_compare(triggers); !a) {
        return tl::unexpected(a.error());
    }
    const std::uint64_t id0 = session.last_frame_id();
    auto frames = session.start_line_frames(kTriggerLine)
                      ? collect_line_frames(axis, session, s, triggers.size(), t, timeout)
                      : Expected<std::vector<devices::Frame>>(make_error(
                            "camera: no line-triggered stream on " + std::string(kTriggerLine)));
    (void)session.stop_line_frames();
    auto pulses = frames ? axis.compare_pulses() : Expected<std::size_t>(0);
    if (!frames || !pulses) {
        (void)axis.disarm_position_compare();
        return tl::unexpected(!frames ? frames.error() : pulses.error());
    }
    SweepFrames out;
    const std::vector<std::size_t> member = frame_members(*frames, *pulses, id0);
    std::vector<bool> taken(targets_deg.size(), false);
    for (std::size_t j = 0; j < frames->size(); ++j) {
        const std::size_t k = member[j];
        if (k >= targets_deg.size() || taken[k]) {
            continue;
        }
        auto latch = axis.compare_latch_deg(k + 1);
        if (!latch) {
            return tl::unexpected(latch.error());
        }
        taken[k] = true;
        out.frames.push_back(FlyFrame{k, std::move((*frames)[j]), *latch});
    }
    for (std::size_t k = 0; k < taken.size(); ++k) {
        if (!taken[k]) {
            out.missed.push_back(k);
        }
    }
    if (auto d = axis.disarm_position_compare(); !d) {
        return tl::unexpected(d.error());
    }
    return out;
}

/// The exposure after a sweep at `t`: auto exposure on its brightest frame's level.
Expected<double> exposure_after(const CaptureSession& session,
                                const SweepFrames& frames,
                                double t,
                                double max_us) {
    double hf_max = -1;
    for (const FlyFrame& f : frames.frames) {
        auto level = session.level_of(f.frame);
        if (!level) {
            return tl::unexpected(level.error());
        }
        hf_max = std::max(
            hf_max,
            level->saturated > 0 ? std::max(level->high_fraction, 1.0) : level->high_fraction);
    }
    return hf_max < 0 ? t : next_fly_exposure_us(session, t, hf_max, max_us);
}

}  // namespace

double next_fly_exposure_us(const CaptureSession& session,
                            double exposure_us,
                            double high_fraction,
                            double max_us) {
    const CaptureConfig& c = session.config();
    const double lo = c.min_exposure_us;
    const double hi = std::max(lo, std::min(max_us, c.max_exposure_us));
    double t = session.quantise_exposure(next_exposure_us(
        exposure_us, high_fraction, c.target_fraction / c.linear_max_fraction, lo, hi));
    // The ladder step at or below the sweep's bound.
    while (t > hi * (1 + 1e-9) && t > lo * (1 + 1e-9)) {
        t = session.quantise_exposure(t / std::sqrt(2.0));
    }
    return t;
}

Expected<SweepFrames> run_sweep(devices::Axis& axis,
                                CaptureSession& session,
                                const Sweep& s,
                                const std::vector<double>& targets_deg,
                                double* exposure_us,
                                std::chrono::milliseconds timeout,
                                SweepTrigger trigger) {
    const devices::Motion normal = axis.motion();
    devices::Motion m = normal;
    m.speed_deg_per_s = s.speed / kDeg;
    if (auto r = axis.set_motion(m); !r) {
        return tl::unexpected(r.error());
    }
    Expected<SweepFrames> out = SweepFrames{};
    if (trigger == SweepTrigger::kPolled) {
        out = sweep_frames(axis, session, s, targets_deg, exposure_us, timeout);
    } else {
        const CaptureConfig& c = session.config();
        const double max_us = s.max_exposure_s * 1e6;
        const double t = next_fly_exposure_us(
            session, *exposure_us, c.target_fraction / c.linear_max_fraction, max_us);
        auto e = session.set_moving_exposure(t);
        out = e ? compare_sweep_frames(axis, session, s, targets_deg, t, timeout)
                : Expected<SweepFrames>(tl::unexpected(e.error()));
        auto next = out ? exposure_after(session, *out, t, max_us) : Expected<double>(t);
        if (out && !next) {
            out = tl::unexpected(next.error());
        }
        *exposure_us = next ? *next : t;
    }
    auto back = axis.set_motion(normal);
    if (!out) {
        return out;
    }
    if (!back) {
        return tl::unexpected(back.error());
    }
    return out;
}

}  // namespace gonio::acquisition
