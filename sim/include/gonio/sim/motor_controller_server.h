#pragma once

// Simulated motor controllers served over Modbus: the register logic of motor_registers.h (the
// drive profiles of data/devices register for register, several units behind one address) behind
// a Modbus TCP server on 127.0.0.1 (port 0 = ephemeral) or an RTU server on a pseudo-terminal,
// both speaking the wire format of devices/modbus_codec.h. One thread serves every connection with
// poll() and non-blocking I/O (per-connection buffers, frame timeouts, bounded output, a
// connection limit), so no client can hold up another. Faults are injected from C++ (inject()) or
// over Modbus through the fault registers (kFaultRegister...). All public functions are
// thread-safe.

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/sim/motor_registers.h"
#include "gonio/sim/motor_sim.h"

namespace gonio::sim {

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
    /// A unit's load angles `after_s[k]` simulated seconds from now (MotorRegisters::path_deg).
    std::vector<double> path_deg(int unit, const std::vector<double>& after_s) const;
    /// Latches an exposure of `exposure_s` starting now in a unit's touch probe
    /// (MotorRegisters::latch_exposure).
    void latch_exposure(int unit, double exposure_s) const;
    /// Position compare (MotorRegisters::take_pulses, path_deg_at, latch_pulse).
    std::vector<ComparePulse> take_pulses(bool* armed = nullptr);
    std::vector<double> path_deg_at(int unit,
                                    std::chrono::steady_clock::time_point at,
                                    const std::vector<double>& after_s) const;
    void latch_pulse(int unit,
                     std::size_t index,
                     std::chrono::steady_clock::time_point at,
                     double exposure_s) const;
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
