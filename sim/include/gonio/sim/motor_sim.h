#pragma once

// Kinematics of one simulated stepper/servo stage: trapezoidal velocity profiles, step
// quantisation, backlash between motor and load, encoder noise, homing onto a home switch at the
// physical zero, limit switches, and injected faults (alarm mid-move, stall). Time is simulated
// seconds (the server multiplies wall time by its time scale). Not thread-safe: the server owns it
// under its lock.

#include <cstdint>
#include <random>
#include <vector>

namespace gonio::sim {

struct MotorSimConfig {
    double time_scale = 1;           ///< Simulated seconds per wall-clock second (> 0).
    double backlash_deg = 0;         ///< Play between motor and load (load in [motor - b, motor]).
    double encoder_noise_steps = 0;  ///< Standard deviation of the feedback reading, steps.
    std::uint64_t seed = 1;          ///< Encoder noise seed.
    double initial_deg = 0;          ///< Physical position at power-up.
    bool start_homed = false;        ///< Counter already referenced at power-up.
    double limit_min_deg = -270;     ///< Physical position of the lower limit switch.
    double limit_max_deg = 270;      ///< Physical position of the upper limit switch.
};

/// One segment of constant acceleration.
struct MotionPhase {
    double t0 = 0;  ///< Start, simulated s.
    double p0 = 0;  ///< Start position, steps (physical).
    double v0 = 0;  ///< Start velocity, steps/s.
    double a = 0;   ///< Acceleration, steps/s^2.
    double duration = 0;
};

/// Trapezoidal (or triangular) profile from rest at p0 to rest at p1, at most v_max, accelerating
/// at `accel` and decelerating at `decel` (all > 0). Standard kinematics: with D = |p1 - p0| the
/// cruise speed is v = min(v_max, sqrt(2 D a d / (a + d))); ramps last v/a and v/d; the cruise
/// covers D - v^2/(2a) - v^2/(2d). D = 0 gives no phases.
std::vector<MotionPhase> plan_trapezoid(
    double t0, double p0, double p1, double v_max, double accel, double decel);

class MotorSim {
  public:
    MotorSim(const MotorSimConfig& cfg, double steps_per_degree);

    /// Advances the state to simulated time t (monotonic; earlier times are ignored).
    void update(double t);

    /// Absolute move in counter steps. Refused (returns false) while in alarm.
    bool start_move(double t, std::int64_t target_counter_steps, double v, double a, double d);
    /// Moves to the home switch (physical 0) at `v`, then references the counter there.
    bool start_home(double t, double v, double a);
    /// Decelerates to rest at `d` (immediately when d <= 0).
    void stop(double t, double d);
    void reset_alarm();

    /// Arms a fault for the next move: at `fraction` of its distance the motor stops and raises
    /// `code` (alarm) or freezes while still reporting motion (stall, code ignored).
    void arm_alarm(double fraction, int code);
    void arm_stall(double fraction, int deviation_alarm_code);
    /// Forgets an armed fault.
    void disarm() { armed_ = Armed::kNone; }
    /// Raises an alarm now (stops at once).
    void raise_alarm(int code);
    void set_overtravel_code(int code) { overtravel_code_ = code; }

    // Readings at the last update().
    bool moving() const;
    bool in_position() const { return !moving() && alarm_ == 0; }
    bool homing() const { return homing_ && moving(); }
    bool homed() const { return homed_; }
    int alarm_code() const { return alarm_; }
    /// Counter position (what the drive reports) without noise, steps, quantised.
    std::int64_t counter_steps() const;
    /// Counter position as read through the encoder (quantised, with noise).
    std::int64_t read_counter_steps();
    /// Physical motor and load angles in steps (load differs by the backlash).
    double motor_steps() const { return pos_; }
    double load_steps() const { return load_; }
    double steps_per_degree() const { return steps_per_degree_; }
    /// The load position (steps) at simulated times t >= the last update() along the move under
    /// way (its profile, then the backlash from the present load), as an encoder would read it
    /// then without noise; faults armed for later are not foreseen.
    /// `motor`, when given, receives the motor's positions (what its encoder reads) at the same
    /// times.
    std::vector<double> load_steps_at(const std::vector<double>& t,
                                      std::vector<double>* motor = nullptr) const;
    /// counter = physical motor position + this offset (steps).
    double counter_offset() const { return counter_offset_; }

    /// The load positions (steps) at simulated times `t` (ascending, past or future) along the
    /// last move started, as the profile ran it (cut where a fault or a limit stopped it);
    /// `motor` receives the motor's. Before that move's start: where it started.
    std::vector<double> history_steps_at(const std::vector<double>& t,
                                         std::vector<double>* motor = nullptr) const;

    /// Position compare: from simulated time `t` on, a pulse as the counter passes each of
    /// `counter_steps` in turn (either direction). Replaces an earlier table; empty disarms.
    void arm_compare(double t, std::vector<double> counter_steps);
    /// The simulated times of the pulses sent so far and of those the move under way will send
    /// (in order); pulses_fired(t) counts those at or before t.
    const std::vector<double>& compare_times() const { return compare_times_; }
    std::size_t pulses_fired(double t) const;

  private:
    /// Records the phases just planned as the move's history (and reschedules the compare).
    void begin_history(double t);
    /// Where the history's move was cut at simulated time t (fault, limit switch).
    void cut_history(double t);
    double history_motor_at(double t) const;
    /// The first time >= t0 at which the history's motor passes `p` (steps); +inf when never.
    double history_crossing(double t0, double p) const;
    void schedule_compare(double t);

    void apply_backlash(double motor);
    double position_at(double t, double* velocity) const;

    MotorSimConfig cfg_;
    double steps_per_degree_;
    double now_ = 0;
    double pos_ = 0;  ///< Physical motor position, steps.
    double vel_ = 0;
    double load_ = 0;            ///< Physical load position, steps.
    double counter_offset_ = 0;  ///< counter = physical + offset.
    std::vector<MotionPhase> phases_;
    double move_start_ = 0;
    double move_end_ = 0;
    bool homing_ = false;
    bool homed_ = false;
    bool stalled_ = false;
    int alarm_ = 0;
    int overtravel_code_ = 1;
    // Armed fault.
    enum class Armed { kNone, kAlarm, kStall } armed_ = Armed::kNone;
    double armed_fraction_ = 0.5;
    int armed_code_ = 0;
    // The last move's history: its phases from its start (load and motor there).
    std::vector<MotionPhase> hist_phases_;
    double hist_t0_ = 0;
    double hist_motor0_ = 0;
    double hist_load0_ = 0;
    double hist_end_ = 0;
    double hist_cut_t_ = 0;
    bool hist_cut_ = false;
    // Position compare.
    std::vector<double> compare_steps_;  ///< Motor positions (physical steps) of the table.
    std::vector<double> compare_times_;
    double compare_armed_t_ = 0;
    std::mt19937_64 rng_;
    std::normal_distribution<double> noise_{0.0, 1.0};
};

}  // namespace gonio::sim
