#pragma once

// A camera frame as a person looks at it (the live campaign page): 8-bit grey, box-averaged down
// to at most a given width (aspect kept), each pixel sqrt((counts - black) / (saturation - black))
// clamped to [0, 1]. The square root is a display gamma that keeps the dim parts of a linear
// frame visible; saturated pixels are white. A frame without a saturation level above its black
// level is scaled by its type's range (8-bit, 16-bit; float frames by 1).

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/devices/camera.h"

namespace gonio::acquisition {

struct FramePicture {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> grey;  ///< Row-major, top row first.
};

/// The picture of a frame (file comment); empty for an empty frame, a width below 1, or a frame
/// of other than one or three channels (three: converted to grey first).
FramePicture frame_picture(const devices::Frame& frame, int max_width);

/// The caption of such a picture: `what` (the pose, filter or role of the frame), the frame's id,
/// exposure and size, the picture's size, and how its counts are shown.
std::string frame_picture_caption(const devices::Frame& frame,
                                  int picture_width,
                                  int picture_height,
                                  const std::string& what);

}  // namespace gonio::acquisition
