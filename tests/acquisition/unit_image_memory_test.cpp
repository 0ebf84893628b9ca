// The image planner's memory: the prediction streams over each candidate's pixels and keeps only
// its unique bins (checked bin for bin against every pixel binned on its own, on a telecentric
// and a perspective camera); the pixel list never reallocates; the memory estimate bounds what
// the prediction holds, and its candidates' part is bounded by the table, not the camera.

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "gonio/acquisition/image/image_memory.h"
#include "gonio/acquisition/image/image_planner.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/base/limits.h"
#include "gonio/brdf/coords.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;

/// A camera on the detector arm at 0 looking at the 20 mm sphere at the origin, and the sphere
/// as it sees it (silhouette radius from the projection).
struct View {
    CameraModel camera;
    SphereGeometry sphere;
};

View view_of(Projection projection, int size, double f, double distance) {
    CameraIntrinsics k;
    k.width = k.height = size;
    k.cx = k.cy = (size - 1) / 2.0;
    k.fx = k.fy = f;
    View v;
    v.camera = camera_on_detector_arm(k, projection, 0.0, distance);
    v.sphere.radius_m = 0.02;
    const Eigen::Vector2d c = v.camera.project(v.sphere.centre);
    const double r = projection == Projection::kOrthographic
                         ? f * v.sphere.radius_m
                         : f * std::tan(std::asin(v.sphere.radius_m / distance));
    v.sphere.silhouette = {c.x(), c.y(), r};
    return v;
}

/// The reference: every pixel's bin on its own, gathered in a set.
std::vector<std::uint32_t> every_pixel_binned(const View& v,
                                              const ExclusionRules& rules,
                                              const TableLayout& l,
                                              double light_arm_rad) {
    const brdf::Vec3d light = brdf::arm_direction(light_arm_rad);
    std::set<std::uint32_t> bins;
    for (const SpherePixel& p : sphere_pixels(v.camera, v.sphere, rules, nullptr)) {
        const auto [wi, wo] = local_directions(p, light);
        if (wi.z() < std::cos(rules.max_theta_i)) {
            continue;
        }
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
        const std::size_t b = bin_index(l, hd.theta_h, hd.theta_d, hd.phi_d);
        if (bin_valid(l, b)) {
            bins.insert(static_cast<std::uint32_t>(b));
        }
    }
    return {bins.begin(), bins.end()};
}

void expect_streamed_as_every_pixel(const View& v) {
    const TableLayout l = coarse_layout(2);
    const ExclusionRules rules;
    LightRange range;
    range.step_rad = 3 * kPi / 180;
    const std::vector<LightCandidate> cands =
        light_candidates(v.camera, v.sphere, rules, l, 0.0, range, 1);
    ASSERT_GE(cands.size(), 60u);
    for (const LightCandidate& c : cands) {
        const std::vector<std::uint32_t> expected =
            every_pixel_binned(v, rules, l, c.light_arm_rad);
        ASSERT_EQ(c.bins, expected) << "light at " << c.light_arm_rad * 180 / kPi << " deg";
        // Nothing held beyond its unique bins.
        EXPECT_EQ(c.bins.capacity(), c.bins.size());
    }
}

TEST(ImagePrediction, StreamedBinsAreEveryPixelsBinTelecentric) {
    expect_streamed_as_every_pixel(view_of(Projection::kOrthographic, 120, 2500, 0.5));
}

TEST(ImagePrediction, StreamedBinsAreEveryPixelsBinPerspective) {
    expect_streamed_as_every_pixel(view_of(Projection::kPerspective, 120, 1200, 0.5));
}

TEST(ImagePrediction, PixelListNeverReallocates) {
    for (const int size : {64, 257, 1000}) {
        const View v = view_of(Projection::kPerspective, size, 12.0 * size, 0.5);
        const ExclusionRules rules;
        const std::vector<SpherePixel> px = sphere_pixels(v.camera, v.sphere, rules, nullptr);
        const std::size_t bound = sphere_pixel_bound(v.camera, v.sphere, rules);
        EXPECT_EQ(px.capacity(), bound) << size << " px";
        EXPECT_LE(px.size(), bound);
        // The bound is the disc within the edge margin: pi (r - 1)^2 pixels, to the perimeter.
        const double r = v.sphere.silhouette.r - rules.edge_margin_px + 1;
        EXPECT_NEAR(static_cast<double>(bound), kPi * r * r, 2 * kPi * r + 4) << size << " px";
    }
}

ImageCampaignConfig config_of(int size, const TableLayout& layout) {
    ImageCampaignConfig cfg;
    cfg.camera = default_image_camera(size, false, 0.02);
    cfg.layout = layout;
    cfg.silhouette.radius_m = 0.02;
    cfg.lights.step_rad = 2 * kPi / 180;
    cfg.plan_pixel_stride = 1;
    return cfg;
}

TEST(ImageMemory, EstimateBoundsWhatThePredictionHolds) {
    const ImageCampaignConfig cfg = config_of(160, coarse_layout(2));
    auto e = estimate_image_memory(cfg, true, 0);
    ASSERT_TRUE(e) << e.error().message;
    View v;
    v.camera = cfg.camera;
    v.sphere.radius_m = 0.02;
    const Eigen::Vector2d c = v.camera.project(v.sphere.centre);
    v.sphere.silhouette = {c.x(), c.y(), 0.02 * cfg.camera.intrinsics.fx};
    const std::vector<LightCandidate> cands =
        light_candidates(v.camera, v.sphere, cfg.rules, cfg.layout, 0.0, cfg.lights, 1);
    EXPECT_EQ(e->candidates, light_positions(cfg.lights, 0.0).size());
    double held = 0;
    for (const LightCandidate& k : cands) {
        held += 2.0 * (k.bins.capacity() * 4 + sizeof(LightCandidate));
    }
    EXPECT_LE(held, e->candidate_bytes);
    const std::vector<SpherePixel> px = sphere_pixels(v.camera, v.sphere, cfg.rules, nullptr);
    EXPECT_GE(e->pixel_bytes, px.capacity() * sizeof(SpherePixel));
    // A plan has no frames; a run adds them and its binned table.
    EXPECT_EQ(e->frame_bytes, 0);
    auto run = estimate_image_memory(cfg, false, 2);
    ASSERT_TRUE(run);
    EXPECT_GT(run->frame_bytes, 160.0 * 160 * 8);
    EXPECT_GT(run->table_bytes, e->table_bytes + cfg.layout.size() * 64.0);
    // Per bin: the binned table's statistics (count, mean, m2, model variance, position), a
    // dataset row, and what stating its uncertainty holds beside it (the row's bin and slope, the
    // bin's row index: bin_uncertainty.h).
    const double per_bin = (4 + 24 + 24 + 12 + 12) + sizeof(brdf::Sample) + sizeof(std::size_t) +
                           sizeof(brdf::Rgbd) + 4;
    EXPECT_GE(run->table_bytes, e->table_bytes + cfg.layout.size() * per_bin);
}

TEST(ImageMemory, CandidatesAreBoundedByTheTableNotTheCamera) {
    // MERL resolution: a telecentric frame fills (part of) one or two theta_d rows of 90 x 180
    // bins, whatever the camera; only the pixel list grows with it (4 times the pixels).
    const TableLayout merl = TableLayout::merl();
    auto small = estimate_image_memory(config_of(1024, merl), true, 0);
    auto large = estimate_image_memory(config_of(2048, merl), true, 0);
    ASSERT_TRUE(small && large);
    EXPECT_EQ(small->candidate_bytes, large->candidate_bytes);
    EXPECT_GT(large->pixel_bytes, 3 * small->pixel_bytes);
    EXPECT_LT(large->total(), 2.0 * (1u << 30));
}

TEST(ImageMemory, RequestAboveTheBudgetIsRefusedNamingEstimateAndBudget) {
    CampaignRequest r;
    r.mode = CampaignMode::kImage;
    r.camera_px = 48;
    r.grid = TableLayout{15, 15, 30};
    const std::size_t saved = max_memory_bytes();
    set_max_memory_bytes(std::size_t{1} << 20);
    const Expected<void> run = check_image_request_memory(r);
    r.plan_only = true;
    const Expected<void> plan = check_image_request_memory(r);
    set_max_memory_bytes(saved);
    ASSERT_FALSE(run);
    EXPECT_NE(run.error().message.find("the image campaign (program "), std::string::npos)
        << run.error().message;
    EXPECT_NE(run.error().message.find("above the limit of 1 MiB"), std::string::npos)
        << run.error().message;
    ASSERT_FALSE(plan);
    EXPECT_NE(plan.error().message.find("the image plan (program "), std::string::npos)
        << plan.error().message;
    // Within the default budget both pass.
    EXPECT_TRUE(check_image_request_memory(r));
    r.plan_only = false;
    EXPECT_TRUE(check_image_request_memory(r));
}

}  // namespace
}  // namespace gonio::acquisition
