#pragma once

// A motorised rotary stage. Degrees at this interface; steps only on the wire (the driver scales).
// Implementations own their I/O (one owner per bus); calls on one Axis are not concurrent.

#include <array>
#include <chrono>
#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::devices {

/// What the drive reports.
enum class AxisState {
    kIdle,          ///< Standing still, in position.
    kMoving,        ///< A move is under way.
    kHoming,        ///< The homing sequence is under way.
    kAlarm,         ///< The drive raised an alarm (AxisStatus::alarm_code); moves are refused.
    kDisconnected,  ///< No answer from the drive.
};

const char* to_string(AxisState s);

struct AxisStatus {
    AxisState state = AxisState::kDisconnected;
    double position_deg = 0;  ///< Read in one request (never torn).
    bool homed = false;
    int alarm_code = 0;  ///< The drive's own alarm code when state == kAlarm.
};

struct SoftLimits {
    double min_deg = -180;
    double max_deg = 180;
};

struct Motion {
    double speed_deg_per_s = 20;
    double accel_deg_per_s2 = 40;
    double settle_ms = 50;  ///< Time after the drive reports in-position before a measurement.
};

class Axis {
  public:
    virtual ~Axis() = default;
    /// The axis's name in the rig ("light", "detector", ...), used in every error message.
    virtual const std::string& name() const = 0;
    virtual SoftLimits limits() const = 0;
    virtual Motion motion() const = 0;
    /// Sets speed and acceleration (written to the drive).
    virtual Expected<void> set_motion(const Motion& m) = 0;

    /// Runs the homing sequence and waits for the drive's homed flag, at most `timeout`.
    virtual Expected<void> home(std::chrono::milliseconds timeout) = 0;
    /// Starts an absolute move. Refused before any byte is sent when outside the soft limits or in
    /// alarm.
    virtual Expected<void> start_move(double position_deg) = 0;
    /// Waits for the drive's own in-position flag (and finishes any backlash approach), at most
    /// `timeout`. An alarm raised during the move is returned as an error naming the axis and the
    /// alarm code.
    virtual Expected<void> wait_done(std::chrono::milliseconds timeout) = 0;
    /// start_move + wait_done.
    Expected<void> move_to(double position_deg, std::chrono::milliseconds timeout) {
        if (auto r = start_move(position_deg); !r) {
            return r;
        }
        return wait_done(timeout);
    }
    virtual Expected<AxisStatus> status() = 0;
    virtual Expected<double> position_deg() = 0;
    /// Decelerates to a stop.
    virtual Expected<void> stop() = 0;
    /// Clears a drive alarm (where the drive allows it).
    virtual Expected<void> reset_alarm() = 0;
    /// Fly scans: the positions (degrees) the drive latched at the start and at the end of the
    /// camera's last exposure (a touch probe on the camera's exposure-active output, latching on
    /// its rising and falling edges). An error when the drive has no such latch.
    virtual Expected<std::array<double, 2>> exposure_latch_deg() {
        return make_error("axis \"" + name() +
                          "\": its drive latches no exposure positions (no touch probe in its "
                          "register map): fly scans need one");
    }

    /// Fly scans with a hardware trigger: whether the drive has a position compare output (its
    /// pulses wired to the camera's trigger input line).
    virtual bool has_position_compare() const { return false; }
    /// Writes the compare table (degrees, in the order the arm will pass them) and arms it: the
    /// drive pulses as its encoder passes each in turn, counting the pulses from 0.
    virtual Expected<void> arm_position_compare(const std::vector<double>& positions_deg) {
        (void)positions_deg;
        return no_compare();
    }
    /// Disarms the compare output (no further pulses).
    virtual Expected<void> disarm_position_compare() { return no_compare(); }
    /// Pulses sent since armed.
    virtual Expected<std::size_t> compare_pulses() { return no_compare(); }
    /// The touch probe's latches of pulse `index` (1-based): the positions (degrees) at the start
    /// and at the end of the exposure it triggered.
    virtual Expected<std::array<double, 2>> compare_latch_deg(std::size_t index) {
        (void)index;
        return no_compare();
    }

  private:
    tl::unexpected<Error> no_compare() const {
        return make_error("axis \"" + name() +
                          "\": its drive has no position compare output (no position_compare in "
                          "its register map)");
    }
};

}  // namespace gonio::devices
