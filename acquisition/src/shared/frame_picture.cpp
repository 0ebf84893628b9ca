#include "gonio/acquisition/shared/frame_picture.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

namespace gonio::acquisition {

namespace {

/// The frame's counts as [0, 1] above black relative to the range up to saturation (frames
/// without that range: their type's own range), CV_32F, not yet clamped.
cv::Mat relative_counts(const devices::Frame& frame, const cv::Mat& grey) {
    double black = frame.black_level;
    double range = frame.saturation_level - frame.black_level;
    if (!(range > 0)) {
        black = 0;
        range = grey.depth() == CV_8U ? 255.0 : grey.depth() == CV_16U ? 65535.0 : 1.0;
    }
    cv::Mat linear;
    grey.convertTo(linear, CV_32F, 1.0 / range, -black / range);
    return linear;
}

/// Box-averaged down to `max_width` px wide when wider (aspect kept).
cv::Mat fit_width(const cv::Mat& linear, int max_width) {
    if (linear.cols <= max_width) {
        return linear;
    }
    const int h =
        std::max(1,
                 static_cast<int>(std::lround(static_cast<double>(linear.rows) * max_width /
                                              static_cast<double>(linear.cols))));
    cv::Mat small;
    cv::resize(linear, small, cv::Size(max_width, h), 0, 0, cv::INTER_AREA);
    return small;
}

}  // namespace

FramePicture frame_picture(const devices::Frame& frame, int max_width) {
    FramePicture out;
    const cv::Mat& src = frame.image;
    if (src.empty() || max_width < 1) {
        return out;
    }
    cv::Mat grey;
    if (src.channels() == 3) {
        cv::cvtColor(src, grey, cv::COLOR_BGR2GRAY);
    } else if (src.channels() == 1) {
        grey = src;
    } else {
        return out;
    }
    cv::Mat linear = fit_width(relative_counts(frame, grey), max_width);
    cv::max(linear, 0.0, linear);
    cv::min(linear, 1.0, linear);
    cv::sqrt(linear, linear);
    cv::Mat bytes;
    linear.convertTo(bytes, CV_8U, 255.0);
    out.width = bytes.cols;
    out.height = bytes.rows;
    out.grey.resize(static_cast<std::size_t>(out.width) * out.height);
    for (int y = 0; y < bytes.rows; ++y) {
        const std::uint8_t* row = bytes.ptr<std::uint8_t>(y);
        std::copy(
            row, row + bytes.cols, out.grey.begin() + static_cast<std::ptrdiff_t>(y) * out.width);
    }
    return out;
}

std::string frame_picture_caption(const devices::Frame& frame,
                                  int picture_width,
                                  int picture_height,
                                  const std::string& what) {
    char buf[400];
    std::snprintf(buf,
                  sizeof buf,
                  "Latest camera frame: %s; frame %llu, exposure %.3g ms, %d x %d px, shown at "
                  "%d x %d px as the square root of the counts above black relative to "
                  "saturation (white: saturated).",
                  what.c_str(),
                  static_cast<unsigned long long>(frame.frame_id),
                  frame.exposure_us / 1000,
                  frame.image.cols,
                  frame.image.rows,
                  picture_width,
                  picture_height);
    return buf;
}

}  // namespace gonio::acquisition
