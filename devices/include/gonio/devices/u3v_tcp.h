#pragma once

// The USB3 Vision bytes carried over TCP (127.0.0.1) so that a simulated camera served by one
// process can be used by another. Each transfer travels as one frame:
//   channel u8 (0 = control, 1 = stream), length u32 little-endian, then `length` bytes.
// The host only sends control frames; the device sends control (acknowledges) and stream frames.
// Address form: u3v-tcp://HOST:PORT (HOST must be a numeric IPv4 address).

#include <cstdint>
#include <memory>
#include <string>

#include "gonio/devices/u3v_transport.h"

namespace gonio::devices {

inline constexpr std::uint8_t kTcpChannelControl = 0;
inline constexpr std::uint8_t kTcpChannelStream = 1;
inline constexpr std::size_t kTcpFrameHeaderSize = 5;
/// Largest transfer accepted in one frame (a whole 64 MB payload piece).
inline constexpr std::uint32_t kTcpMaxFrameLength = 64u << 20;

/// Header bytes of one frame.
Bytes encode_tcp_frame_header(std::uint8_t channel, std::uint32_t length);

/// Connects to a served device; the error names the address and the socket error.
Expected<std::unique_ptr<U3vTransport>> connect_u3v_tcp(const std::string& host,
                                                        std::uint16_t port);

}  // namespace gonio::devices
