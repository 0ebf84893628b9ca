#include "gonio/report/preview.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "canvas.h"
#include "gonio/brdf/table.h"
#include "image_cv.h"

namespace gonio::report {

namespace {

using brdf::Rgbd;
using brdf::Vec3d;

/// splitmix64 (S. Vigna, 2015): a well-mixed 64-bit hash of a counter, for per-pixel seeds.
std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

double to_unit(std::uint64_t x) {
    return static_cast<double>(x >> 11) * (1.0 / 9007199254740992.0);
}

/// Van der Corput radical inverse in base 2 (the second Hammersley coordinate).
double radical_inverse2(std::uint32_t i) {
    i = (i << 16) | (i >> 16);
    i = ((i & 0x55555555u) << 1) | ((i & 0xAAAAAAAAu) >> 1);
    i = ((i & 0x33333333u) << 2) | ((i & 0xCCCCCCCCu) >> 2);
    i = ((i & 0x0F0F0F0Fu) << 4) | ((i & 0xF0F0F0F0u) >> 4);
    i = ((i & 0x00FF00FFu) << 8) | ((i & 0xFF00FF00u) >> 8);
    return static_cast<double>(i) * (1.0 / 4294967296.0);
}

/// An orthonormal frame (t, b, n) at a sphere normal, as documented in preview.h.
struct Frame {
    Vec3d t, b, n;
    Vec3d to_local(const Vec3d& w) const { return {w.dot(t), w.dot(b), w.dot(n)}; }
};

Frame frame_at(const Vec3d& n) {
    Vec3d t(n.z(), 0.0, -n.x());  // e_y x n
    const double len = t.norm();
    if (len < 1e-12) {
        // n = +-e_y (top or bottom of the silhouette): e_y x n vanishes; e_x is perpendicular.
        t = Vec3d(1, 0, 0);
    } else {
        t /= len;
    }
    return {t, n.cross(t), n};
}

/// Any unit vector perpendicular to a (for the lobe frame).
std::pair<Vec3d, Vec3d> basis_about(const Vec3d& a) {
    const Vec3d helper = std::abs(a.x()) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
    const Vec3d u = a.cross(helper).normalized();
    return {u, a.cross(u)};
}

constexpr double kLobeExponents[] = {8, 64, 512, 4096, 32768};
constexpr int kStrategies = 1 + sizeof(kLobeExponents) / sizeof(kLobeExponents[0]);

template <class PixelFn>
RadianceImage render(int size_px, PixelFn pixel) {
    RadianceImage img;
    img.width = size_px;
    img.height = size_px;
    img.pixels.assign(static_cast<std::size_t>(size_px) * size_px, Rgbd::Zero());
    img.covered.assign(img.pixels.size(), false);
    const SphereLayout lay = sphere_layout(size_px);
    for (int j = 0; j < size_px; ++j) {
        for (int i = 0; i < size_px; ++i) {
            const double u = (i + 0.5 - lay.cx) / lay.radius;
            const double w = (lay.cy - (j + 0.5)) / lay.radius;
            const double r2 = u * u + w * w;
            if (r2 >= 1.0) {
                // Outside the disk: background.
                continue;
            }
            const Vec3d n(u, w, std::sqrt(1.0 - r2));
            const std::size_t idx = static_cast<std::size_t>(j) * size_px + i;
            img.covered[idx] = true;
            Rgbd L = pixel(frame_at(n), idx);
            for (int c = 0; c < 3; ++c) {
                if (!std::isfinite(L[c]) || L[c] < 0) {
                    // A BRDF that broke its contract (NaN, Inf or negative): show black rather
                    // than propagate; the Brdf interface promises this does not happen.
                    L[c] = 0;
                }
            }
            img.pixels[idx] = L;
        }
    }
    return img;
}

}  // namespace

SphereLayout sphere_layout(int size_px) {
    const double half = size_px / 2.0;
    return {half, half, std::max(1.0, half - 4.0)};
}

RadianceImage render_directional(const brdf::Brdf& brdf, const PreviewOptions& options) {
    const Vec3d l = options.light_dir.normalized();
    const Vec3d v(0, 0, 1);
    // A table's unmeasured bins are holes, not black reflectance.
    const auto* table = dynamic_cast<const brdf::TabulatedBrdf*>(&brdf);
    std::vector<bool> hole(static_cast<std::size_t>(options.size_px) * options.size_px, false);
    bool any_hole = false;
    RadianceImage img = render(options.size_px, [&](const Frame& f, std::size_t idx) -> Rgbd {
        const Vec3d wi = f.to_local(l);
        const Vec3d wo = f.to_local(v);
        if (wi.z() <= 0 || wo.z() <= 0) {
            // Light or camera below the local horizon: no direct light reaches the camera.
            return Rgbd::Zero();
        }
        if (table != nullptr) {
            const brdf::TableLookup t = table->lookup(wi, wo);
            if (!t.valid) {
                hole[idx] = true;
                any_hole = true;
                return Rgbd::Zero();
            }
            return t.value * (options.light_irradiance * wi.z());
        }
        return brdf.eval(wi, wo) * (options.light_irradiance * wi.z());
    });
    if (any_hole) {
        img.hole = std::move(hole);
    }
    return img;
}

brdf::Rgbd environment_radiance(const brdf::Vec3d& w) {
    if (w.y() >= 0) {
        const double t = std::min(1.0, w.y());
        const Rgbd horizon(0.9, 0.95, 1.0);
        const Rgbd zenith(0.25, 0.45, 0.9);
        return horizon * (1 - t) + zenith * t;
    }
    return Rgbd(0.22, 0.18, 0.14);
}

RadianceImage render_environment(const brdf::Brdf& brdf, const PreviewOptions& options) {
    const Vec3d v(0, 0, 1);
    const int per = std::max(1, options.env_samples / kStrategies);
    const double n_k = per;  // samples per strategy (equal allocation)
    // A pixel most of whose directions fall in a table's unmeasured bins is a hole.
    const auto* table = dynamic_cast<const brdf::TabulatedBrdf*>(&brdf);
    std::vector<bool> hole(static_cast<std::size_t>(options.size_px) * options.size_px, false);
    bool any_hole = false;
    RadianceImage img = render(options.size_px, [&](const Frame& f, std::size_t idx) -> Rgbd {
        const Vec3d wo = f.to_local(v);
        if (wo.z() <= 0) {
            // Silhouette: the camera grazes the surface.
            return Rgbd::Zero();
        }
        const Vec3d r = 2.0 * v.dot(f.n) * f.n - v;  // mirror direction of v about n, world
        const auto [ru, rv] = basis_about(r);
        const std::uint64_t h = splitmix64(options.seed ^ splitmix64(idx));
        const double shift_u = to_unit(splitmix64(h));
        const double shift_v = to_unit(splitmix64(h + 1));

        // Sum over all strategies of n_k pdf_k(w) (balance heuristic denominator).
        auto mixture_pdf = [&](const Vec3d& w) {
            double p = 0;
            const double cos_n = w.dot(f.n);
            if (cos_n > 0) {
                p += n_k * cos_n * brdf::kInvPi;
            }
            const double cos_r = w.dot(r);
            if (cos_r > 0) {
                for (double e : kLobeExponents) {
                    p += n_k * (e + 1) / (2 * brdf::kPi) * std::pow(cos_r, e);
                }
            }
            return p;
        };
        Rgbd sum = Rgbd::Zero();
        int drawn = 0;
        int unmeasured = 0;
        for (int s = 0; s < kStrategies; ++s) {
            for (int k = 0; k < per; ++k) {
                // Hammersley point, rotated per pixel (Cranley-Patterson).
                double u1 = (k + 0.5) / per + shift_u;
                double u2 = radical_inverse2(static_cast<std::uint32_t>(k)) + shift_v;
                u1 -= std::floor(u1);
                u2 -= std::floor(u2);
                const double phi = 2 * brdf::kPi * u2;
                Vec3d w;
                if (s == 0) {
                    // Cosine-weighted hemisphere about n (Malley's method).
                    const double rad = std::sqrt(u1);
                    const double z = std::sqrt(std::max(0.0, 1 - u1));
                    w = f.t * (rad * std::cos(phi)) + f.b * (rad * std::sin(phi)) + f.n * z;
                } else {
                    // Cosine-power lobe about r: cos(angle) = u1^(1 / (e + 1)).
                    const double e = kLobeExponents[s - 1];
                    const double c = std::pow(u1, 1.0 / (e + 1));
                    const double sn = std::sqrt(std::max(0.0, 1 - c * c));
                    w = ru * (sn * std::cos(phi)) + rv * (sn * std::sin(phi)) + r * c;
                }
                const Vec3d wi = f.to_local(w);
                if (wi.z() <= 0) {
                    // Below the local horizon: the BRDF is zero there.
                    continue;
                }
                ++drawn;
                if (table != nullptr && !table->lookup(wi, wo).valid) {
                    // An unmeasured bin: no value, counted toward the pixel's being a hole.
                    ++unmeasured;
                    continue;
                }
                const double pdf = mixture_pdf(w);
                if (!(pdf > 0)) {
                    // Cannot happen for a direction we drew; guard the division anyway.
                    continue;
                }
                sum += brdf.eval(wi, wo) * environment_radiance(w) * (wi.z() / pdf);
            }
        }
        if (2 * unmeasured > drawn) {
            hole[idx] = true;
            any_hole = true;
        }
        return sum;
    });
    if (any_hole) {
        img.hole = std::move(hole);
    }
    return img;
}

/// Splits a label into lines no wider than width_px: at spaces, or inside a word longer than a
/// line.
static std::vector<std::string> wrap_text(const std::string& text, int width_px) {
    std::vector<std::string> lines;
    std::string line;
    std::size_t i = 0;
    while (i < text.size()) {
        std::size_t j = text.find(' ', i);
        if (j == std::string::npos) {
            j = text.size();
        }
        std::string word = text.substr(i, j - i);
        i = j + 1;
        const std::string candidate = line.empty() ? word : line + " " + word;
        if (draw::text_width(candidate) <= width_px) {
            line = candidate;
            continue;
        }
        if (!line.empty()) {
            lines.push_back(line);
            line.clear();
        }
        while (draw::text_width(word) > width_px && word.size() > 1) {
            // A word wider than a line: broken where it stops fitting.
            std::size_t n = word.size() - 1;
            while (n > 1 && draw::text_width(word.substr(0, n)) > width_px) {
                --n;
            }
            lines.push_back(word.substr(0, n));
            word = word.substr(n);
        }
        line = word;
    }
    if (!line.empty() || lines.empty()) {
        lines.push_back(line);
    }
    return lines;
}

namespace {

/// Automatic exposure: the median sphere pixel of the whole sheet becomes mid grey.
double auto_exposure(const std::vector<RadianceImage>& renders) {
    std::vector<double> lum;
    for (const RadianceImage& r : renders) {
        for (std::size_t i = 0; i < r.pixels.size(); ++i) {
            if (r.covered[i] && (r.hole.empty() || !r.hole[i])) {
                lum.push_back(luminance(r.pixels[i]));
            }
        }
    }
    double median = 0;
    if (!lum.empty()) {
        std::nth_element(lum.begin(), lum.begin() + lum.size() / 2, lum.end());
        median = lum[lum.size() / 2];
    }
    return median > 0 ? std::clamp(0.18 / median, 0.25, 100.0) : 1.0;
}

/// The footer: exposure, light direction, axes, and what magenta means when a table has holes.
std::string preview_footer(double exposure,
                           const Vec3d& light_dir,
                           const std::vector<RadianceImage>& renders) {
    const Vec3d l = light_dir.normalized();
    char foot[160];
    std::snprintf(foot,
                  sizeof foot,
                  "exposure x%.3g; light toward (%.2f, %.2f, %.2f); x right, y up, z to viewer",
                  exposure,
                  l.x(),
                  l.y(),
                  l.z());
    bool holes = false;
    for (const RadianceImage& r : renders) {
        holes = holes || !r.hole.empty();
    }
    return std::string(foot) + (holes ? "; magenta: table bins not measured" : "");
}

}  // namespace

Expected<Image> preview_sheet(const brdf::Brdf& a,
                              const std::string& label_a,
                              const brdf::Brdf* b,
                              const std::string& label_b,
                              const PreviewOptions& options) {
    if (options.size_px < 16) {
        return make_error("preview: size_px = " + std::to_string(options.size_px) +
                          ": must be >= 16");
    }
    const int cell = options.size_px;
    const int margin = 12;
    const int header = 64;
    const int rows = b ? 2 : 1;
    // Columns at least 220 px apart so that their titles never overlap.
    const int column = std::max(cell, 220);
    const int W = 2 * column + 3 * margin;
    // Row labels are wrapped (never cut): one band line per 20 px.
    std::vector<std::vector<std::string>> labels;
    int rows_height = 0;
    for (int row = 0; row < rows; ++row) {
        labels.push_back(wrap_text(row == 0 ? label_a : label_b, W - 2 * margin));
        rows_height += 8 + 20 * static_cast<int>(labels.back().size()) + cell + margin;
    }
    const int H = header + rows_height + 22;
    cv::Mat img = draw::blank(
        W, H, "Sphere preview", "one exposure for all pictures; filmic tone curve, sRGB");
    const int cx0 = margin + column / 2;
    const int cx1 = 2 * margin + column + column / 2;
    draw::text(img,
               "directional light",
               {cx0, header - 8},
               draw::kTextScale,
               draw::kBlack,
               draw::Align::kCenter);
    draw::text(img,
               "sky / ground environment",
               {cx1, header - 8},
               draw::kTextScale,
               draw::kBlack,
               draw::Align::kCenter);
    std::vector<RadianceImage> renders;
    std::vector<int> rows_y;  // top of each row's pictures
    int y = header;
    for (int row = 0; row < rows; ++row) {
        const brdf::Brdf& br = row == 0 ? a : *b;
        for (std::size_t k = 0; k < labels[row].size(); ++k) {
            draw::text(img,
                       labels[row][k],
                       {W / 2, y + 14 + 20 * static_cast<int>(k)},
                       draw::kTextScale,
                       draw::kBlack,
                       draw::Align::kCenter);
        }
        y += 8 + 20 * static_cast<int>(labels[row].size());
        renders.push_back(render_directional(br, options));
        renders.push_back(render_environment(br, options));
        rows_y.push_back(y);
        y += cell + margin;
    }
    const double exposure = options.exposure > 0 ? options.exposure : auto_exposure(renders);
    const Color bg{48, 48, 48};
    for (std::size_t row = 0; row < rows_y.size(); ++row) {
        const cv::Rect left(cx0 - cell / 2, rows_y[row], cell, cell);
        const cv::Rect right(cx1 - cell / 2, rows_y[row], cell, cell);
        to_mat(tone_map(renders[2 * row], exposure, bg)).copyTo(img(left));
        to_mat(tone_map(renders[2 * row + 1], exposure, bg)).copyTo(img(right));
    }
    draw::text(img,
               preview_footer(exposure, options.light_dir, renders),
               {W / 2, H - 12},
               0.42,
               draw::kAxis,
               draw::Align::kCenter);
    return from_mat(img);
}

}  // namespace gonio::report
