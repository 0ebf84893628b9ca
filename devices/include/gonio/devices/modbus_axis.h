#pragma once

// A rotary stage behind a Modbus drive, described by a register-map profile (axis_profile.h).
// Degrees at the interface, steps on the wire. Soft limits and alarm state are checked before any
// byte is sent; waits poll the drive's own in-position / homed flags with a bounded deadline;
// backlash is taken up by a final approach from one configured side.

#include <chrono>
#include <memory>
#include <string>

#include "gonio/base/error.h"
#include "gonio/devices/axis.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_bus.h"

namespace gonio::devices {

/// From which side the final approach to a target is made.
enum class BacklashApproach {
    kNone,       ///< Go straight to the target.
    kFromBelow,  ///< Always arrive moving in +degrees (overshoot below first when coming from
                 ///< above).
    kFromAbove,  ///< Always arrive moving in -degrees.
};

struct AxisOptions {
    BacklashApproach approach = BacklashApproach::kNone;
    double approach_overshoot_deg = 0.5;  ///< Distance of the intermediate point before the target.
    double position_tolerance_deg = -1;   ///< Read-back check after a move; < 0 = 1.5 steps.
    /// Override the profile's timing (<= 0 keeps the profile's value).
    int response_timeout_ms = 0;
    int retries = -1;
    /// Longest wait between two status polls while a move is far from its target (the wait is
    /// half the time to go predicted from the profile's speed and acceleration, at least the
    /// profile's poll_ms; the bus's poll budget applies on top).
    int max_poll_interval_ms = 200;
};

/// What the axis did to get through lost links.
struct AxisRecovery {
    std::uint64_t link_recoveries = 0;  ///< Links re-established during a wait (state re-read).
    std::uint64_t reissued_moves = 0;   ///< Moves sent again because the drive had lost them.
    std::uint64_t polls = 0;            ///< Status polls made while waiting.
};

class ModbusAxis : public Axis {
  public:
    ModbusAxis(std::shared_ptr<ModbusBus> bus,
               int unit,
               AxisProfile profile,
               std::string name,
               SoftLimits limits,
               Motion motion,
               AxisOptions options = {});

    const std::string& name() const override { return name_; }
    SoftLimits limits() const override { return limits_; }
    Motion motion() const override { return motion_; }
    Expected<void> set_motion(const Motion& m) override;
    Expected<void> home(std::chrono::milliseconds timeout) override;
    Expected<void> start_move(double position_deg) override;
    Expected<void> wait_done(std::chrono::milliseconds timeout) override;
    Expected<AxisStatus> status() override;
    Expected<double> position_deg() override;
    Expected<std::array<double, 2>> exposure_latch_deg() override;
    bool has_position_compare() const override { return profile_.compare.present(); }
    Expected<void> arm_position_compare(const std::vector<double>& positions_deg) override;
    Expected<void> disarm_position_compare() override;
    Expected<std::size_t> compare_pulses() override;
    Expected<std::array<double, 2>> compare_latch_deg(std::size_t index) override;
    Expected<void> stop() override;
    Expected<void> reset_alarm() override;

    int unit() const { return unit_; }
    const AxisProfile& profile() const { return profile_; }
    const std::shared_ptr<ModbusBus>& bus() const { return bus_; }
    const AxisRecovery& recovery() const { return recovery_; }
    /// The wait before the next poll for a stage `remaining_deg` from its target, moving at
    /// `observed_deg_per_s` (< 0 = not known yet): half the predicted time to go, clamped to
    /// [poll_ms, max_poll_interval_ms]. The time to go is the smaller of the trapezoidal profile's
    /// (speed v, acceleration a: d/v + v/(2a) when d > v^2/(2a), else sqrt(2d/a)) and
    /// d / observed speed.
    std::chrono::microseconds poll_wait(double remaining_deg, double observed_deg_per_s) const;

  private:
    struct Raw {
        std::uint32_t status_word = 0;
        std::int64_t position_steps = 0;
    };
    Expected<Raw> read_raw(const RequestPolicy& policy);
    Expected<Raw> read_raw() { return read_raw(policy_); }
    Expected<int> read_alarm_code();
    Expected<void> run_action(const Action& a, const BlockInputs& in, const char* what);
    Expected<void> send_move(double position_deg);
    Expected<void> wait_flag(bool homing, std::chrono::steady_clock::time_point deadline);
    Error axis_error(const std::string& msg) const;
    std::string reg_label(int documented) const;
    bool bit(std::uint32_t word, int b) const { return b >= 0 && ((word >> b) & 1U) != 0; }

    std::shared_ptr<ModbusBus> bus_;
    int unit_;
    AxisProfile profile_;
    std::string name_;
    SoftLimits limits_;
    Motion motion_;
    AxisOptions options_;
    RequestPolicy policy_;
    RequestPolicy poll_policy_;  ///< policy_ with poll = true.
    AxisRecovery recovery_;
    bool homing_ = false;
    bool approach_pending_ = false;  ///< A backlash approach leg is under way.
    double final_target_deg_ = 0;
    double commanded_deg_ = 0;
};

/// Opens the bus for `address` (shared with other axes on it), loads the profile (name or path),
/// checks the limits and motion against it, and returns the axis. Nothing is sent to the drive yet.
Expected<std::unique_ptr<Axis>> open_axis(const std::string& name,
                                          const std::string& address,
                                          int unit,
                                          const std::string& profile_name_or_path,
                                          const SoftLimits& limits,
                                          const Motion& motion,
                                          const AxisOptions& options = {});

}  // namespace gonio::devices
