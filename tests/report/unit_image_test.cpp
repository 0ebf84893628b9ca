// Picture helpers against their specifications.

#include <gtest/gtest.h>

#include <cmath>

#include "gonio/report/image.h"

namespace gonio::report {
namespace {

std::vector<std::uint8_t> bytes(const std::string& s) {
    return {s.begin(), s.end()};
}

TEST(Base64, Rfc4648TestVectors) {
    // RFC 4648 section 10.
    EXPECT_EQ(base64_encode(bytes("")), "");
    EXPECT_EQ(base64_encode(bytes("f")), "Zg==");
    EXPECT_EQ(base64_encode(bytes("fo")), "Zm8=");
    EXPECT_EQ(base64_encode(bytes("foo")), "Zm9v");
    EXPECT_EQ(base64_encode(bytes("foob")), "Zm9vYg==");
    EXPECT_EQ(base64_encode(bytes("fooba")), "Zm9vYmE=");
    EXPECT_EQ(base64_encode(bytes("foobar")), "Zm9vYmFy");
    EXPECT_EQ(base64_encode({0xff, 0xfe, 0x00}), "//4A");
}

TEST(Srgb, EncodingMatchesIec61966) {
    EXPECT_EQ(srgb_encode(0.0), 0.0);
    EXPECT_EQ(srgb_encode(1.0), 1.0);
    EXPECT_NEAR(srgb_encode(0.0031308), 0.0404500, 1e-6);  // the two branches meet
    EXPECT_NEAR(srgb_encode(0.18), 0.4613561, 1e-6);       // 1.055 * 0.18^(1/2.4) - 0.055
    EXPECT_EQ(srgb_encode(std::nan("")), 0.0);
    EXPECT_EQ(srgb_encode(-1.0), 0.0);
    EXPECT_EQ(srgb_encode(7.0), 1.0);
}

TEST(ToneMap, FilmicCurveIsMonotoneAndBounded) {
    EXPECT_EQ(tone_map_filmic(0.0), 0.0);
    EXPECT_EQ(tone_map_filmic(std::nan("")), 0.0);
    EXPECT_EQ(tone_map_filmic(INFINITY), 1.0);
    // y(1) = 2.54 / 3.16 from the rational form.
    EXPECT_NEAR(tone_map_filmic(1.0), 2.54 / 3.16, 1e-12);
    double prev = 0;
    for (double x = 0.001; x < 100; x *= 1.1) {
        const double y = tone_map_filmic(x);
        EXPECT_GE(y, prev);
        EXPECT_LE(y, 1.0);
        prev = y;
    }
}

TEST(Luminance, Rec709Weights) {
    EXPECT_NEAR(luminance(brdf::Rgbd(1, 1, 1)), 1.0, 1e-12);
    EXPECT_NEAR(luminance(brdf::Rgbd(0, 1, 0)), 0.7152, 1e-12);
    EXPECT_NEAR(luminance_sigma(brdf::Rgbd(1, 0, 0)), 0.2126, 1e-12);
    EXPECT_NEAR(luminance_sigma(brdf::Rgbd(1, 1, 1)),
                std::sqrt(0.2126 * 0.2126 + 0.7152 * 0.7152 + 0.0722 * 0.0722),
                1e-12);
}

TEST(Png, EncodeDecodeRoundTrip) {
    Image img;
    img.width = 3;
    img.height = 2;
    img.rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30, 40, 50, 60, 70, 80, 90};
    auto png = encode_png(img);
    ASSERT_TRUE(png);
    ASSERT_GT(png->size(), 8u);
    EXPECT_EQ((*png)[1], 'P');
    const std::string path = std::string(GONIO_BINARY_DIR) + "/tests/report_roundtrip.png";
    ASSERT_TRUE(write_png(path, img));
    auto back = read_png(path);
    ASSERT_TRUE(back);
    EXPECT_EQ(back->rgb, img.rgb);
    EXPECT_FALSE(write_png(path, Image{}));
    EXPECT_FALSE(read_png(path + ".missing"));
}

}  // namespace
}  // namespace gonio::report
