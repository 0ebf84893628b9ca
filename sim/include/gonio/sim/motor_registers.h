#pragma once

// The register logic of the simulated motor controllers, apart from any transport: units (drives,
// each with a MotorSim, and shutter coils) behind one address, their holding registers and coils
// laid out as the drive profiles of data/devices say, requests executed from Modbus request PDUs
// (devices/modbus_codec.h), and the injected faults. No I/O: the TCP and RTU servers
// (MotorControllerServer) feed it the PDUs they receive and send what it answers; the modbus fuzz
// target feeds it arbitrary bytes. All public functions are thread-safe.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/sim/motor_sim.h"

namespace gonio::sim {

/// Injectable faults.
enum class FaultKind {
    kDelayReply,      ///< Replies `count` requests `delay` late (the reply is still sent).
    kDropConnection,  ///< Closes the TCP connection (RTU: stays silent) on the next `count`
                      ///< requests.
    kException,       ///< Answers `count` requests with Modbus exception `exception_code`.
    kAlarmMidMove,  ///< The next move stops at `fraction` of its distance with alarm `alarm_code`.
    kStall,         ///< The next move freezes at `fraction` while still reporting "moving".
};

struct Fault {
    FaultKind kind = FaultKind::kDelayReply;
    int unit = 0;   ///< 0 = whichever unit is addressed next (reply faults) / every unit (motion).
    int count = 1;  ///< Requests affected (reply faults).
    std::chrono::milliseconds delay{0};
    int exception_code = 6;  ///< 6 = slave (server) busy, 2 = illegal data address.
    int alarm_code = 0;      ///< 0 = the profile's overload code.
    double fraction = 0.5;
};

/// Fault registers present on every unit (wire addresses). Writing the kind register (in the same
/// request as the others, or after the
/// others) injects the fault: kind = 1 + FaultKind, count, delay ms, exception or alarm code,
/// fraction in 1/1000.
constexpr int kFaultRegister = 0xFF00;
constexpr int kFaultRegisterCount = 5;

/// The values of the fault registers for `f` (write them in one request to kFaultRegister).
std::vector<std::uint16_t> fault_registers(const Fault& f);
/// Parses a fault kind: delay, drop, exception, alarm, stall.
Expected<FaultKind> parse_fault_kind(const std::string& name);

/// State of one unit at one instant.
struct UnitSnapshot {
    double position_deg = 0;  ///< Physical load angle (what the optics see), degrees.
    double motor_deg = 0;     ///< Physical motor angle, degrees.
    double counter_deg = 0;   ///< What the drive reports, degrees.
    bool moving = false;
    bool homed = false;
    int alarm_code = 0;
    bool shutter_open = false;
};

/// A pulse of a drive's position compare output: the `index`-th (1-based) since it was armed,
/// sent at `at` (the instant the profile passes the table's entry, not when it is noticed).
struct ComparePulse {
    int unit = 0;
    std::size_t index = 0;
    std::chrono::steady_clock::time_point at;
};

/// What a transport does with one request.
struct Reply {
    enum class Kind {
        kSend,    ///< Send `pdu` back after `delay`.
        kSilent,  ///< Send nothing (RTU broadcast, absent RTU unit, dropped RTU request).
        kDrop,    ///< Close the TCP connection (injected fault).
    };
    Kind kind = Kind::kSilent;
    std::vector<std::uint8_t> pdu;
    std::chrono::milliseconds delay{0};
};

class MotorRegisters {
  public:
    MotorRegisters();
    ~MotorRegisters();
    MotorRegisters(const MotorRegisters&) = delete;
    MotorRegisters& operator=(const MotorRegisters&) = delete;

    /// Adds a drive. Errors on a duplicate or invalid unit id (1..247).
    Expected<void> add_unit(int unit,
                            const devices::AxisProfile& profile,
                            const MotorSimConfig& cfg = {});
    /// Adds a shutter coil (wire address) to `unit`; a unit without a drive is created if needed.
    Expected<void> add_shutter(int unit, int coil);

    /// Executes one request PDU addressed to `unit` and says what to answer. `serial`: Modbus over
    /// Serial Line rules (unit 0 is a broadcast that nobody answers; an absent unit is silent);
    /// otherwise a gateway's (an absent unit is answered with exception 0x0B). The checks follow
    /// the service flowcharts of the Application Protocol V1.1b3 (section 6): an unsupported
    /// function is exception 1, a malformed request exception 3, an address range outside the
    /// drive's registers (or a write to a register the drive writes itself) exception 2.
    Reply process(int unit, const std::vector<std::uint8_t>& pdu, bool serial);

    void inject(const Fault& f);
    void clear_faults();
    /// The drives lose power: a move under way is lost (the stage stops at once in this model),
    /// the position counter keeps its value.
    void power_loss();

    /// Physical load angle of a unit's stage, degrees (NaN for an unknown unit).
    double position_deg(int unit) const;
    std::map<int, double> positions_deg() const;
    /// The load angles of a unit's stage, degrees, `after_s[k]` simulated seconds from now (in
    /// increasing order) along the move under way (MotorSim::load_steps_at); NaN for an unknown
    /// unit.
    std::vector<double> path_deg(int unit, const std::vector<double>& after_s) const;
    /// The touch probe (profiles with registers probe_start and probe_end): latches the counter
    /// now and `exposure_s` simulated seconds from now along the move under way, as the rising and
    /// falling edges of an exposure of that length starting now would. Nothing for a unit without
    /// a drive or a probe.
    void latch_exposure(int unit, double exposure_s) const;
    Expected<UnitSnapshot> snapshot(int unit) const;
    bool shutter_open(int unit) const;

    /// Position compare: the pulses sent since the last call (by every armed drive, in order);
    /// `*armed` (when given) says whether any drive's compare is armed.
    std::vector<ComparePulse> take_pulses(bool* armed = nullptr);
    /// A unit's load angles (degrees) `after_s[k]` simulated seconds (ascending) after the instant
    /// `at` (past or future) along its last move (MotorSim::history_steps_at); NaN for an unknown
    /// unit.
    std::vector<double> path_deg_at(int unit,
                                    std::chrono::steady_clock::time_point at,
                                    const std::vector<double>& after_s) const;
    /// The touch probe's latches of compare pulse `index` (1-based) of `unit`: the counter at `at`
    /// and `exposure_s` simulated seconds later, into the latch table's entry and probe_start /
    /// probe_end. Nothing for a unit without the registers or an index beyond the table.
    void latch_pulse(int unit,
                     std::size_t index,
                     std::chrono::steady_clock::time_point at,
                     double exposure_s) const;
    /// Requests received for `unit` (0 = all units), including ones answered with exceptions.
    std::uint64_t request_count(int unit = 0) const;
    /// Changes the time scale of every unit (applies from now on).
    void set_time_scale(double time_scale);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace gonio::sim
