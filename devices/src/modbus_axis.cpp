#include "gonio/devices/modbus_axis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <thread>

namespace gonio::devices {
namespace {

std::string hex(long long v, int digits) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "0x%0*llX", digits, static_cast<unsigned long long>(v));
    return buf;
}

std::string fmt_deg(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v);
    return buf;
}

/// Does the documented register `reg` lie inside `block`?
bool inside(const CommandBlock& block, const RegisterField& reg) {
    return block.present() && reg.address >= block.address &&
           reg.address + reg.count() <= block.address + block.register_count();
}

/// What a wait remembers between polls: whether motion was seen, when the position last changed
/// (for the stall check) and the previous reading (for the observed speed).
struct PollHistory {
    using Clock = std::chrono::steady_clock;
    std::int64_t last_steps = 0;
    bool have_last = false;
    bool seen_moving = false;
    Clock::time_point last_change = Clock::now();
    double prev_deg = 0;
    Clock::time_point prev_t = Clock::now();
    bool have_prev = false;

    /// After a link recovery the drive's state is re-read: what was seen before no longer counts.
    void forget() {
        seen_moving = false;
        have_last = false;
        have_prev = false;
    }
    /// Records the position; true when it has not changed for longer than `stall` while the
    /// drive reports motion.
    bool stalled(std::int64_t steps, Clock::time_point now, bool moving, Clock::duration stall) {
        if (!have_last || steps != last_steps) {
            last_steps = steps;
            last_change = now;
            have_last = true;
            return false;
        }
        return moving && now - last_change > stall;
    }
    /// The stage's speed between the previous reading and this one in deg/s; -1 when unknown.
    double observed_speed(double at_deg, Clock::time_point now) {
        double observed = -1;
        if (have_prev) {
            const double dt = std::chrono::duration<double>(now - prev_t).count();
            if (dt > 0) {
                observed = std::fabs(at_deg - prev_deg) / dt;
            }
        }
        prev_deg = at_deg;
        prev_t = now;
        have_prev = true;
        return observed;
    }
};

std::string wait_alarm_message(const Expected<int>& code,
                               bool homing,
                               double commanded_deg,
                               double at_deg) {
    return std::string("drive alarm code ") +
           (code ? std::to_string(*code) + " (" + hex(*code, 2) + ")"
                 : std::string("unreadable: ") + code.error().message) +
           (homing ? " during homing" : " during move to " + fmt_deg(commanded_deg) + " deg") +
           ", at " + fmt_deg(at_deg) + " deg";
}

}  // namespace

ModbusAxis::ModbusAxis(std::shared_ptr<ModbusBus> bus,
                       int unit,
                       AxisProfile profile,
                       std::string name,
                       SoftLimits limits,
                       Motion motion,
                       AxisOptions options)
    : bus_(std::move(bus)),
      unit_(unit),
      profile_(std::move(profile)),
      name_(std::move(name)),
      limits_(limits),
      motion_(motion),
      options_(options) {
    policy_.response_timeout =
        std::chrono::milliseconds(options_.response_timeout_ms > 0 ? options_.response_timeout_ms
                                                                   : profile_.timeouts.response_ms);
    policy_.retries = options_.retries >= 0 ? options_.retries : profile_.timeouts.retries;
    policy_.backoff = std::chrono::milliseconds(profile_.timeouts.backoff_ms);
    poll_policy_ = policy_;
    poll_policy_.poll = true;
}

std::chrono::microseconds ModbusAxis::poll_wait(double remaining_deg,
                                                double observed_deg_per_s) const {
    const double d = std::fabs(remaining_deg);
    const double v = motion_.speed_deg_per_s;
    const double a = motion_.accel_deg_per_s2;
    double t_go = d > v * v / (2 * a) ? d / v + v / (2 * a) : std::sqrt(2 * d / a);
    if (observed_deg_per_s > 0) {
        t_go = std::min(t_go, d / observed_deg_per_s);
    }
    const double lo = std::max(0, profile_.timeouts.poll_ms) * 1e-3;
    const double hi = std::max(lo, options_.max_poll_interval_ms * 1e-3);
    const double wait = std::clamp(0.5 * t_go, lo, hi);
    return std::chrono::microseconds(static_cast<long long>(wait * 1e6));
}

Error ModbusAxis::axis_error(const std::string& msg) const {
    return Error{"axis \"" + name_ + "\" (unit " + std::to_string(unit_) + "): " + msg};
}

std::string ModbusAxis::reg_label(int documented) const {
    return "axis \"" + name_ + "\" reg " + hex(documented, 4);
}

Expected<void> ModbusAxis::set_motion(const Motion& m) {
    if (!(m.speed_deg_per_s > 0) || m.speed_deg_per_s > profile_.max_speed_deg_per_s) {
        return tl::unexpected(axis_error(
            "speed " + fmt_deg(m.speed_deg_per_s) + " deg/s not in (0, " +
            fmt_deg(profile_.max_speed_deg_per_s) + "] (profile \"" + profile_.name + "\")"));
    }
    if (!(m.accel_deg_per_s2 > 0) || !std::isfinite(m.accel_deg_per_s2)) {
        return tl::unexpected(axis_error("acceleration " + fmt_deg(m.accel_deg_per_s2) +
                                         " deg/s^2 must be finite and > 0"));
    }
    if (!(m.settle_ms >= 0) || !std::isfinite(m.settle_ms)) {
        return tl::unexpected(axis_error("settle time must be finite and >= 0 ms"));
    }
    // The drive takes speed and acceleration with each move: check that they encode now.
    BlockInputs in;
    in.speed_steps_per_s = m.speed_deg_per_s * profile_.steps_per_degree;
    in.accel_steps_per_s2 = m.accel_deg_per_s2 * profile_.steps_per_degree;
    in.decel_steps_per_s2 = in.accel_steps_per_s2;
    if (auto e = encode_block(profile_, profile_.move.block, in); !e) {
        return tl::unexpected(axis_error(e.error().message));
    }
    motion_ = m;
    return {};
}

Expected<ModbusAxis::Raw> ModbusAxis::read_raw(const RequestPolicy& policy) {
    Raw raw;
    const RegisterField& sr = profile_.status.reg;
    auto sw = bus_->read_registers(
        unit_, *wire_address(profile_, sr.address), sr.count(), policy, reg_label(sr.address));
    if (!sw) {
        return tl::unexpected(sw.error());
    }
    raw.status_word =
        static_cast<std::uint32_t>(decode_value(sw->data(), sr.width, false, profile_.word_order));
    const RegisterField& pr = profile_.position;
    // One request for both words: a 32-bit position is never torn.
    auto pw = bus_->read_registers(
        unit_, *wire_address(profile_, pr.address), pr.count(), policy, reg_label(pr.address));
    if (!pw) {
        return tl::unexpected(pw.error());
    }
    raw.position_steps = decode_value(pw->data(), pr.width, pr.is_signed, profile_.word_order);
    return raw;
}

Expected<int> ModbusAxis::read_alarm_code() {
    const RegisterField& ar = profile_.alarm_code;
    auto w = bus_->read_registers(
        unit_, *wire_address(profile_, ar.address), ar.count(), policy_, reg_label(ar.address));
    if (!w) {
        return tl::unexpected(w.error());
    }
    return static_cast<int>(decode_value(w->data(), ar.width, false, profile_.word_order));
}

Expected<void> ModbusAxis::run_action(const Action& a, const BlockInputs& in, const char* what) {
    if (!a.supported()) {
        return tl::unexpected(axis_error(std::string(what) + " is not supported by profile \"" +
                                         profile_.name + "\""));
    }
    if (a.block.present()) {
        auto words = encode_block(profile_, a.block, in);
        if (!words) {
            return tl::unexpected(axis_error(words.error().message));
        }
        if (auto r = bus_->write_registers(unit_,
                                           *wire_address(profile_, a.block.address),
                                           *words,
                                           policy_,
                                           reg_label(a.block.address));
            !r) {
            return r;
        }
    }
    const Trigger& t = a.trigger;
    if (t.kind == TriggerKind::kNone || inside(a.block, t.reg)) {
        return {};  // The block write was the trigger.
    }
    const int wire = *wire_address(profile_, t.reg.address);
    auto write = [&](std::uint32_t v) -> Expected<void> {
        auto words = encode_value(v, t.reg.width, profile_.word_order);
        if (words.size() == 1) {
            return bus_->write_register(unit_, wire, words[0], policy_, reg_label(t.reg.address));
        }
        return bus_->write_registers(unit_, wire, words, policy_, reg_label(t.reg.address));
    };
    if (t.kind == TriggerKind::kWriteValue) {
        return write(t.value);
    }
    // Edge-triggered input bit: set, then clear so that the next command makes a new edge.
    if (auto r = write(1U << t.bit); !r) {
        return r;
    }
    return write(0);
}

Expected<void> ModbusAxis::send_move(double position_deg) {
    BlockInputs in;
    in.target_steps = degrees_to_steps(profile_, position_deg);
    in.speed_steps_per_s = motion_.speed_deg_per_s * profile_.steps_per_degree;
    in.accel_steps_per_s2 = motion_.accel_deg_per_s2 * profile_.steps_per_degree;
    in.decel_steps_per_s2 = in.accel_steps_per_s2;
    commanded_deg_ = position_deg;
    return run_action(profile_.move, in, "move");
}

Expected<void> ModbusAxis::start_move(double position_deg) {
    // Every check that needs no I/O comes first: nothing is sent for a refused move.
    if (!std::isfinite(position_deg)) {
        return tl::unexpected(axis_error("target position is not finite"));
    }
    if (position_deg < limits_.min_deg || position_deg > limits_.max_deg) {
        return tl::unexpected(axis_error("target " + fmt_deg(position_deg) +
                                         " deg outside soft limits [" + fmt_deg(limits_.min_deg) +
                                         ", " + fmt_deg(limits_.max_deg) + "]; nothing sent"));
    }
    double approach_deg = position_deg;
    if (options_.approach == BacklashApproach::kFromBelow) {
        approach_deg = position_deg - options_.approach_overshoot_deg;
    } else if (options_.approach == BacklashApproach::kFromAbove) {
        approach_deg = position_deg + options_.approach_overshoot_deg;
    }
    if (approach_deg < limits_.min_deg || approach_deg > limits_.max_deg) {
        return tl::unexpected(axis_error("backlash approach point " + fmt_deg(approach_deg) +
                                         " deg for target " + fmt_deg(position_deg) +
                                         " deg outside soft limits [" + fmt_deg(limits_.min_deg) +
                                         ", " + fmt_deg(limits_.max_deg) + "]; nothing sent"));
    }
    auto raw = read_raw();
    if (!raw) {
        return tl::unexpected(raw.error());
    }
    if (bit(raw->status_word, profile_.status.alarm)) {
        auto code = read_alarm_code();
        return tl::unexpected(axis_error(
            "drive in alarm (code " +
            (code ? std::to_string(*code) + " = " + hex(*code, 2) : std::string("unreadable")) +
            "); move refused, reset the alarm first"));
    }
    homing_ = false;
    final_target_deg_ = position_deg;
    const double here = steps_to_degrees(profile_, static_cast<double>(raw->position_steps));
    const double step = 1.0 / profile_.steps_per_degree;
    // A final approach is needed when the last leg would arrive from the wrong side.
    const bool wrong_side =
        (options_.approach == BacklashApproach::kFromBelow && here > position_deg - 0.5 * step) ||
        (options_.approach == BacklashApproach::kFromAbove && here < position_deg + 0.5 * step);
    if (wrong_side) {
        approach_pending_ = true;
        return send_move(approach_deg);
    }
    approach_pending_ = false;
    return send_move(position_deg);
}

Expected<void> ModbusAxis::wait_flag(bool homing, std::chrono::steady_clock::time_point deadline) {
    const StatusBits& sb = profile_.status;
    PollHistory history;
    const auto stall = std::chrono::milliseconds(profile_.timeouts.stall_ms);
    std::uint64_t generation = bus_->link_generation();
    for (;;) {
        auto raw = read_raw(poll_policy_);
        if (!raw) {
            return tl::unexpected(raw.error());
        }
        ++recovery_.polls;
        const auto now = std::chrono::steady_clock::now();
        const std::uint32_t w = raw->status_word;
        const double at_deg = steps_to_degrees(profile_, static_cast<double>(raw->position_steps));
        if (bit(w, sb.alarm)) {
            auto code = read_alarm_code();
            approach_pending_ = false;
            return tl::unexpected(
                axis_error(wait_alarm_message(code, homing, commanded_deg_, at_deg)));
        }
        const bool moving = sb.moving >= 0 ? bit(w, sb.moving) : !bit(w, sb.in_position);
        const bool in_pos = sb.in_position >= 0 ? bit(w, sb.in_position) : !moving;
        const bool at_target =
            std::fabs(at_deg - commanded_deg_) <= 1.5 / profile_.steps_per_degree;
        if (const std::uint64_t g = bus_->link_generation(); g != generation) {
            // The link was lost and re-established during the wait: the drive's state was just
            // re-read (position, status; the alarm bit was checked above). A drive that stands
            // still away from the target lost the move (power blip): send it again.
            generation = g;
            ++recovery_.link_recoveries;
            history.forget();
            if (!moving && !at_target) {
                if (auto r =
                        homing ? run_action(profile_.home, {}, "home") : send_move(commanded_deg_);
                    !r) {
                    return r;
                }
                ++recovery_.reissued_moves;
                continue;
            }
        }
        history.seen_moving = history.seen_moving || moving;
        // A drive may still show the previous move's in-position flag for a moment after a new
        // command: accept "done" only once motion was seen or the stage is at the target.
        const bool done = homing ? (!moving && bit(w, sb.homed))
                                 : (!moving && in_pos && (history.seen_moving || at_target));
        if (done) {
            return {};
        }
        if (history.stalled(raw->position_steps, now, moving, stall)) {
            (void)run_action(profile_.stop, {}, "stop");
            approach_pending_ = false;
            return tl::unexpected(axis_error(
                "stalled at " + fmt_deg(at_deg) + " deg: position unchanged for " +
                std::to_string(profile_.timeouts.stall_ms) +
                " ms while the drive reports motion (status " + hex(w, 4) + "); stop sent"));
        }
        if (now > deadline) {
            (void)run_action(profile_.stop, {}, "stop");
            approach_pending_ = false;
            return tl::unexpected(axis_error(
                std::string(homing ? "homing" : "move to " + fmt_deg(commanded_deg_) + " deg") +
                " not finished before the deadline (at " + fmt_deg(at_deg) + " deg, status " +
                hex(w, 4) + "); stop sent"));
        }
        // Back off while far from the target; homing has no known distance: poll at poll_ms.
        // The first wait is short: two readings give the stage's observed speed (a simulator
        // running faster than real time, a drive slower than its profile).
        const double observed = history.observed_speed(at_deg, now);
        const double remaining = homing || observed < 0 ? 0 : at_deg - commanded_deg_;
        std::this_thread::sleep_for(std::min<std::chrono::microseconds>(
            poll_wait(remaining, observed),
            std::chrono::duration_cast<std::chrono::microseconds>(deadline - now) +
                std::chrono::microseconds(1000)));
    }
}

Expected<void> ModbusAxis::wait_done(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    if (auto r = wait_flag(homing_, deadline); !r) {
        homing_ = false;
        return r;
    }
    if (homing_) {
        homing_ = false;
        return {};
    }
    if (approach_pending_) {
        approach_pending_ = false;
        if (auto r = send_move(final_target_deg_); !r) {
            return r;
        }
        if (auto r = wait_flag(false, deadline); !r) {
            return r;
        }
    }
    // Read back: the drive's in-position flag must agree with its position.
    auto raw = read_raw();
    if (!raw) {
        return tl::unexpected(raw.error());
    }
    const double at = steps_to_degrees(profile_, static_cast<double>(raw->position_steps));
    const double tol = options_.position_tolerance_deg >= 0 ? options_.position_tolerance_deg
                                                            : 1.5 / profile_.steps_per_degree;
    if (std::fabs(at - commanded_deg_) > tol + 0.5 / profile_.steps_per_degree) {
        return tl::unexpected(
            axis_error("in position at " + fmt_deg(at) + " deg but " + fmt_deg(commanded_deg_) +
                       " deg was commanded (tolerance " + fmt_deg(tol) + " deg)"));
    }
    return {};
}

Expected<void> ModbusAxis::home(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    if (!profile_.home.supported()) {
        return tl::unexpected(
            axis_error("homing is not supported by profile \"" + profile_.name + "\""));
    }
    auto raw = read_raw();
    if (!raw) {
        return tl::unexpected(raw.error());
    }
    if (bit(raw->status_word, profile_.status.alarm)) {
        auto code = read_alarm_code();
        return tl::unexpected(axis_error(
            "drive in alarm (code " + (code ? std::to_string(*code) : std::string("unreadable")) +
            "); homing refused, reset the alarm first"));
    }
    approach_pending_ = false;
    if (auto r = run_action(profile_.home, {}, "home"); !r) {
        return r;
    }
    homing_ = true;
    auto r = wait_flag(true, deadline);
    homing_ = false;
    if (r) {
        commanded_deg_ = 0;
    }
    return r;
}

Expected<AxisStatus> ModbusAxis::status() {
    auto raw = read_raw();
    if (!raw) {
        return tl::unexpected(raw.error());
    }
    const StatusBits& sb = profile_.status;
    AxisStatus st;
    st.position_deg = steps_to_degrees(profile_, static_cast<double>(raw->position_steps));
    st.homed = bit(raw->status_word, sb.homed);
    const bool moving =
        sb.moving >= 0 ? bit(raw->status_word, sb.moving) : !bit(raw->status_word, sb.in_position);
    if (bit(raw->status_word, sb.alarm)) {
        st.state = AxisState::kAlarm;
        auto code = read_alarm_code();
        if (!code) {
            return tl::unexpected(code.error());
        }
        st.alarm_code = *code;
    } else if (moving) {
        st.state =
            (homing_ || bit(raw->status_word, sb.homing)) ? AxisState::kHoming : AxisState::kMoving;
    } else {
        st.state = AxisState::kIdle;
    }
    return st;
}

Expected<double> ModbusAxis::position_deg() {
    const RegisterField& pr = profile_.position;
    auto pw = bus_->read_registers(
        unit_, *wire_address(profile_, pr.address), pr.count(), policy_, reg_label(pr.address));
    if (!pw) {
        return tl::unexpected(pw.error());
    }
    return steps_to_degrees(
        profile_,
        static_cast<double>(decode_value(pw->data(), pr.width, pr.is_signed, profile_.word_order)));
}

Expected<std::array<double, 2>> ModbusAxis::exposure_latch_deg() {
    if (!profile_.probe_start.present()) {
        return Axis::exposure_latch_deg();
    }
    std::array<double, 2> out{};
    int k = 0;
    for (const RegisterField* f : {&profile_.probe_start, &profile_.probe_end}) {
        auto w = bus_->read_registers(
            unit_, *wire_address(profile_, f->address), f->count(), policy_, reg_label(f->address));
        if (!w) {
            return tl::unexpected(w.error());
        }
        out[k++] = steps_to_degrees(profile_,
                                    static_cast<double>(decode_value(
                                        w->data(), f->width, f->is_signed, profile_.word_order)));
    }
    return out;
}

Expected<void> ModbusAxis::arm_position_compare(const std::vector<double>& positions_deg) {
    const PositionCompare& pc = profile_.compare;
    if (!pc.present()) {
        return Axis::arm_position_compare(positions_deg);
    }
    if (positions_deg.empty() || positions_deg.size() > static_cast<std::size_t>(pc.entries)) {
        return tl::unexpected(
            axis_error("position compare: " + std::to_string(positions_deg.size()) +
                       " positions, the drive's table holds 1 to " + std::to_string(pc.entries)));
    }
    if (auto r = disarm_position_compare(); !r) {
        return r;
    }
    // The table in writes of at most 120 registers (function 16 allows 123).
    const std::size_t per_write = static_cast<std::size_t>(120 / pc.table.count());
    for (std::size_t k0 = 0; k0 < positions_deg.size(); k0 += per_write) {
        std::vector<std::uint16_t> words;
        for (std::size_t k = k0; k < std::min(positions_deg.size(), k0 + per_write); ++k) {
            if (!std::isfinite(positions_deg[k])) {
                return tl::unexpected(axis_error("position compare: a position is not finite"));
            }
            const auto w = encode_value(
                degrees_to_steps(profile_, positions_deg[k]), pc.table.width, profile_.word_order);
            words.insert(words.end(), w.begin(), w.end());
        }
        const int addr = pc.table.address + static_cast<int>(k0) * pc.table.count();
        if (auto r = bus_->write_registers(
                unit_, *wire_address(profile_, addr), words, policy_, reg_label(addr));
            !r) {
            return r;
        }
    }
    for (const auto& [f, v] : {std::pair<const RegisterField*, std::int64_t>{
                                   &pc.count, static_cast<std::int64_t>(positions_deg.size())},
                               {&pc.control, 1}}) {
        if (auto r = bus_->write_registers(unit_,
                                           *wire_address(profile_, f->address),
                                           encode_value(v, f->width, profile_.word_order),
                                           policy_,
                                           reg_label(f->address));
            !r) {
            return r;
        }
    }
    return {};
}

Expected<void> ModbusAxis::disarm_position_compare() {
    const PositionCompare& pc = profile_.compare;
    if (!pc.present()) {
        return Axis::disarm_position_compare();
    }
    return bus_->write_registers(unit_,
                                 *wire_address(profile_, pc.control.address),
                                 encode_value(0, pc.control.width, profile_.word_order),
                                 policy_,
                                 reg_label(pc.control.address));
}

Expected<std::size_t> ModbusAxis::compare_pulses() {
    const PositionCompare& pc = profile_.compare;
    if (!pc.present()) {
        return Axis::compare_pulses();
    }
    auto w = bus_->read_registers(unit_,
                                  *wire_address(profile_, pc.fired.address),
                                  pc.fired.count(),
                                  policy_,
                                  reg_label(pc.fired.address));
    if (!w) {
        return tl::unexpected(w.error());
    }
    return static_cast<std::size_t>(
        decode_value(w->data(), pc.fired.width, false, profile_.word_order));
}

Expected<std::array<double, 2>> ModbusAxis::compare_latch_deg(std::size_t index) {
    const PositionCompare& pc = profile_.compare;
    if (!pc.present()) {
        return Axis::compare_latch_deg(index);
    }
    if (index < 1 || index > static_cast<std::size_t>(pc.entries)) {
        return tl::unexpected(axis_error("position compare: no latch of pulse " +
                                         std::to_string(index) + " (1 to " +
                                         std::to_string(pc.entries) + ")"));
    }
    const int n = pc.latches.count();
    const int addr = pc.latches.address + 2 * (static_cast<int>(index) - 1) * n;
    auto w =
        bus_->read_registers(unit_, *wire_address(profile_, addr), 2 * n, policy_, reg_label(addr));
    if (!w) {
        return tl::unexpected(w.error());
    }
    std::array<double, 2> out{};
    for (int k = 0; k < 2; ++k) {
        out[static_cast<std::size_t>(k)] = steps_to_degrees(
            profile_,
            static_cast<double>(decode_value(
                w->data() + k * n, pc.latches.width, pc.latches.is_signed, profile_.word_order)));
    }
    return out;
}

Expected<void> ModbusAxis::stop() {
    approach_pending_ = false;
    homing_ = false;
    return run_action(profile_.stop, {}, "stop");
}

Expected<void> ModbusAxis::reset_alarm() {
    return run_action(profile_.reset_alarm, {}, "alarm reset");
}

Expected<std::unique_ptr<Axis>> open_axis(const std::string& name,
                                          const std::string& address,
                                          int unit,
                                          const std::string& profile_name_or_path,
                                          const SoftLimits& limits,
                                          const Motion& motion,
                                          const AxisOptions& options) {
    const std::string where = "axis \"" + name + "\"";
    if (unit < 1 || unit > 247) {
        return make_error(where + ": unit " + std::to_string(unit) + " not in [1, 247]");
    }
    if (!std::isfinite(limits.min_deg) || !std::isfinite(limits.max_deg) ||
        !(limits.min_deg < limits.max_deg)) {
        return make_error(where + ": soft limits [" + fmt_deg(limits.min_deg) + ", " +
                          fmt_deg(limits.max_deg) + "] must be finite with min < max");
    }
    if (options.approach != BacklashApproach::kNone &&
        !(options.approach_overshoot_deg > 0 && std::isfinite(options.approach_overshoot_deg))) {
        return make_error(where + ": backlash approach overshoot must be finite and > 0 deg");
    }
    auto profile = load_axis_profile(profile_name_or_path);
    if (!profile) {
        return make_error(where + ": " + profile.error().message);
    }
    auto bus = ModbusBus::shared(address);
    if (!bus) {
        return make_error(where + ": " + bus.error().message);
    }
    auto axis = std::make_unique<ModbusAxis>(
        *bus, unit, std::move(*profile), name, limits, Motion{}, options);
    if (auto r = axis->set_motion(motion); !r) {
        return tl::unexpected(r.error());
    }
    return std::unique_ptr<Axis>(std::move(axis));
}

}  // namespace gonio::devices
