#include "gonio/report/blender_report.h"

#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "gonio/base/atomic_file.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_json.h"
#include "gonio/report/blender_export.h"
#include "gonio/report/blender_render.h"

namespace gonio::report {

namespace {

namespace fs = std::filesystem;

/// A temporary folder removed when this goes out of scope.
class ScratchDir {
  public:
    ScratchDir() {
        std::string tmpl = (fs::temp_directory_path() / "gonio-blender-XXXXXX").string();
        if (::mkdtemp(tmpl.data()) != nullptr) {
            path_ = tmpl;
        }
    }
    ~ScratchDir() {
        std::error_code ec;
        if (!path_.empty()) {
            fs::remove_all(path_, ec);
        }
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    const std::string& path() const { return path_; }

  private:
    std::string path_;
};

/// One exposure for gonio's and Blender's pictures: 0.18 over the median luminance of the
/// compared pixels of gonio's picture.
double shared_exposure(const RadianceImage& expected) {
    std::vector<double> lum;
    for (std::size_t i = 0; i < expected.pixels.size(); ++i) {
        if (expected.covered[i]) {
            lum.push_back(luminance(expected.pixels[i]));
        }
    }
    if (lum.empty()) {
        return 1.0;
    }
    std::nth_element(lum.begin(), lum.begin() + lum.size() / 2, lum.end());
    const double m = lum[lum.size() / 2];
    return m > 0 ? std::clamp(0.18 / m, 0.25, 1e4) : 1.0;
}

/// The relative difference per pixel as grey: 0 black, 5 % or more white; not compared dark blue.
Image difference_picture(const BlenderView& v) {
    Image out;
    out.width = v.render.width;
    out.height = v.render.height;
    out.rgb.assign(static_cast<std::size_t>(out.width) * out.height * 3, 0);
    for (std::size_t i = 0; i < v.pixel_rel.size(); ++i) {
        if (v.pixel_rel[i] < 0) {
            out.rgb[3 * i + 2] = 40;
            continue;
        }
        const auto g =
            static_cast<std::uint8_t>(std::lround(255 * std::min(1.0, v.pixel_rel[i] / 0.05)));
        out.rgb[3 * i] = out.rgb[3 * i + 1] = out.rgb[3 * i + 2] = g;
    }
    return out;
}

/// Pictures side by side, 4 px apart.
Image side_by_side(const std::vector<Image>& parts) {
    constexpr int kGap = 4;
    Image out;
    for (const Image& p : parts) {
        out.width += p.width + (out.width > 0 ? kGap : 0);
        out.height = std::max(out.height, p.height);
    }
    out.rgb.assign(static_cast<std::size_t>(out.width) * out.height * 3, 255);
    int x0 = 0;
    for (const Image& p : parts) {
        for (int y = 0; y < p.height; ++y) {
            std::copy_n(p.rgb.begin() + static_cast<std::ptrdiff_t>(y) * p.width * 3,
                        p.width * 3,
                        out.rgb.begin() + (static_cast<std::ptrdiff_t>(y) * out.width + x0) * 3);
        }
        x0 += p.width + kGap;
    }
    return out;
}

std::string caption_text(const BlenderComparison& c, const BlenderExport& e) {
    char buf[512];
    const BlenderView& front = c.views.front();
    std::snprintf(buf,
                  sizeof buf,
                  "The fit exported to Blender (gonio export --to blender) and rendered by "
                  "Blender's Cycles, beside gonio's own evaluation under the same sun (left: "
                  "gonio, middle: Blender, one exposure; right: relative difference, black 0 %%, "
                  "white 5 %% or more, blue not compared). Difference per pixel: median %.2g %%, "
                  "90th percentile %.2g %% lit 38 degrees from the view",
                  100 * front.median_rel,
                  100 * front.p90_rel);
    std::string s = buf;
    if (c.views.size() > 1) {
        std::snprintf(buf,
                      sizeof buf,
                      "; %.2g %% and %.2g %% back-lit at 120 degrees",
                      100 * c.views[1].median_rel,
                      100 * c.views[1].p90_rel);
        s += buf;
    }
    s += ".";
    if (e.approximations.empty()) {
        s += " Every term is written exactly.";
    }
    for (const std::string& a : e.approximations) {
        s += " " + a + ".";
    }
    return s;
}

}  // namespace

Expected<std::string> write_blender_preview(const std::string& dir, int size_px) {
    const fs::path root(dir);
    auto model = brdf::load_model_json((root / "fit.json").string());
    if (!model) {
        return make_error("blender: " + model.error().message);
    }
    BlenderExportOptions eo;
    eo.name = "gonio_fit";
    eo.approximate = true;
    auto exported = export_blender(*model, eo);
    if (!exported) {
        return make_error("blender: fit.json: " + exported.error().message);
    }
    ScratchDir scratch;
    if (scratch.path().empty()) {
        return make_error("blender: cannot make a temporary folder");
    }
    BlenderRenderOptions ro;
    ro.size_px = size_px;
    ro.work_dir = scratch.path();
    const auto truth = brdf::make_analytic_brdf(*model);
    auto cmp = render_and_compare(exported->text, eo.name, *truth, ro);
    if (!cmp) {
        return make_error("blender: " + cmp.error().message);
    }
    const BlenderView& v = cmp->views.front();
    const double exposure = shared_exposure(v.expected);
    RadianceImage render = v.render;
    std::fill(render.covered.begin(), render.covered.end(), true);
    const Image picture = side_by_side({tone_map(v.expected, exposure, {0, 0, 0}),
                                        tone_map(render, exposure, {0, 0, 0}),
                                        difference_picture(v)});
    const fs::path previews = root / "previews";
    std::error_code ec;
    fs::create_directories(previews, ec);
    const std::string png = (previews / "blender.png").string();
    if (auto w = write_png(png, picture); !w) {
        return make_error(w.error().message);
    }
    if (auto w =
            write_file_atomic((previews / "blender.txt").string(), caption_text(*cmp, *exported));
        !w) {
        return make_error(w.error().message);
    }
    return png;
}

std::string blender_preview_caption(const std::string& previews_dir) {
    std::ifstream in(fs::path(previews_dir) / "blender.txt");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string s = ss.str();
    return s.empty() ? "The fit rendered by Blender (gonio report --blender)." : s;
}

}  // namespace gonio::report
