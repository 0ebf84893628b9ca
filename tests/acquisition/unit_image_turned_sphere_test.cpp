// The turned sphere of anisotropic image mode (sphere_geometry.h): the tangent field of its tool
// marks, the circles of latitude about the lathe axis along the holder's local y, seen the same way
// by the virtual camera's renderer (sim/sphere_render.h) and by the acquisition's per-pixel
// geometry; and the holder's spin, which leaves the outline in place, turning an anisotropic
// material's image while leaving an isotropic one's alone.

#include <gtest/gtest.h>

#include <cmath>

#include "common/test_units.h"
#include "embedded_rig.h"
#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/sphere_geometry.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/rig_geometry.h"
#include "gonio/sim/sphere_imaging.h"

namespace gonio {
namespace {

using brdf::kPi;
using brdf::Vec3d;

using gonio::test_units::kDeg;

TEST(TurnedSphere, TangentAtTheFrontIsTheHolderXAxisTurnedBySpin) {
    // At the point facing along the holder's normal the circles of latitude about the holder's y
    // axis run along its x axis: (R_z(s) y) x z = R_z(s) (y x z) = R_z(s) x in the holder frame.
    for (const double tilt_deg : {0.0, 25.0, -60.0}) {
        for (const double spin_deg : {0.0, 30.0, 90.0, -135.0, 180.0}) {
            const double t = tilt_deg * kDeg;
            const double s = spin_deg * kDeg;
            const Vec3d n = brdf::sample_to_world(Vec3d(0, 0, 1), t, s);
            const Vec3d x = brdf::sample_to_world(Vec3d(1, 0, 0), t, s);
            const Vec3d got =
                acquisition::lathe_tangent(n, acquisition::lathe_axis_world(t, s), 5 * kDeg);
            EXPECT_LT((got - x).norm(), 1e-12) << "tilt " << tilt_deg << ", spin " << spin_deg;
        }
    }
}

TEST(TurnedSphere, NoTangentInsideThePoleCaps) {
    const Vec3d a = acquisition::lathe_axis_world(0, 0);
    EXPECT_LT((a - Vec3d(0, 0, 1)).norm(), 1e-15);  // holder y at rest is world z
    for (const double from_pole_deg : {0.0, 1.0, 9.9}) {
        const double e = from_pole_deg * kDeg;
        const Vec3d n(std::sin(e), 0, std::cos(e));
        EXPECT_EQ(acquisition::lathe_tangent(n, a, 10 * kDeg), Vec3d::Zero()) << from_pole_deg;
        EXPECT_EQ(acquisition::lathe_tangent(-n, a, 10 * kDeg), Vec3d::Zero()) << from_pole_deg;
    }
    const double e = 10.1 * kDeg;
    const Vec3d t = acquisition::lathe_tangent(Vec3d(std::sin(e), 0, std::cos(e)), a, 10 * kDeg);
    // z x (sin e, 0, cos e) = (0, sin e, 0), normalised.
    EXPECT_LT((t - Vec3d(0, 1, 0)).norm(), 1e-12);
}

/// The renderer's per-pixel truth against the acquisition's geometry of the same pixel, for the
/// holder at (tilt, spin) and the light and detector arms where given.
void expect_same_frames(
    bool perspective, double tilt_deg, double spin_deg, double light_deg, double detector_deg) {
    const int size = 48;
    const acquisition::CameraModel at_zero =
        acquisition::default_image_camera(size, perspective, 0.02);
    const acquisition::CameraModel cam = acquisition::camera_on_detector_arm(
        at_zero.intrinsics, at_zero.projection, detector_deg * kDeg, 0.5);
    sim::SphereImaging im;
    im.camera = tools::to_sphere_camera(at_zero);
    im.radius_m = 0.02;
    im.supersample = 1;
    sim::SceneState state;
    state.light_arm_rad = light_deg * kDeg;
    state.detector_arm_rad = detector_deg * kDeg;
    state.tilt_rad = tilt_deg * kDeg;
    state.spin_rad = spin_deg * kDeg;
    const std::vector<sim::SpherePixelTruth> truth =
        sim::sphere_truth(sim::sphere_scene(im, state));

    acquisition::SphereGeometry g;
    g.radius_m = 0.02;
    const Eigen::Vector2d c = cam.project(g.centre);
    g.silhouette.cx = c.x();
    g.silhouette.cy = c.y();
    g.silhouette.r = perspective ? cam.intrinsics.fx * std::tan(std::asin(g.radius_m / 0.5))
                                 : g.radius_m * cam.intrinsics.fx;
    acquisition::ExclusionRules rules;
    rules.edge_margin_px = 1;
    const std::vector<acquisition::SpherePixel> pixels =
        acquisition::sphere_pixels(cam, g, rules, nullptr);
    ASSERT_GT(pixels.size(), 500u);
    const Vec3d axis = acquisition::lathe_axis_world(state.tilt_rad, state.spin_rad);
    const Vec3d light = brdf::arm_direction(state.light_arm_rad);
    std::size_t compared = 0;
    for (const acquisition::SpherePixel& p : pixels) {
        const sim::SpherePixelTruth& t = truth[static_cast<std::size_t>(p.y) * size + p.x];
        ASSERT_TRUE(t.hit) << p.x << "," << p.y;
        const Vec3d tangent = acquisition::lathe_tangent(p.normal, axis, 5 * kDeg);
        if (tangent == Vec3d::Zero()) {
            continue;
        }
        const auto [wi, wo] = acquisition::local_directions(p, tangent, light);
        EXPECT_LT((wi - t.wi).norm(), 1e-6) << "pixel " << p.x << "," << p.y;
        EXPECT_LT((wo - t.wo).norm(), 1e-6) << "pixel " << p.x << "," << p.y;
        ++compared;
    }
    EXPECT_GT(compared, pixels.size() * 9 / 10);
}

TEST(TurnedSphere, RendererAndAcquisitionAgreeOnEveryPixelsFrame) {
    for (const bool perspective : {false, true}) {
        expect_same_frames(perspective, 0, 0, 50, 0);
        expect_same_frames(perspective, 0, 30, -70, 0);
        expect_same_frames(perspective, 0, -120, 100, 0);
        expect_same_frames(perspective, 20, 75, 40, 0);
        expect_same_frames(perspective, 0, 45, 80, 25);
    }
}

brdf::ModelD ggx(double ax, double ay, double orientation_deg) {
    brdf::ModelD m;
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kGgx;
    l.anisotropic = ax != ay;
    l.alpha_x = ax;
    l.alpha_y = ay;
    l.orientation_deg = orientation_deg;
    l.shadowing = brdf::Shadowing::kSmithCorrelated;
    l.fresnel.type = brdf::FresnelType::kNone;
    l.scale = brdf::Rgbd::Constant(1);
    m.lobes.push_back(l);
    return m;
}

double max_difference(const cv::Mat& a, const cv::Mat& b) {
    double worst = 0;
    cv::minMaxLoc(cv::abs(a - b), nullptr, &worst);
    return worst;
}

TEST(TurnedSphere, SpinTurnsAnAnisotropicImageAndLeavesAnIsotropicOne) {
    const int size = 48;
    sim::SphereImaging im;
    im.camera = tools::to_sphere_camera(acquisition::default_image_camera(size, false, 0.02));
    im.radius_m = 0.02;
    im.supersample = 1;
    const sim::RadianceFn render = sim::sphere_renderer(im);
    const devices::Roi full{0, 0, size, size};
    const auto iso = brdf::make_analytic_brdf(ggx(0.2, 0.2, 0));
    const auto aniso = brdf::make_analytic_brdf(ggx(0.08, 0.4, 0));
    // The aniso lobe turned by 90 degrees (alpha_x and alpha_y swapped): the same material.
    const auto swapped = brdf::make_analytic_brdf(ggx(0.4, 0.08, 90));
    sim::SceneState s0;
    s0.light_arm_rad = 50 * kDeg;
    double peak = 0;
    const cv::Mat a0 = render(*aniso, s0, size, size, full);
    cv::minMaxLoc(a0, nullptr, &peak);
    ASSERT_GT(peak, 0);
    EXPECT_LT(max_difference(a0, render(*swapped, s0, size, size, full)), 1e-5 * peak);
    const cv::Mat i0 = render(*iso, s0, size, size, full);
    double iso_peak = 0;
    cv::minMaxLoc(i0, nullptr, &iso_peak);
    for (const double spin_deg : {30.0, 90.0, -45.0}) {
        sim::SceneState s = s0;
        s.spin_rad = spin_deg * kDeg;
        EXPECT_GT(max_difference(a0, render(*aniso, s, size, size, full)), 0.1 * peak)
            << "spin " << spin_deg;
        EXPECT_LT(max_difference(i0, render(*iso, s, size, size, full)), 1e-5 * iso_peak)
            << "spin " << spin_deg;
    }
    // Half a turn of spin reverses every tangent: a centrally symmetric lobe looks the same.
    sim::SceneState half = s0;
    half.spin_rad = kPi;
    EXPECT_LT(max_difference(a0, render(*aniso, half, size, size, full)), 1e-5 * peak);
}

}  // namespace
}  // namespace gonio
