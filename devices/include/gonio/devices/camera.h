#pragma once

// The detector. Frames are linear OpenCV matrices (CV_16U or CV_32F) carrying their exposure
// metadata; a frame that is not radiometric (8-bit gamma-encoded webcam output) says so in
// Frame::linear.

#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "gonio/base/error.h"

namespace gonio::devices {

struct CameraInfo {
    std::string vendor;
    std::string model;
    std::string serial;
    std::string version;
    int sensor_width = 0;
    int sensor_height = 0;
    /// Where the sensor size was read: "SensorWidth and SensorHeight", "WidthMax and HeightMax",
    /// the top of Width's and Height's ranges, or the current Width and Height when the camera's
    /// description gives them no maximum.
    std::string sensor_size_from;
    int bit_depth = 0;
};

/// Pixel formats (PFNC names).
enum class PixelFormat {
    kMono8,   ///< 8 bits per pixel.
    kMono12,  ///< 12 significant bits in 16-bit little-endian words.
    kMono16,  ///< 16 bits per pixel.
};

const char* to_string(PixelFormat f);

struct Roi {
    int x = 0;
    int y = 0;
    int width = 0;  ///< 0 = full sensor
    int height = 0;
};

struct Frame {
    cv::Mat image;  ///< CV_16U (raw counts) or CV_32F
    double exposure_us = 0;
    double gain = 1;  ///< Linear gain factor (1 = unity).
    std::int64_t timestamp_ns = 0;
    double black_level = 0;       ///< Counts of a dark pixel at zero exposure.
    double saturation_level = 0;  ///< Counts at which pixels clip.
    int bit_depth = 16;
    std::uint64_t frame_id = 0;
    bool linear = true;        ///< False for gamma-encoded 8-bit frames (not radiometric).
    std::string pixel_format;  ///< PFNC name of the format the camera sent ("" when not known).
    /// Bayer colour filter pattern ("RGGB", "GRBG", "GBRG", "BGGR") of a raw mosaic kept as sent,
    /// one value per pixel, not demosaiced; empty for a monochrome frame.
    std::string cfa;
};

class Camera {
  public:
    virtual ~Camera() = default;
    virtual Expected<CameraInfo> info() = 0;
    virtual Expected<void> set_exposure_us(double exposure_us) = 0;
    virtual Expected<double> exposure_us() = 0;
    virtual Expected<void> set_gain(double gain) = 0;
    virtual Expected<void> set_pixel_format(PixelFormat f) = 0;
    virtual Expected<void> set_roi(const Roi& roi) = 0;
    /// One frame (software trigger), waiting at most `timeout`.
    virtual Expected<Frame> capture(std::chrono::milliseconds timeout) = 0;
    virtual Expected<void> start_stream() = 0;
    virtual Expected<Frame> next_frame(std::chrono::milliseconds timeout) = 0;
    virtual Expected<void> stop_stream() = 0;
    /// Fly scans with a hardware trigger: starts a stream of frames each exposed on a rising edge
    /// of the trigger input `line` (GenICam TriggerMode On, TriggerSource `line`,
    /// TriggerActivation RisingEdge); next_frame() returns them in order, stop_stream() ends it.
    /// An error when the camera has no such input.
    virtual Expected<void> start_line_stream(const std::string& line) {
        return make_error("camera: no trigger input line \"" + line + "\" (TriggerSource)");
    }
};

/// The light source and its shutter (dark frames are taken with the shutter closed).
class Light {
  public:
    virtual ~Light() = default;
    virtual Expected<void> set_shutter_open(bool open) = 0;
    virtual Expected<bool> shutter_open() = 0;
};

}  // namespace gonio::devices
