// Frames as OpenEXR, encoded in memory (Imf::OStream over a string) and written atomically.

#include "gonio/acquisition/shared/frame_exr.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <cstdint>
#include <exception>
#include <vector>

#include "gonio/base/atomic_file.h"

namespace gonio::acquisition {

namespace {

/// An OpenEXR output stream into a string (the writer seeks back to fill in the offset table).
class StringOStream final : public Imf::OStream {
  public:
    StringOStream() : Imf::OStream("<memory>") {}
    void write(const char c[], int n) override {
        if (pos_ + static_cast<std::size_t>(n) > bytes_.size()) {
            bytes_.resize(pos_ + static_cast<std::size_t>(n));
        }
        bytes_.replace(pos_, static_cast<std::size_t>(n), c, static_cast<std::size_t>(n));
        pos_ += static_cast<std::size_t>(n);
    }
    std::uint64_t tellp() override { return pos_; }
    void seekp(std::uint64_t pos) override { pos_ = static_cast<std::size_t>(pos); }
    std::string take() { return std::move(bytes_); }

  private:
    std::string bytes_;
    std::size_t pos_ = 0;
};

}  // namespace

Expected<std::string> encode_frame_exr(const devices::Frame& f) {
    const int w = f.image.cols, h = f.image.rows;
    if (w <= 0 || h <= 0) {
        return make_error("frame " + std::to_string(f.frame_id) + ": empty image");
    }
    const int depth = f.image.depth();
    if (f.image.channels() != 1 || (depth != CV_8U && depth != CV_16U && depth != CV_32F)) {
        return make_error("frame " + std::to_string(f.frame_id) +
                          ": expected one channel of 8- or 16-bit integers or 32-bit floats");
    }
    std::vector<float> pixels(static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            float v = 0;
            if (depth == CV_32F) {
                v = f.image.at<float>(y, x);
            } else if (depth == CV_16U) {
                v = static_cast<float>(f.image.at<std::uint16_t>(y, x));
            } else {
                v = static_cast<float>(f.image.at<std::uint8_t>(y, x));
            }
            pixels[static_cast<std::size_t>(y) * w + x] = v;
        }
    }
    try {
        Imf::Header header(w, h);
        header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        Imf::addExpTime(header, static_cast<float>(f.exposure_us * 1e-6));
        header.insert("gonio.exposure_us", Imf::DoubleAttribute(f.exposure_us));
        header.insert("gonio.gain", Imf::DoubleAttribute(f.gain));
        header.insert("gonio.black_level", Imf::DoubleAttribute(f.black_level));
        header.insert("gonio.saturation_level", Imf::DoubleAttribute(f.saturation_level));
        header.insert("gonio.bit_depth", Imf::IntAttribute(f.bit_depth));
        header.insert("gonio.timestamp_ns", Imf::StringAttribute(std::to_string(f.timestamp_ns)));
        header.insert("gonio.linear", Imf::IntAttribute(f.linear ? 1 : 0));
        header.insert("gonio.frame_id", Imf::StringAttribute(std::to_string(f.frame_id)));
        if (!f.pixel_format.empty()) {
            header.insert("gonio.pixel_format", Imf::StringAttribute(f.pixel_format));
        }
        if (!f.cfa.empty()) {
            // A raw Bayer mosaic, one value per pixel: not demosaiced (see docs/camera.md).
            header.insert("gonio.cfa", Imf::StringAttribute(f.cfa));
        }
        StringOStream stream;
        {
            Imf::OutputFile file(stream, header);
            Imf::FrameBuffer fb;
            fb.insert("Y",
                      Imf::Slice(Imf::FLOAT,
                                 reinterpret_cast<char*>(pixels.data()),
                                 sizeof(float),
                                 sizeof(float) * static_cast<std::size_t>(w)));
            file.setFrameBuffer(fb);
            file.writePixels(h);
        }
        return stream.take();
    } catch (const std::exception& e) {
        return make_error("frame " + std::to_string(f.frame_id) +
                          ": OpenEXR encoding failed: " + e.what());
    }
}

Expected<void> write_frame_exr(const std::string& path, const devices::Frame& frame) {
    // Refused before the encoding: a folder, a device, a missing folder.
    if (auto ok = check_output_path(path); !ok) {
        return ok;
    }
    auto bytes = encode_frame_exr(frame);
    if (!bytes) {
        return make_error(path + ": " + bytes.error().message);
    }
    return write_file_atomic(path, *bytes);
}

}  // namespace gonio::acquisition
