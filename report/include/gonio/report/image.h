#pragma once

// 8-bit RGB pictures (plots, previews) and linear radiance images, independent of the drawing
// library so that callers and tests need no OpenCV headers.

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::report {

/// An sRGB-encoded 8-bit colour.
struct Color {
    std::uint8_t r = 0, g = 0, b = 0;
    bool operator==(const Color& o) const { return r == o.r && g == o.g && b == o.b; }
    bool operator!=(const Color& o) const { return !(*this == o); }
};

/// An 8-bit RGB picture, row-major, top row first, 3 bytes per pixel in R, G, B order.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> rgb;

    bool empty() const { return width <= 0 || height <= 0; }
    Color at(int x, int y) const {
        const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 3;
        return {rgb[i], rgb[i + 1], rgb[i + 2]};
    }
};

/// Linear radiance per pixel (arbitrary but consistent units), row-major, top row first; pixels
/// outside the rendered object are marked by `covered` = false.
struct RadianceImage {
    int width = 0;
    int height = 0;
    std::vector<brdf::Rgbd> pixels;
    std::vector<bool> covered;
    /// Pixels whose value a table could not give (its bins there were not measured); empty when
    /// none. tone_map shows them in kHoleColor, not as black reflectance.
    std::vector<bool> hole;
};

/// The colour of a table's holes in pictures (magenta: no material is drawn in it).
inline constexpr Color kHoleColor{230, 0, 200};

/// Encodes an image as PNG bytes.
Expected<std::vector<std::uint8_t>> encode_png(const Image& image);
/// Writes an image as a PNG file; the error names the path.
Expected<void> write_png(const std::string& path, const Image& image);
/// Reads a PNG (or any format OpenCV decodes) into an Image; the error names the path.
Expected<Image> read_png(const std::string& path);

/// sRGB transfer function (IEC 61966-2-1:1999, eq. for the encoding C' = 12.92 C for C <=
/// 0.0031308, else 1.055 C^(1/2.4) - 0.055) applied to a linear value in [0, 1]; input clamped to
/// [0, 1] first (NaN maps to 0).
double srgb_encode(double linear);

/// Filmic tone curve: the fit of the ACES reference rendering transform by K. Narkowicz (2016,
/// "ACES Filmic Tone Mapping Curve"): y = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14) for x >=
/// 0, clamped to [0, 1]. Linear radiance 0 -> 0; large values saturate to 1 smoothly, so specular
/// highlights stay white without flattening the diffuse shading. Negative or NaN input maps to 0.
double tone_map_filmic(double x);

/// Tone maps (exposure * radiance, filmic) and sRGB-encodes a radiance image; uncovered pixels get
/// `background`.
Image tone_map(const RadianceImage& radiance, double exposure, Color background);

/// Luminance Y of a linear RGB triple with the Rec. 709 / sRGB primaries (ITU-R BT.709-6, item
/// 3.2): Y = 0.2126 R + 0.7152 G + 0.0722 B.
inline double luminance(const brdf::Rgbd& c) {
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/// One-sigma uncertainty of luminance() for independent channel uncertainties: sqrt(sum (w_c
/// sigma_c)^2).
double luminance_sigma(const brdf::Rgbd& sigma);

/// Standard base64 (RFC 4648 section 4, with '=' padding) of bytes, for data URIs.
std::string base64_encode(const std::vector<std::uint8_t>& bytes);

}  // namespace gonio::report
