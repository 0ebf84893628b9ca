#include "gonio/sim/motor_sim.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gonio::sim {
namespace {

double sign(double x) {
    return x < 0 ? -1.0 : 1.0;
}

}  // namespace

std::vector<MotionPhase> plan_trapezoid(
    double t0, double p0, double p1, double v_max, double accel, double decel) {
    std::vector<MotionPhase> phases;
    const double distance = std::fabs(p1 - p0);
    // Degenerate: already there (or invalid rates, which the caller refuses before).
    if (distance == 0 || !(v_max > 0) || !(accel > 0) || !(decel > 0)) {
        return phases;
    }
    const double s = sign(p1 - p0);
    // Peak speed of a triangular profile covering the whole distance.
    const double v_tri = std::sqrt(2 * distance * accel * decel / (accel + decel));
    const double v = std::min(v_max, v_tri);
    const double t_acc = v / accel;
    const double t_dec = v / decel;
    const double d_acc = v * v / (2 * accel);
    const double d_dec = v * v / (2 * decel);
    // Cruise distance; for a triangular profile rounding leaves a few ulps either side of 0.
    double d_cruise = distance - d_acc - d_dec;
    if (d_cruise < 1e-9 * distance) {
        d_cruise = 0;
    }
    const double t_cruise = d_cruise / v;
    double t = t0;
    phases.push_back({t, p0, 0, s * accel, t_acc});
    t += t_acc;
    if (t_cruise > 0) {
        phases.push_back({t, p0 + s * d_acc, s * v, 0, t_cruise});
        t += t_cruise;
    }
    phases.push_back({t, p0 + s * (d_acc + d_cruise), s * v, -s * decel, t_dec});
    return phases;
}

MotorSim::MotorSim(const MotorSimConfig& cfg, double steps_per_degree)
    : cfg_(cfg), steps_per_degree_(steps_per_degree), rng_(cfg.seed) {
    pos_ = cfg.initial_deg * steps_per_degree_;
    load_ = pos_;
    // Unreferenced counters start at 0 wherever the stage is; a referenced one reads physical.
    counter_offset_ = cfg.start_homed ? 0 : -pos_;
    homed_ = cfg.start_homed;
    hist_motor0_ = hist_load0_ = hist_end_ = pos_;
}

double MotorSim::position_at(double t, double* velocity) const {
    for (const MotionPhase& ph : phases_) {
        if (t <= ph.t0 + ph.duration) {
            const double dt = std::max(0.0, t - ph.t0);
            if (velocity != nullptr) {
                *velocity = ph.v0 + ph.a * dt;
            }
            return ph.p0 + ph.v0 * dt + 0.5 * ph.a * dt * dt;
        }
    }
    if (velocity != nullptr) {
        *velocity = 0;
    }
    return move_end_;
}

void MotorSim::apply_backlash(double motor) {
    // Play of width b: the load stays where it is while the motor is within [load, load + b].
    const double b = std::fabs(cfg_.backlash_deg * steps_per_degree_);
    if (load_ < motor - b) {
        load_ = motor - b;
    } else if (load_ > motor) {
        load_ = motor;
    }
}

std::vector<double> MotorSim::load_steps_at(const std::vector<double>& t,
                                            std::vector<double>* motor_out) const {
    std::vector<double> out;
    out.reserve(t.size());
    const double b = std::fabs(cfg_.backlash_deg * steps_per_degree_);
    double load = load_;
    for (double ti : t) {
        const bool ended = phases_.empty() || ti >= phases_.back().t0 + phases_.back().duration;
        const double motor = phases_.empty() ? pos_ : ended ? move_end_ : position_at(ti, nullptr);
        // The play of apply_backlash(), carried from node to node (the nodes come in time order).
        load = std::clamp(load, motor - b, motor);
        out.push_back(load);
        if (motor_out != nullptr) {
            motor_out->push_back(motor);
        }
    }
    return out;
}

void MotorSim::update(double t) {
    if (t <= now_) {
        return;
    }
    if (phases_.empty()) {
        now_ = t;
        return;
    }
    // Motion is monotonic within a phase: the load only needs the positions at phase ends.
    for (const MotionPhase& ph : phases_) {
        const double te = ph.t0 + ph.duration;
        if (te > now_ && te < t) {
            apply_backlash(position_at(te, nullptr));
        }
    }
    const double end_t = phases_.back().t0 + phases_.back().duration;
    double v = 0;
    double p = position_at(t, &v);
    bool finished = t >= end_t;
    if (finished) {
        p = move_end_;
        v = 0;
    }
    // Armed fault: stop at the given fraction of the move.
    if (armed_ != Armed::kNone && move_end_ != move_start_) {
        const double progress = (p - move_start_) / (move_end_ - move_start_);
        if (progress >= armed_fraction_) {
            p = move_start_ + armed_fraction_ * (move_end_ - move_start_);
            phases_.clear();
            vel_ = 0;
            pos_ = p;
            apply_backlash(p);
            if (armed_ == Armed::kAlarm) {
                alarm_ = armed_code_;
                homing_ = false;
            } else {
                stalled_ = true;
            }
            armed_ = Armed::kNone;
            now_ = t;
            cut_history(t);
            return;
        }
    }
    // Limit switches (physical positions): the stage stops on the switch and the drive alarms.
    const double lo =
        std::min(cfg_.limit_min_deg, cfg_.limit_max_deg) * std::fabs(steps_per_degree_);
    const double hi =
        std::max(cfg_.limit_min_deg, cfg_.limit_max_deg) * std::fabs(steps_per_degree_);
    const double lim_lo = steps_per_degree_ >= 0 ? lo : -hi;
    const double lim_hi = steps_per_degree_ >= 0 ? hi : -lo;
    if (p < lim_lo || p > lim_hi) {
        p = std::clamp(p, lim_lo, lim_hi);
        phases_.clear();
        vel_ = 0;
        pos_ = p;
        apply_backlash(p);
        alarm_ = overtravel_code_;
        homing_ = false;
        now_ = t;
        cut_history(t);
        return;
    }
    pos_ = p;
    vel_ = v;
    apply_backlash(p);
    if (finished) {
        phases_.clear();
        if (homing_) {
            // On the home switch: reference the counter to the physical zero.
            counter_offset_ = 0;
            homed_ = true;
            homing_ = false;
        }
    }
    now_ = t;
}

bool MotorSim::start_move(
    double t, std::int64_t target_counter_steps, double v, double a, double d) {
    update(t);
    if (alarm_ != 0 || !(v > 0) || !(a > 0) || !(d > 0) || !std::isfinite(v) || !std::isfinite(a) ||
        !std::isfinite(d)) {
        return false;
    }
    stalled_ = false;
    homing_ = false;
    const double target = static_cast<double>(target_counter_steps) - counter_offset_;
    double t_start = t;
    double p_start = pos_;
    std::vector<MotionPhase> phases;
    if (!phases_.empty() && vel_ != 0) {
        // A new target while moving: decelerate to rest first, then start the new profile.
        const double dur = std::fabs(vel_) / d;
        phases.push_back({t, pos_, vel_, -sign(vel_) * d, dur});
        p_start = pos_ + vel_ * dur - 0.5 * sign(vel_) * d * dur * dur;
        t_start = t + dur;
    }
    auto rest = plan_trapezoid(t_start, p_start, target, v, a, d);
    phases.insert(phases.end(), rest.begin(), rest.end());
    phases_ = std::move(phases);
    move_start_ = pos_;
    move_end_ = target;
    if (phases_.empty()) {
        pos_ = target;
        apply_backlash(pos_);
    }
    begin_history(t);
    return true;
}

bool MotorSim::start_home(double t, double v, double a) {
    update(t);
    if (alarm_ != 0 || !(v > 0) || !(a > 0)) {
        return false;
    }
    stalled_ = false;
    phases_ = plan_trapezoid(t, pos_, 0.0, v, a, a);
    move_start_ = pos_;
    move_end_ = 0;
    homing_ = true;
    homed_ = false;
    begin_history(t);
    if (phases_.empty()) {
        // Already on the switch.
        pos_ = 0;
        apply_backlash(pos_);
        counter_offset_ = 0;
        homed_ = true;
        homing_ = false;
    }
    return true;
}

void MotorSim::stop(double t, double d) {
    update(t);
    homing_ = false;
    if (stalled_) {
        stalled_ = false;
        phases_.clear();
        vel_ = 0;
        return;
    }
    if (phases_.empty() || vel_ == 0 || !(d > 0)) {
        // At rest already, or an immediate stop.
        phases_.clear();
        vel_ = 0;
        move_end_ = pos_;
        begin_history(t);
        return;
    }
    const double dur = std::fabs(vel_) / d;
    phases_ = {{t, pos_, vel_, -sign(vel_) * d, dur}};
    move_start_ = pos_;
    move_end_ = pos_ + vel_ * dur - 0.5 * sign(vel_) * d * dur * dur;
    begin_history(t);
}

void MotorSim::reset_alarm() {
    alarm_ = 0;
    stalled_ = false;
}

void MotorSim::arm_alarm(double fraction, int code) {
    armed_ = Armed::kAlarm;
    armed_fraction_ = std::clamp(fraction, 0.0, 1.0);
    armed_code_ = code;
}

void MotorSim::arm_stall(double fraction, int /*deviation_alarm_code*/) {
    armed_ = Armed::kStall;
    armed_fraction_ = std::clamp(fraction, 0.0, 1.0);
}

void MotorSim::raise_alarm(int code) {
    cut_history(now_);
    phases_.clear();
    vel_ = 0;
    stalled_ = false;
    homing_ = false;
    alarm_ = code;
}

bool MotorSim::moving() const {
    return !phases_.empty() || stalled_;
}

std::int64_t MotorSim::counter_steps() const {
    return static_cast<std::int64_t>(std::llround(pos_ + counter_offset_));
}

std::int64_t MotorSim::read_counter_steps() {
    double noise = 0;
    if (cfg_.encoder_noise_steps > 0) {
        noise = cfg_.encoder_noise_steps * noise_(rng_);
    }
    return static_cast<std::int64_t>(std::llround(pos_ + counter_offset_ + noise));
}

void MotorSim::begin_history(double t) {
    hist_phases_ = phases_;
    hist_t0_ = t;
    hist_motor0_ = pos_;
    hist_load0_ = load_;
    hist_end_ = phases_.empty() ? pos_ : move_end_;
    hist_cut_ = false;
    schedule_compare(t);
}

void MotorSim::cut_history(double t) {
    hist_end_ = pos_;
    hist_cut_t_ = t;
    hist_cut_ = true;
    schedule_compare(t);
}

double MotorSim::history_motor_at(double t) const {
    if (t <= hist_t0_ || hist_phases_.empty()) {
        return t <= hist_t0_ ? hist_motor0_ : hist_end_;
    }
    if (hist_cut_ && t >= hist_cut_t_) {
        return hist_end_;
    }
    for (const MotionPhase& ph : hist_phases_) {
        if (t <= ph.t0 + ph.duration) {
            const double dt = std::max(0.0, t - ph.t0);
            return ph.p0 + ph.v0 * dt + 0.5 * ph.a * dt * dt;
        }
    }
    return hist_end_;
}

std::vector<double> MotorSim::history_steps_at(const std::vector<double>& t,
                                               std::vector<double>* motor_out) const {
    // The play of apply_backlash(), carried from the move's start through the ends of its phases
    // (the motor is monotonic within a phase) and the nodes, in time order.
    const double b = std::fabs(cfg_.backlash_deg * steps_per_degree_);
    double load = hist_load0_;
    std::size_t next_end = 0;
    std::vector<double> out;
    out.reserve(t.size());
    for (double ti : t) {
        for (; next_end < hist_phases_.size(); ++next_end) {
            const double te = hist_phases_[next_end].t0 + hist_phases_[next_end].duration;
            if (te >= ti) {
                break;
            }
            const double m = history_motor_at(te);
            load = std::clamp(load, m - b, m);
        }
        const double m = history_motor_at(ti);
        load = std::clamp(load, m - b, m);
        out.push_back(ti <= hist_t0_ ? hist_load0_ : load);
        if (motor_out != nullptr) {
            motor_out->push_back(m);
        }
    }
    return out;
}

double MotorSim::history_crossing(double t0, double p) const {
    const double inf = std::numeric_limits<double>::infinity();
    const double t_cut = hist_cut_ ? hist_cut_t_ : inf;
    for (const MotionPhase& ph : hist_phases_) {
        double a = std::max(t0, ph.t0);
        double b = std::min(ph.t0 + ph.duration, t_cut);
        if (!(a <= b)) {
            continue;
        }
        const double pa = history_motor_at(a) - p;
        const double pb = history_motor_at(b) - p;
        if (pa == 0) {
            return a;
        }
        if ((pa < 0) == (pb < 0) && pb != 0) {
            continue;
        }
        // Monotonic within the phase: bisection to the instant it passes p.
        for (int k = 0; k < 100 && b - a > 1e-12; ++k) {
            const double mid = 0.5 * (a + b);
            if ((history_motor_at(mid) - p < 0) == (pa < 0)) {
                a = mid;
            } else {
                b = mid;
            }
        }
        return b;
    }
    return inf;
}

void MotorSim::schedule_compare(double t) {
    // Pulses sent before t stay; the rest follow the history from t (or from the last pulse).
    std::size_t fired = pulses_fired(t);
    compare_times_.resize(fired);
    double from = std::max(t, compare_armed_t_);
    if (!compare_times_.empty()) {
        from = std::max(from, compare_times_.back());
    }
    for (std::size_t k = fired; k < compare_steps_.size(); ++k) {
        const double tk = history_crossing(from, compare_steps_[k]);
        if (!std::isfinite(tk)) {
            break;
        }
        compare_times_.push_back(tk);
        from = tk;
    }
}

void MotorSim::arm_compare(double t, std::vector<double> counter_steps) {
    update(t);
    compare_steps_.clear();
    for (double c : counter_steps) {
        compare_steps_.push_back(c - counter_offset_);
    }
    compare_times_.clear();
    compare_armed_t_ = t;
    schedule_compare(t);
}

std::size_t MotorSim::pulses_fired(double t) const {
    return static_cast<std::size_t>(
        std::upper_bound(compare_times_.begin(), compare_times_.end(), t) - compare_times_.begin());
}

}  // namespace gonio::sim
