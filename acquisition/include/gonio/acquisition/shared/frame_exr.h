#pragma once

// A captured frame as an OpenEXR file (one FLOAT channel "Y", the raw counts; the exposure, gain,
// levels, bit depth, pixel format, colour filter array, timestamp and frame id as header
// attributes "gonio.*", the exposure also as the standard expTime in seconds). The image is
// encoded in memory and written through AtomicFile: a link at the target is never followed and a
// failed write leaves the previous file and no debris.

#include <string>

#include "gonio/base/error.h"
#include "gonio/devices/camera.h"

namespace gonio::acquisition {

/// The bytes of the OpenEXR file of a frame (8- or 16-bit integer or 32-bit float images).
Expected<std::string> encode_frame_exr(const devices::Frame& frame);

/// encode_frame_exr() written to `path` through AtomicFile.
Expected<void> write_frame_exr(const std::string& path, const devices::Frame& frame);

}  // namespace gonio::acquisition
