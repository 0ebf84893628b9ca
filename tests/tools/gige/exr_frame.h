#pragma once

// Reads the single-channel frames `gonio camera capture` writes, with the OpenEXR library.

#include <OpenEXR/ImfArray.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <string>
#include <vector>

namespace gonio::testing {

struct ExrFrame {
    int width = 0;
    int height = 0;
    std::vector<float> y;  ///< row-major
    std::string frame_id, pixel_format, cfa;
    float at(int x, int row) const { return y[static_cast<std::size_t>(row) * width + x]; }
};

inline bool read_exr_frame(const std::string& path, ExrFrame* f, std::string* why) {
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i dw = file.header().dataWindow();
        f->width = dw.max.x - dw.min.x + 1;
        f->height = dw.max.y - dw.min.y + 1;
        f->y.assign(static_cast<std::size_t>(f->width) * f->height, -1.0f);
        Imf::FrameBuffer fb;
        fb.insert(
            "Y",
            Imf::Slice(Imf::FLOAT,
                       reinterpret_cast<char*>(f->y.data() - dw.min.x -
                                               static_cast<std::ptrdiff_t>(dw.min.y) * f->width),
                       sizeof(float),
                       sizeof(float) * static_cast<std::size_t>(f->width)));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        auto str = [&](const char* name) {
            const auto* a = file.header().findTypedAttribute<Imf::StringAttribute>(name);
            return a != nullptr ? a->value() : std::string();
        };
        f->frame_id = str("gonio.frame_id");
        f->pixel_format = str("gonio.pixel_format");
        f->cfa = str("gonio.cfa");
        return true;
    } catch (const std::exception& e) {
        *why = e.what();
        return false;
    }
}

}  // namespace gonio::testing
