#pragma once

// A UVC/V4L2 webcam through OpenCV's VideoCapture for cheap rigs. Its 8-bit frames are usually
// gamma-encoded and auto-exposed: they are not radiometric, and every Frame says so
// (Frame::linear = false, converted to a grey CV_16U image scaled from 8 bits).

#include <memory>

#include "gonio/devices/camera.h"

namespace gonio::devices {

/// Opens /dev/video<index> (or the platform's camera <index>).
Expected<std::unique_ptr<Camera>> open_uvc_camera(int index);

/// The warning every UVC user is shown.
const char* uvc_radiometry_warning();

}  // namespace gonio::devices
