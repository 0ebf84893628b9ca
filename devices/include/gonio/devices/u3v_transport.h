#pragma once

// The seam between the USB3 Vision protocol and the carrier of its bytes: a control channel (bulk
// out for commands, bulk in for acknowledges) and a stream channel (bulk in). The libusb
// transport drives hardware; the simulator serves the same bytes in-process or over TCP.

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/brdf/error.h"

namespace gonio::devices {

using Bytes = std::vector<std::uint8_t>;

/// What went wrong in a transfer: callers retry on kTimeout, give up on kDisconnected.
enum class TransportFailure {
    kTimeout,       ///< nothing arrived before the deadline
    kDisconnected,  ///< the device or the connection is gone
    kOther,         ///< any other failure (message says which)
};

class U3vTransport {
  public:
    virtual ~U3vTransport() = default;
    /// Sends one command transfer on the control channel.
    virtual Expected<void> control_out(const Bytes& bytes, std::chrono::milliseconds timeout) = 0;
    /// Receives one acknowledge transfer (at most max_bytes).
    virtual Expected<Bytes> control_in(std::size_t max_bytes,
                                       std::chrono::milliseconds timeout) = 0;
    /// Receives one stream transfer (leader, a payload piece or trailer; at most max_bytes).
    virtual Expected<Bytes> stream_in(std::size_t max_bytes, std::chrono::milliseconds timeout) = 0;
    /// Clears a stalled stream endpoint / discards queued stream bytes.
    virtual void stream_flush() {}
    /// Kind of the last failure returned by one of the calls above.
    virtual TransportFailure last_failure() const = 0;
    /// "usb 2-3 (serial X)", "u3v-tcp://127.0.0.1:PORT"...
    virtual std::string describe() const = 0;
};

}  // namespace gonio::devices
