// Unpacking of the pixel formats cameras send, against byte layouts written out by hand from the
// standards (GigE Vision 2.x Mono10Packed/Mono12Packed, PFNC 2.x Mono10p/Mono12p, little-endian
// 16-bit containers).

#include <gtest/gtest.h>

#include <vector>

#include "gonio/devices/packed_pixels.h"

namespace {

using gonio::devices::find_pixel_format;
using gonio::devices::unpack_pixels;

std::vector<int> unpack(const std::string& name,
                        const std::vector<std::uint8_t>& bytes,
                        int w,
                        int h,
                        int padding = 0) {
    auto f = find_pixel_format(name);
    EXPECT_TRUE(f) << name;
    auto m = unpack_pixels(bytes.data(), bytes.size(), *f, w, h, padding);
    EXPECT_TRUE(m) << m.error().message;
    std::vector<int> out;
    for (int y = 0; y < m->rows; ++y) {
        for (int x = 0; x < m->cols; ++x) {
            out.push_back(m->at<std::uint16_t>(y, x));
        }
    }
    return out;
}

TEST(PackedPixels, GigeMono12PackedTwoPixelsInThreeBytes) {
    // p0 = 0xABC, p1 = 0x123: byte 0 = p0[11:4], byte 1 = p0[3:0] | p1[3:0] << 4, byte 2 =
    // p1[11:4].
    EXPECT_EQ(unpack("Mono12Packed", {0xAB, 0x3C, 0x12}, 2, 1), (std::vector<int>{0xABC, 0x123}));
}

TEST(PackedPixels, GigeMono10PackedTwoPixelsInThreeBytes) {
    // p0 = 0x2AB, p1 = 0x1CD: byte 0 = p0[9:2], byte 1 = p0[1:0] | p1[1:0] << 4, byte 2 = p1[9:2].
    EXPECT_EQ(unpack("Mono10Packed", {0xAA, 0x13, 0x73}, 2, 1), (std::vector<int>{0x2AB, 0x1CD}));
}

TEST(PackedPixels, PfncMono12pIsAnLsbFirstBitStream) {
    // p0 = 0xABC in bits 0..11, p1 = 0x123 in bits 12..23.
    EXPECT_EQ(unpack("Mono12p", {0xBC, 0x3A, 0x12}, 2, 1), (std::vector<int>{0xABC, 0x123}));
}

TEST(PackedPixels, PfncMono10pFourPixelsInFiveBytes) {
    // 0x3FF, 0x000, 0x155, 0x2AA in bits 0..9, 10..19, 20..29, 30..39.
    EXPECT_EQ(unpack("Mono10p", {0xFF, 0x03, 0x50, 0x95, 0xAA}, 4, 1),
              (std::vector<int>{0x3FF, 0x000, 0x155, 0x2AA}));
    // The same stream read as a 2 x 2 image: lines do not restart on a byte boundary.
    EXPECT_EQ(unpack("Mono10p", {0xFF, 0x03, 0x50, 0x95, 0xAA}, 2, 2),
              (std::vector<int>{0x3FF, 0x000, 0x155, 0x2AA}));
}

TEST(PackedPixels, SixteenBitContainersAreLittleEndian) {
    EXPECT_EQ(unpack("Mono16", {0x34, 0x12, 0xFF, 0xFF}, 2, 1), (std::vector<int>{0x1234, 0xFFFF}));
    EXPECT_EQ(unpack("Mono12", {0xFF, 0x0F}, 1, 1), (std::vector<int>{0x0FFF}));
    EXPECT_EQ(find_pixel_format("Mono12")->bits, 12);
}

TEST(PackedPixels, LinePaddingIsSkipped) {
    // Two Mono8 lines of 3 pixels, each followed by one padding byte (0xEE).
    EXPECT_EQ(unpack("Mono8", {1, 2, 3, 0xEE, 4, 5, 6, 0xEE}, 3, 2, 1),
              (std::vector<int>{1, 2, 3, 4, 5, 6}));
}

TEST(PackedPixels, BayerFormatsNameTheirFilterPattern) {
    EXPECT_STREQ(find_pixel_format("BayerRG8")->cfa, "RGGB");
    EXPECT_STREQ(find_pixel_format(0x0108000Bu)->cfa, "BGGR");  // BayerBG8 by PFNC code
    EXPECT_STREQ(find_pixel_format("BayerGR12Packed")->cfa, "GRBG");
    EXPECT_STREQ(find_pixel_format("Mono8")->cfa, "");
    EXPECT_FALSE(find_pixel_format("RGB8"));
    EXPECT_FALSE(find_pixel_format(0x02180014u));  // RGB8: not a raw radiometric format
}

TEST(PackedPixels, ShortBufferIsAnErrorNamingTheSizes) {
    auto f = find_pixel_format("Mono12Packed");
    const std::vector<std::uint8_t> bytes(5);
    auto m = unpack_pixels(bytes.data(), bytes.size(), *f, 4, 1);
    ASSERT_FALSE(m);
    EXPECT_NE(m.error().message.find("needs 6 bytes, the buffer has 5"), std::string::npos)
        << m.error().message;
}

}  // namespace
