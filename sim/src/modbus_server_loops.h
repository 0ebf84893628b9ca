#pragma once

// The event loops of the simulated controllers' Modbus servers (private to sim/): Modbus TCP on a
// loopback listener and Modbus RTU on a pseudo-terminal. Each frames the byte stream with the
// codec of devices/modbus_codec.h, hands the request PDUs to the register logic (MotorRegisters)
// and sends what it answers. One thread runs one loop; stop() and blip() wake it through a pipe.

#include <atomic>
#include <chrono>
#include <functional>
#include <optional>
#include <string>

#include "gonio/sim/motor_controller_server.h"
#include "gonio/sim/motor_registers.h"

namespace gonio::sim::detail {

using Clock = std::chrono::steady_clock;

/// A simulated power blip: the link is down until `until`.
struct Blip {
    Clock::time_point until;
    std::chrono::milliseconds length{0};
};

/// What a loop shares with MotorControllerServer.
struct LoopContext {
    MotorRegisters* registers = nullptr;
    ServerOptions options;
    const std::atomic<bool>* running = nullptr;
    int wake_fd = -1;  ///< Readable when stop() or blip() wants the loop's attention.
    std::function<std::optional<Blip>()> take_blip;  ///< A pending blip request, taken.

    void log(const std::string& line) const;
    /// Empties the wake pipe.
    void drain_wake() const;
};

/// A non-blocking listener on 127.0.0.1:port; -1 (and *err) on failure.
int make_tcp_listener(int port, std::string* err);

/// Serves Modbus TCP until *ctx.running is false. `listen_fd` is the loop's listener: closed
/// during a blip and made again on `port` after it.
void serve_modbus_tcp(const LoopContext& ctx, int& listen_fd, int port);

/// Serves Modbus RTU on the pseudo-terminal's master side until *ctx.running is false.
void serve_modbus_rtu(const LoopContext& ctx, int pty_master);

}  // namespace gonio::sim::detail
