#pragma once

// Simulated motor controllers: a Modbus server (libmodbus) that implements the drive profiles of
// data/devices register for register, with several units (drives) behind one address, over TCP on
// 127.0.0.1 (port 0 = ephemeral) or over RTU on a pseudo-terminal pair. One thread serves every
// connection with poll() and non-blocking I/O (per-connection buffers, frame timeouts, bounded
// output, a connection limit), so no client can hold up another. Each unit runs a MotorSim;
// a unit may also carry a shutter coil. Faults are injected from C++ (inject()) or over Modbus
// through the fault registers (kFaultRegister...). All public functions are thread-safe.

#include <chrono>
#include <cstdint>
#include <cstdio>
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

enum class Transport {
    kTcp,  ///< Modbus TCP on 127.0.0.1.
    kRtu,  ///< Modbus RTU on a pseudo-terminal; clients open device_path().
};

struct ServerOptions {
    Transport transport = Transport::kTcp;
    int port = 0;  ///< TCP: 0 = ephemeral (see port()).
    int baud = 115200;
    /// TCP: connections served at once; further ones are accepted and closed, with a log line.
    int max_connections = 64;
    /// TCP: a connection whose incomplete frame has not been completed within this time is
    /// closed (a half frame or a byte trickle never holds anything up; 0 = never).
    int frame_timeout_ms = 1000;
    /// Replies waiting for a client that does not read; beyond this the client is dropped.
    std::size_t max_output_bytes = 64 * 1024;
    /// Log lines (connection limit, dropped clients, blips) go here; null = silent.
    std::FILE* log = stderr;
};

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

class MotorControllerServer {
  public:
    MotorControllerServer();
    ~MotorControllerServer();  ///< Stops the server.
    MotorControllerServer(const MotorControllerServer&) = delete;
    MotorControllerServer& operator=(const MotorControllerServer&) = delete;

    /// Adds a drive (before or after start()). Errors on a duplicate or invalid unit id (1..247).
    Expected<void> add_unit(int unit,
                            const devices::AxisProfile& profile,
                            const MotorSimConfig& cfg = {});
    /// Adds a shutter coil (wire address) to `unit`; a unit without a drive is created if needed.
    Expected<void> add_shutter(int unit, int coil);

    /// Binds and starts the server thread.
    Expected<void> start(const ServerOptions& options = {});
    void stop();
    bool running() const;

    int port() const;                 ///< TCP port (after start()).
    std::string device_path() const;  ///< RTU: pseudo-terminal path clients open.
    /// The address a client connects to: "tcp://127.0.0.1:PORT" or "rtu:/dev/pts/N?baud=...".
    std::string address() const;

    void inject(const Fault& f);
    /// Simulates a power blip of the gateway (TCP: every connection and the listener close, and
    /// the same port listens again after `down`) or of the line (RTU: requests go unanswered for
    /// `down`). With `drive_power_loss` the drives lose their move under way as well.
    void blip(std::chrono::milliseconds down, bool drive_power_loss = false);
    void clear_faults();

    /// Physical load angle of a unit's stage, degrees (NaN for an unknown unit).
    double position_deg(int unit) const;
    std::map<int, double> positions_deg() const;
    Expected<UnitSnapshot> snapshot(int unit) const;
    bool shutter_open(int unit) const;

    /// Requests received for `unit` (0 = all units), including ones answered with exceptions.
    std::uint64_t request_count(int unit = 0) const;

    /// Changes the time scale of every unit (applies from now on).
    void set_time_scale(double time_scale);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace gonio::sim
