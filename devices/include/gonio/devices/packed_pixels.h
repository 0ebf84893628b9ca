#pragma once

// Pixel formats a GenICam camera sends (PFNC 2.x codes, the same 32-bit values GigE Vision and
// USB3 Vision carry in their stream leaders) and their conversion to 16-bit counts. Pure bytes ->
// pixels: no device I/O.
//
// Packed layouts, from the standards:
// - GigE Vision 2.x "Mono10Packed" / "Mono12Packed" (and the Bayer ..Packed forms): two pixels in
//   three bytes. Byte 0 holds the high bits of pixel 0, byte 2 the high bits of pixel 1; byte 1
//   holds the low bits, pixel 0 in bits 0.. and pixel 1 from bit 4 (12-bit: bits 3..0 and 7..4;
//   10-bit: bits 1..0 and 5..4).
// - PFNC "Mono10p" / "Mono12p" (and Bayer ..10p/..12p): a little-endian bit stream, pixel i in bits
//   [i*b, (i+1)*b) counted from bit 0 of byte 0.

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "gonio/base/error.h"

namespace gonio::devices {

/// How the bytes of one pixel format are laid out.
enum class PixelLayout {
    kU8,            ///< one byte per pixel
    kU16Le,         ///< one little-endian 16-bit word per pixel (value in the low bits)
    kGigePacked10,  ///< GigE Vision Mono10Packed: 2 pixels in 3 bytes
    kGigePacked12,  ///< GigE Vision Mono12Packed: 2 pixels in 3 bytes
    kLsbPacked10,   ///< PFNC Mono10p: LSB-first 10-bit stream
    kLsbPacked12,   ///< PFNC Mono12p: LSB-first 12-bit stream
};

/// A pixel format gonio can turn into counts.
struct PixelFormatInfo {
    std::uint32_t pfnc = 0;
    const char* name = "";  ///< PFNC name ("Mono12Packed", "BayerRG8")
    PixelLayout layout = PixelLayout::kU8;
    int bits = 8;          ///< significant bits per pixel
    const char* cfa = "";  ///< colour filter array of a Bayer format ("RGGB"), empty for mono
};

/// The format with this PFNC code, or nullopt when gonio does not decode it (colour, YUV, 3D...).
std::optional<PixelFormatInfo> find_pixel_format(std::uint32_t pfnc);
/// The format with this PFNC name, or nullopt.
std::optional<PixelFormatInfo> find_pixel_format(const std::string& name);

/// Bytes of one line of `width` pixels in this layout, without padding (packed streams round up).
std::size_t packed_line_bytes(PixelLayout layout, int width);

/// Decodes an image of width x height pixels into CV_16U counts. `padding_x` bytes follow each
/// line; with no padding a packed image is one continuous stream (lines need not end on a byte).
/// Fails, naming the sizes, when `size` is smaller than the image needs.
Expected<cv::Mat> unpack_pixels(const std::uint8_t* data,
                                std::size_t size,
                                const PixelFormatInfo& format,
                                int width,
                                int height,
                                int padding_x = 0);

}  // namespace gonio::devices
