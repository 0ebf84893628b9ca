#pragma once

// Conversions between gonio::report::Image (RGB) and OpenCV matrices (BGR); private to the module.

#include <opencv2/core.hpp>

#include "gonio/report/image.h"

namespace gonio::report {

cv::Mat to_mat(const Image& image);
Image from_mat(const cv::Mat& bgr);

}  // namespace gonio::report
