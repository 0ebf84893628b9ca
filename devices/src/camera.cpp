// Names and PFNC codes of pixel formats.

#include "gonio/devices/camera.h"

#include "gonio/devices/pixel_format.h"

namespace gonio::devices {

const char* to_string(PixelFormat f) {
    switch (f) {
        case PixelFormat::kMono8:
            return "Mono8";
        case PixelFormat::kMono12:
            return "Mono12";
        case PixelFormat::kMono16:
            return "Mono16";
    }
    return "unknown";
}

std::uint32_t pfnc_code(PixelFormat f) {
    switch (f) {
        case PixelFormat::kMono8:
            return kPfncMono8;
        case PixelFormat::kMono12:
            return kPfncMono12;
        case PixelFormat::kMono16:
            return kPfncMono16;
    }
    return 0;
}

std::optional<PixelFormat> pixel_format_from_pfnc(std::uint32_t code) {
    switch (code) {
        case kPfncMono8:
            return PixelFormat::kMono8;
        case kPfncMono12:
            return PixelFormat::kMono12;
        case kPfncMono16:
            return PixelFormat::kMono16;
        default:
            return std::nullopt;
    }
}

int significant_bits(PixelFormat f) {
    switch (f) {
        case PixelFormat::kMono8:
            return 8;
        case PixelFormat::kMono12:
            return 12;
        case PixelFormat::kMono16:
            return 16;
    }
    return 16;
}

int bytes_per_pixel(PixelFormat f) {
    return f == PixelFormat::kMono8 ? 1 : 2;
}

std::optional<PixelFormat> pixel_format_from_string(const std::string& name) {
    for (PixelFormat f : {PixelFormat::kMono8, PixelFormat::kMono12, PixelFormat::kMono16}) {
        if (name == to_string(f)) {
            return f;
        }
    }
    return std::nullopt;
}

}  // namespace gonio::devices
