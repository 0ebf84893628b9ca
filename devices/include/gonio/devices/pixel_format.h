#pragma once

// Pixel formats named by their PFNC (GenICam Pixel Format Naming Convention 2.x) 32-bit codes, as
// they travel in the U3V stream leader and in the PixelFormat enumeration of a device's XML.

#include <cstdint>
#include <optional>

#include "gonio/devices/camera.h"

namespace gonio::devices {

/// PFNC codes: bits 31..24 say mono/colour (0x01 = mono), bits 23..16 the bits per pixel as
/// stored, bits 15..0 an identifier.
inline constexpr std::uint32_t kPfncMono8 = 0x01080001;
inline constexpr std::uint32_t kPfncMono12 = 0x01100005;  ///< 12 bits in a 16-bit LE word
inline constexpr std::uint32_t kPfncMono16 = 0x01100007;

std::uint32_t pfnc_code(PixelFormat f);
std::optional<PixelFormat> pixel_format_from_pfnc(std::uint32_t code);
/// Significant bits of a pixel (8, 12, 16).
int significant_bits(PixelFormat f);
/// Bytes each pixel occupies in the payload (1 or 2).
int bytes_per_pixel(PixelFormat f);
/// Parses "Mono8", "Mono12", "Mono16" (the PFNC names).
std::optional<PixelFormat> pixel_format_from_string(const std::string& name);

}  // namespace gonio::devices
