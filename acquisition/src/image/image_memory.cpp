#include "gonio/acquisition/image/image_memory.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gonio/base/limits.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/rig_geometry.h"
#include "light_choice.h"

namespace gonio::acquisition {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;
/// The process before the work: the executable and its libraries (a plan of a 64 px camera peaks
/// at 78 MiB), with a rig also its drivers, the stream's threads and the virtual rig's servers (a
/// campaign of the default 256 px camera on a 30 x 30 x 60 table peaks at 155 MiB).
constexpr double kProgramPlanBytes = 96 * kMiB;
constexpr double kProgramRunBytes = 160 * kMiB;
/// Bytes a traced ray costs sphere_pixels() (its pixel position and the ray).
constexpr double kRayBytes = sizeof(cv::Point2d) + sizeof(Ray);
/// Sub-pixel rays the virtual camera traces at a time (sim/src/sphere_render.cpp), each with its
/// position, owner pixel and ray.
constexpr double kRenderTileBytes = double(1 << 18) * (16 + 4 + 48);
/// Bytes of one camera pixel along the capture: the virtual camera's radiance and its copy
/// (float), its sensor counts and GigE payload, the received frame (16 bit), the frame and the
/// running sum of a dark frame (double), the silhouette frames (float, two), and the stream's
/// four buffers (16 bit).
constexpr double kCameraBytesPerPixel = 4 + 4 + 2 + 2 + 2 + 8 + 8 + 8 + 4 * 2;
/// Bytes of one lit pixel within a frame: lit and pending flags, the HDR signal, variance and
/// flag of three channels, the binned sample (bin, position, value, variance) and its order.
constexpr double kFramePixelBytes = 2 + 3 * (8 + 8 + 1) + (4 + 12 + 24 + 24) + 4;
/// Bytes one candidate costs besides its bins: the object and its bins' allocation.
constexpr double kCandidateBytes = sizeof(LightCandidate) + 32;

/// Valid bins of the fullest theta_d row of the table.
std::size_t fullest_row(const TableLayout& l) {
    std::size_t best = 0;
    for (int i_d = 0; i_d < l.n_theta_d; ++i_d) {
        std::size_t n = 0;
        for (int i_h = 0; i_h < l.n_theta_h; ++i_h) {
            for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
                n += bin_valid(l, l.index(i_h, i_d, i_p)) ? 1 : 0;
            }
        }
        best = std::max(best, n);
    }
    return best;
}

/// theta_d rows one frame of the view spans: one for a telecentric view (its light and view
/// directions are the same at every pixel), two where theta_d falls on a row's edge, and more as a
/// perspective view's directions spread over asin(R / d) about its axis (theta_d, half the angle
/// between light and view, then spreads over that much).
int rows_per_frame(const detail::SphereView& v, const TableLayout& l) {
    double spread = 0;
    if (v.camera.projection == Projection::kPerspective) {
        const double d = (v.sphere.centre - v.camera.centre_world()).norm();
        spread = std::asin(std::min(1.0, v.sphere.radius_m / d));
    }
    const double row = (brdf::kPi / 2) / l.n_theta_d;
    return 2 + static_cast<int>(std::ceil(spread / row));
}

/// The candidate light positions of a view: every allowed one in the wide view, those whose
/// highlight a zoomed placement sees (view_candidates).
std::size_t view_lights(const ImageCampaignConfig& cfg, const detail::SphereView& v, int k) {
    const std::vector<double> lights = light_positions(cfg.lights, cfg.detector_arm_rad);
    if (k == 0) {
        return lights.size();
    }
    return static_cast<std::size_t>(std::count_if(lights.begin(), lights.end(), [&](double a) {
        return placement_sees_highlight(v.camera, v.sphere, brdf::arm_direction(a));
    }));
}

/// Pixels, candidates and their bins of every view of an isotropic campaign.
void add_iso_views(const ImageCampaignConfig& cfg,
                   const SphereGeometry& sphere,
                   ImageMemoryEstimate* e,
                   double* largest_view_pixels) {
    const double row_bins = static_cast<double>(fullest_row(cfg.layout));
    for (int k = 0; k <= static_cast<int>(cfg.placements.size()); ++k) {
        const detail::SphereView v = detail::sphere_view(cfg, sphere, k);
        const double pixels = static_cast<double>(sphere_pixel_bound(v.camera, v.sphere, v.rules));
        *largest_view_pixels = std::max(*largest_view_pixels, pixels);
        const std::size_t n = view_lights(cfg, v, k);
        const double bins = std::min(pixels, rows_per_frame(v, cfg.layout) * row_bins);
        // Held twice: the open candidates and all of them (for the holes).
        e->candidate_bytes += 2.0 * static_cast<double>(n) * (bins * 4 + kCandidateBytes);
        e->candidates += n;
    }
}

/// The same for an anisotropic campaign: poses (light and spin) in the wide view, each holding
/// at most its pixels' 4-D bins, with their projection on the half/difference table.
void add_aniso_views(const ImageCampaignConfig& cfg,
                     const SphereGeometry& sphere,
                     ImageMemoryEstimate* e,
                     double* largest_view_pixels) {
    const double pixels = static_cast<double>(sphere_pixel_bound(cfg.camera, sphere, cfg.rules));
    *largest_view_pixels = pixels;
    const int stride = std::max(1, cfg.plan_pixel_stride);
    const std::size_t n =
        light_positions(cfg.lights, cfg.detector_arm_rad).size() * spin_positions(cfg.spins).size();
    const double bins =
        std::min(pixels / (stride * stride), static_cast<double>(cfg.aniso_layout.size()));
    e->candidate_bytes += 3.0 * static_cast<double>(n) * (bins * 4 + kCandidateBytes);
    e->candidates = n;
    // The pixels' tangents at one spin.
    e->pixel_bytes += pixels * sizeof(brdf::Vec3d);
}

/// A run's camera images and one frame's per-pixel samples.
double frame_bytes(const ImageCampaignConfig& cfg, double view_pixels, int virtual_supersample) {
    const double image = static_cast<double>(cfg.camera.intrinsics.width) *
                         static_cast<double>(cfg.camera.intrinsics.height);
    double bytes = image * kCameraBytesPerPixel;
    // The averaged dark frame of each exposure (double), cached for the campaign.
    bytes += std::max(1, cfg.max_brackets) * image * 8;
    if (virtual_supersample > 0) {
        bytes += kRenderTileBytes;
    }
    return bytes + view_pixels * kFramePixelBytes;
}

}  // namespace

std::string ImageMemoryEstimate::describe() const {
    char buf[400];
    std::snprintf(buf,
                  sizeof buf,
                  "program %s, pixels %s, candidates %s for %zu candidates, tables %s, "
                  "frames %s",
                  human_bytes(program_bytes).c_str(),
                  human_bytes(pixel_bytes).c_str(),
                  human_bytes(candidate_bytes).c_str(),
                  candidates,
                  human_bytes(table_bytes).c_str(),
                  human_bytes(frame_bytes).c_str());
    return buf;
}

Expected<ImageMemoryEstimate> estimate_image_memory(const ImageCampaignConfig& cfg,
                                                    bool plan_only,
                                                    int virtual_supersample) {
    auto sphere = detail::nominal_sphere(cfg);
    if (!sphere) {
        return tl::unexpected(sphere.error());
    }
    ImageMemoryEstimate e;
    e.program_bytes = plan_only ? kProgramPlanBytes : kProgramRunBytes;
    double view_pixels = 0;
    if (cfg.anisotropic) {
        add_aniso_views(cfg, *sphere, &e, &view_pixels);
    } else {
        add_iso_views(cfg, *sphere, &e, &view_pixels);
    }
    e.pixel_bytes += view_pixels * sizeof(SpherePixel) + kPixelsPerTile * kRayBytes;
    const TableLayout iso = cfg.anisotropic ? cfg.aniso_layout.iso() : cfg.layout;
    const double bins = cfg.anisotropic ? static_cast<double>(cfg.aniso_layout.size())
                                        : static_cast<double>(iso.size());
    // Coverage maps (valid and covered flags), the reachable flags and the prediction's marks.
    e.table_bytes = 8 * bins;
    if (!plan_only) {
        // The binned table (count, mean, m2, model variance, position) and the dataset written
        // from it, one sample per filled bin at most, with its stated uncertainty's working
        // arrays (bin_uncertainty.h: each row's bin and slope, a row index per bin).
        e.table_bytes += bins * (4 + 24 + 24 + 12 + 12 + sizeof(brdf::Sample) +
                                 sizeof(std::size_t) + sizeof(brdf::Rgbd) + 4);
        e.frame_bytes = frame_bytes(cfg, view_pixels, virtual_supersample);
    }
    return e;
}

}  // namespace gonio::acquisition
