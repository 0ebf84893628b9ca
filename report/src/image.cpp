#include "gonio/report/image.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "gonio/base/atomic_file.h"
#include "gonio/base/check.h"
#include "image_cv.h"

namespace gonio::report {

cv::Mat to_mat(const Image& image) {
    GONIO_CHECK(static_cast<std::size_t>(image.width) * image.height * 3 == image.rgb.size());
    cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data()));
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    return bgr;
}

Image from_mat(const cv::Mat& bgr) {
    GONIO_CHECK(bgr.type() == CV_8UC3);
    Image out;
    out.width = bgr.cols;
    out.height = bgr.rows;
    out.rgb.resize(static_cast<std::size_t>(out.width) * out.height * 3);
    cv::Mat rgb(out.height, out.width, CV_8UC3, out.rgb.data());
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    return out;
}

Expected<std::vector<std::uint8_t>> encode_png(const Image& image) {
    if (image.empty()) {
        return make_error("encode_png: empty image");
    }
    std::vector<std::uint8_t> bytes;
    if (!cv::imencode(".png", to_mat(image), bytes)) {
        return make_error("encode_png: OpenCV could not encode a " + std::to_string(image.width) +
                          "x" + std::to_string(image.height) + " image");
    }
    return bytes;
}

Expected<void> write_png(const std::string& path, const Image& image) {
    if (image.empty()) {
        return make_error(path + ": refusing to write an empty image");
    }
    if (auto ok = check_output_path(path); !ok) {
        return ok;
    }
    Expected<std::vector<std::uint8_t>> bytes = encode_png(image);
    if (!bytes) {
        return make_error(path + ": " + bytes.error().message);
    }
    return write_file_atomic(
        path, std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()));
}

Expected<Image> read_png(const std::string& path) {
    cv::Mat m = cv::imread(path, cv::IMREAD_COLOR);
    if (m.empty()) {
        return make_error(path + ": cannot read image (missing or not a PNG)");
    }
    return from_mat(m);
}

double srgb_encode(double linear) {
    if (!(linear > 0.0)) {
        // Zero, negative or NaN: black.
        return 0.0;
    }
    if (linear >= 1.0) {
        return 1.0;
    }
    if (linear <= 0.0031308) {
        return 12.92 * linear;
    }
    return 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

double tone_map_filmic(double x) {
    if (!(x > 0.0)) {
        // Zero, negative or NaN radiance: black.
        return 0.0;
    }
    if (std::isinf(x)) {
        // Unbounded radiance saturates.
        return 1.0;
    }
    const double y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
    return std::clamp(y, 0.0, 1.0);
}

Image tone_map(const RadianceImage& radiance, double exposure, Color background) {
    Image out;
    out.width = radiance.width;
    out.height = radiance.height;
    out.rgb.resize(static_cast<std::size_t>(out.width) * out.height * 3);
    for (std::size_t i = 0; i < radiance.pixels.size(); ++i) {
        if (!radiance.covered[i]) {
            out.rgb[3 * i] = background.r;
            out.rgb[3 * i + 1] = background.g;
            out.rgb[3 * i + 2] = background.b;
            continue;
        }
        if (!radiance.hole.empty() && radiance.hole[i]) {
            out.rgb[3 * i] = kHoleColor.r;
            out.rgb[3 * i + 1] = kHoleColor.g;
            out.rgb[3 * i + 2] = kHoleColor.b;
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            const double v = srgb_encode(tone_map_filmic(exposure * radiance.pixels[i][c]));
            out.rgb[3 * i + c] = static_cast<std::uint8_t>(std::lround(255.0 * v));
        }
    }
    return out;
}

double luminance_sigma(const brdf::Rgbd& sigma) {
    const double a = 0.2126 * sigma[0];
    const double b = 0.7152 * sigma[1];
    const double c = 0.0722 * sigma[2];
    return std::sqrt(a * a + b * b + c * c);
}

std::string base64_encode(const std::vector<std::uint8_t>& bytes) {
    static const char* kAlphabet =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const std::uint32_t v =
            (std::uint32_t(bytes[i]) << 16) | (std::uint32_t(bytes[i + 1]) << 8) | bytes[i + 2];
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += kAlphabet[(v >> 6) & 63];
        out += kAlphabet[v & 63];
    }
    const std::size_t rest = bytes.size() - i;
    if (rest == 1) {
        // One trailing byte: two symbols and two pad characters.
        const std::uint32_t v = std::uint32_t(bytes[i]) << 16;
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += "==";
    } else if (rest == 2) {
        // Two trailing bytes: three symbols and one pad character.
        const std::uint32_t v =
            (std::uint32_t(bytes[i]) << 16) | (std::uint32_t(bytes[i + 1]) << 8);
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += kAlphabet[(v >> 6) & 63];
        out += '=';
    }
    return out;
}

}  // namespace gonio::report
