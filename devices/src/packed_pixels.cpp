// PFNC pixel formats and their unpacking into 16-bit counts.

#include "gonio/devices/packed_pixels.h"

namespace gonio::devices {

namespace {

using L = PixelLayout;

// PFNC 2.x codes: bits 31..24 mono/colour, 23..16 bits occupied per pixel, 15..0 the id.
constexpr PixelFormatInfo kFormats[] = {
    {0x01080001, "Mono8", L::kU8, 8, ""},
    {0x01100003, "Mono10", L::kU16Le, 10, ""},
    {0x010C0004, "Mono10Packed", L::kGigePacked10, 10, ""},
    {0x010A0046, "Mono10p", L::kLsbPacked10, 10, ""},
    {0x01100005, "Mono12", L::kU16Le, 12, ""},
    {0x010C0006, "Mono12Packed", L::kGigePacked12, 12, ""},
    {0x010C0047, "Mono12p", L::kLsbPacked12, 12, ""},
    {0x01100025, "Mono14", L::kU16Le, 14, ""},
    {0x01100007, "Mono16", L::kU16Le, 16, ""},
    {0x01080008, "BayerGR8", L::kU8, 8, "GRBG"},
    {0x01080009, "BayerRG8", L::kU8, 8, "RGGB"},
    {0x0108000A, "BayerGB8", L::kU8, 8, "GBRG"},
    {0x0108000B, "BayerBG8", L::kU8, 8, "BGGR"},
    {0x0110000C, "BayerGR10", L::kU16Le, 10, "GRBG"},
    {0x0110000D, "BayerRG10", L::kU16Le, 10, "RGGB"},
    {0x0110000E, "BayerGB10", L::kU16Le, 10, "GBRG"},
    {0x0110000F, "BayerBG10", L::kU16Le, 10, "BGGR"},
    {0x01100010, "BayerGR12", L::kU16Le, 12, "GRBG"},
    {0x01100011, "BayerRG12", L::kU16Le, 12, "RGGB"},
    {0x01100012, "BayerGB12", L::kU16Le, 12, "GBRG"},
    {0x01100013, "BayerBG12", L::kU16Le, 12, "BGGR"},
    {0x0110002E, "BayerGR16", L::kU16Le, 16, "GRBG"},
    {0x0110002F, "BayerRG16", L::kU16Le, 16, "RGGB"},
    {0x01100030, "BayerGB16", L::kU16Le, 16, "GBRG"},
    {0x01100031, "BayerBG16", L::kU16Le, 16, "BGGR"},
    {0x010C0026, "BayerGR10Packed", L::kGigePacked10, 10, "GRBG"},
    {0x010C0027, "BayerRG10Packed", L::kGigePacked10, 10, "RGGB"},
    {0x010C0028, "BayerGB10Packed", L::kGigePacked10, 10, "GBRG"},
    {0x010C0029, "BayerBG10Packed", L::kGigePacked10, 10, "BGGR"},
    {0x010C002A, "BayerGR12Packed", L::kGigePacked12, 12, "GRBG"},
    {0x010C002B, "BayerRG12Packed", L::kGigePacked12, 12, "RGGB"},
    {0x010C002C, "BayerGB12Packed", L::kGigePacked12, 12, "GBRG"},
    {0x010C002D, "BayerBG12Packed", L::kGigePacked12, 12, "BGGR"},
    {0x010A0052, "BayerBG10p", L::kLsbPacked10, 10, "BGGR"},
    {0x010A0054, "BayerGB10p", L::kLsbPacked10, 10, "GBRG"},
    {0x010A0056, "BayerGR10p", L::kLsbPacked10, 10, "GRBG"},
    {0x010A0058, "BayerRG10p", L::kLsbPacked10, 10, "RGGB"},
    {0x010C0053, "BayerBG12p", L::kLsbPacked12, 12, "BGGR"},
    {0x010C0055, "BayerGB12p", L::kLsbPacked12, 12, "GBRG"},
    {0x010C0057, "BayerGR12p", L::kLsbPacked12, 12, "GRBG"},
    {0x010C0059, "BayerRG12p", L::kLsbPacked12, 12, "RGGB"},
};

int bits_per_stored_pixel(PixelLayout layout) {
    switch (layout) {
        case L::kU8:
            return 8;
        case L::kU16Le:
            return 16;
        case L::kGigePacked10:
        case L::kGigePacked12:
            return 12;  // 2 pixels in 3 bytes, whatever the significant bits
        case L::kLsbPacked10:
            return 10;
        case L::kLsbPacked12:
            return 12;
    }
    return 16;
}

// Pixel i of a packed run of pixels starting at `src`.
std::uint16_t packed_pixel(const std::uint8_t* src, PixelLayout layout, std::size_t i) {
    switch (layout) {
        case L::kU8:
            return src[i];
        case L::kU16Le:
            return static_cast<std::uint16_t>(src[2 * i] | (src[2 * i + 1] << 8));
        case L::kGigePacked10:
        case L::kGigePacked12: {
            const std::uint8_t* g = src + 3 * (i / 2);
            const bool second = (i % 2) == 1;
            const int low_bits = layout == L::kGigePacked12 ? 4 : 2;
            const unsigned high = second ? g[2] : g[0];
            const unsigned low = second ? (g[1] >> 4) : g[1];
            return static_cast<std::uint16_t>((high << low_bits) | (low & ((1u << low_bits) - 1)));
        }
        case L::kLsbPacked10:
        case L::kLsbPacked12: {
            const unsigned b = layout == L::kLsbPacked12 ? 12 : 10;
            const std::size_t bit = i * b;
            const std::uint8_t* p = src + bit / 8;
            // b + 7 <= 19 bits: three bytes always cover the pixel.
            const std::uint32_t word = p[0] | (std::uint32_t{p[1]} << 8) |
                                       ((bit % 8) + b > 16 ? std::uint32_t{p[2]} << 16 : 0u);
            return static_cast<std::uint16_t>((word >> (bit % 8)) & ((1u << b) - 1));
        }
    }
    return 0;
}

}  // namespace

std::optional<PixelFormatInfo> find_pixel_format(std::uint32_t pfnc) {
    for (const auto& f : kFormats) {
        if (f.pfnc == pfnc) {
            return f;
        }
    }
    return std::nullopt;
}

std::optional<PixelFormatInfo> find_pixel_format(const std::string& name) {
    for (const auto& f : kFormats) {
        if (name == f.name) {
            return f;
        }
    }
    return std::nullopt;
}

std::size_t packed_line_bytes(PixelLayout layout, int width) {
    const std::size_t bits = static_cast<std::size_t>(width) * bits_per_stored_pixel(layout);
    return (bits + 7) / 8;
}

Expected<cv::Mat> unpack_pixels(const std::uint8_t* data,
                                std::size_t size,
                                const PixelFormatInfo& format,
                                int width,
                                int height,
                                int padding_x) {
    if (width <= 0 || height <= 0 || padding_x < 0) {
        return make_error(std::string(format.name) + " image " + std::to_string(width) + " x " +
                          std::to_string(height) + " (padding " + std::to_string(padding_x) +
                          "): sizes must be positive");
    }
    const std::size_t w = static_cast<std::size_t>(width);
    const std::size_t h = static_cast<std::size_t>(height);
    std::size_t needed = 0;
    if (padding_x == 0) {
        needed = (w * h * bits_per_stored_pixel(format.layout) + 7) / 8;
    } else {
        needed =
            (packed_line_bytes(format.layout, width) + static_cast<std::size_t>(padding_x)) * h;
    }
    if (data == nullptr || size < needed) {
        return make_error(std::string(format.name) + " image " + std::to_string(width) + " x " +
                          std::to_string(height) + " needs " + std::to_string(needed) +
                          " bytes, the buffer has " + std::to_string(size));
    }
    cv::Mat out(height, width, CV_16U);
    for (std::size_t y = 0; y < h; ++y) {
        auto* dst = out.ptr<std::uint16_t>(static_cast<int>(y));
        if (padding_x == 0) {
            // One continuous stream: pixel index y * w + x.
            for (std::size_t x = 0; x < w; ++x) {
                dst[x] = packed_pixel(data, format.layout, y * w + x);
            }
        } else {
            const std::uint8_t* line = data + y * (packed_line_bytes(format.layout, width) +
                                                   static_cast<std::size_t>(padding_x));
            for (std::size_t x = 0; x < w; ++x) {
                dst[x] = packed_pixel(line, format.layout, x);
            }
        }
    }
    return out;
}

}  // namespace gonio::devices
