// The live page's picture of a camera frame: each byte against sqrt((counts - black) /
// (saturation - black)) computed here, the box average of a downscale, frames without a
// saturation level, and the caption's figures.

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "gonio/acquisition/shared/frame_picture.h"

namespace gonio::acquisition {
namespace {

std::uint8_t expected_byte(double counts, double black, double saturation) {
    const double x = std::clamp((counts - black) / (saturation - black), 0.0, 1.0);
    return static_cast<std::uint8_t>(std::lround(std::sqrt(x) * 255.0));
}

TEST(FramePicture, SquareRootOfCountsAboveBlackRelativeToSaturation) {
    devices::Frame f;
    f.black_level = 100;
    f.saturation_level = 4095;
    f.image = cv::Mat(2, 3, CV_16U);
    const std::uint16_t counts[6] = {0, 100, 1098, 2000, 4095, 65535};
    for (int i = 0; i < 6; ++i) {
        f.image.at<std::uint16_t>(i / 3, i % 3) = counts[i];
    }
    const FramePicture p = frame_picture(f, 480);
    ASSERT_EQ(p.width, 3);
    ASSERT_EQ(p.height, 2);
    ASSERT_EQ(p.grey.size(), 6u);
    for (int i = 0; i < 6; ++i) {
        SCOPED_TRACE("counts " + std::to_string(counts[i]));
        EXPECT_NEAR(p.grey[i], expected_byte(counts[i], 100, 4095), 1);
    }
    // Below black: 0; at and above saturation: white; a quarter of the range: half grey.
    EXPECT_EQ(p.grey[0], 0);
    EXPECT_EQ(p.grey[1], 0);
    EXPECT_NEAR(p.grey[2], 128, 1);
    EXPECT_EQ(p.grey[4], 255);
    EXPECT_EQ(p.grey[5], 255);
}

TEST(FramePicture, WideFrameIsBoxAveragedToTheWidth) {
    devices::Frame f;
    f.black_level = 0;
    f.saturation_level = 1000;
    // 8 x 4 px, left half 0, right half 640 counts: at 4 px wide each output pixel averages two
    // columns of one half, so the halves stay 0 and sqrt(0.64) = 0.8.
    f.image = cv::Mat(4, 8, CV_16U, cv::Scalar(0));
    f.image.colRange(4, 8).setTo(cv::Scalar(640));
    const FramePicture p = frame_picture(f, 4);
    ASSERT_EQ(p.width, 4);
    ASSERT_EQ(p.height, 2);
    for (int y = 0; y < p.height; ++y) {
        EXPECT_EQ(p.grey[y * 4 + 0], 0);
        EXPECT_EQ(p.grey[y * 4 + 1], 0);
        EXPECT_EQ(p.grey[y * 4 + 2], 204);
        EXPECT_EQ(p.grey[y * 4 + 3], 204);
    }
}

TEST(FramePicture, WithoutSaturationLevelTheTypesRangeIsUsed) {
    devices::Frame f;
    f.black_level = 50;  // ignored without a range above it
    f.saturation_level = 0;
    f.image = cv::Mat(1, 2, CV_8U);
    f.image.at<std::uint8_t>(0, 0) = 255;
    f.image.at<std::uint8_t>(0, 1) = 64;
    const FramePicture p = frame_picture(f, 10);
    ASSERT_EQ(p.grey.size(), 2u);
    EXPECT_EQ(p.grey[0], 255);
    EXPECT_NEAR(p.grey[1], expected_byte(64, 0, 255), 1);
}

TEST(FramePicture, EmptyOrUnsupportedFramesGiveNoPicture) {
    devices::Frame f;
    EXPECT_EQ(frame_picture(f, 100).width, 0);
    f.image = cv::Mat(2, 2, CV_16UC2, cv::Scalar(1, 1));
    EXPECT_EQ(frame_picture(f, 100).width, 0);
    f.image = cv::Mat(2, 2, CV_16U, cv::Scalar(1));
    EXPECT_EQ(frame_picture(f, 0).width, 0);
}

TEST(FramePicture, CaptionNamesFrameExposureAndSizes) {
    devices::Frame f;
    f.frame_id = 42;
    f.exposure_us = 2500;
    f.image = cv::Mat(600, 800, CV_16U, cv::Scalar(0));
    const std::string c = frame_picture_caption(f, 480, 360, "light arm 30 deg");
    EXPECT_NE(c.find("light arm 30 deg"), std::string::npos) << c;
    EXPECT_NE(c.find("frame 42"), std::string::npos) << c;
    EXPECT_NE(c.find("exposure 2.5 ms"), std::string::npos) << c;
    EXPECT_NE(c.find("800 x 600 px"), std::string::npos) << c;
    EXPECT_NE(c.find("480 x 360 px"), std::string::npos) << c;
}

}  // namespace
}  // namespace gonio::acquisition
