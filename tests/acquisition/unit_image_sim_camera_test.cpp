// The image-mode virtual rig's camera against acquisition's camera model: the simulator turns the
// camera at detector arm 0 about world z (sim::sphere_camera_at_arm), acquisition builds the
// camera on the arm from the arm direction (camera_on_detector_arm); both must give the same pose.
// The sphere renderer plugged into the GigE camera reads the light and detector arm angles from
// the rig state: a Lambertian sphere's centre pixel against the closed form, the image's invariance
// under turning both arms together, and the ROI crop.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "embedded_rig.h"
#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/placement.h"
#include "gonio/acquisition/image/sphere_geometry.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/rig_geometry.h"
#include "gonio/sim/sphere_imaging.h"

namespace gonio {
namespace {

using brdf::kPi;

/// The conversion `gonio acquire --mode image` uses (distortion included).
sim::SphereCamera as_sim(const acquisition::CameraModel& c) {
    return tools::to_sphere_camera(c);
}

TEST(ImageSimCamera, ConversionKeepsTheDistortion) {
    acquisition::CameraModel c = acquisition::default_image_camera(64, true, 0.02);
    c.intrinsics.distortion = {0.1, -0.02, 0.001, 0.002, 0.003};
    const sim::SphereCamera s = as_sim(c);
    for (std::size_t i = 0; i < c.intrinsics.distortion.size(); ++i) {
        EXPECT_EQ(s.distortion[i], c.intrinsics.distortion[i]) << "coefficient " << i;
    }
    EXPECT_EQ(s.fx, c.intrinsics.fx);
    EXPECT_EQ(s.cy, c.intrinsics.cy);
    EXPECT_EQ(s.projection, sim::SphereProjection::kPerspective);
}

TEST(ImageSimCamera, PoseOnTheDetectorArmMatchesTheAcquisitionModel) {
    for (const bool perspective : {false, true}) {
        const acquisition::CameraModel zero =
            acquisition::default_image_camera(128, perspective, 0.02);
        for (const double arm_deg : {-170.0, -90.0, -33.0, 0.0, 12.5, 45.0, 90.0, 135.0, 180.0}) {
            const double a = arm_deg * kPi / 180;
            const acquisition::CameraModel want =
                acquisition::camera_on_detector_arm(zero.intrinsics, zero.projection, a, 0.5);
            const sim::SphereCamera got = sim::sphere_camera_at_arm(as_sim(zero), a);
            EXPECT_LT((got.rotation - want.rotation).cwiseAbs().maxCoeff(), 1e-12)
                << "arm " << arm_deg << " deg";
            EXPECT_LT((got.translation - want.translation).cwiseAbs().maxCoeff(), 1e-12)
                << "arm " << arm_deg << " deg";
            // The optical axis points from the arm toward the sample: -arm_direction(a).
            const brdf::Vec3d axis = got.rotation.row(2).transpose();
            EXPECT_LT((axis + brdf::Vec3d(std::cos(a), std::sin(a), 0)).norm(), 1e-12);
        }
    }
}

sim::SphereImaging imaging(int size) {
    sim::SphereImaging im;
    im.camera = as_sim(acquisition::default_image_camera(size, false, 0.02));
    im.radius_m = 0.02;
    im.supersample = 1;
    return im;
}

std::shared_ptr<const brdf::Brdf> lambert(double rho) {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd::Constant(rho);
    return brdf::make_analytic_brdf(m);
}

TEST(ImageSimCamera, CentrePixelOfALambertianSphereFollowsBothArms) {
    // Telecentric camera: the centre pixel sees the point of the sphere whose normal points at the
    // camera, so theta_i is the angle between the arms and L = (rho / pi) E cos(light - detector).
    const int size = 65;  // odd: a pixel centre on the optical axis
    const sim::RadianceFn render = sim::sphere_renderer(imaging(size));
    const auto f = lambert(0.6);
    const devices::Roi full{0, 0, size, size};
    for (const double det_deg : {0.0, 30.0, -75.0}) {
        for (const double rel_deg : {0.0, 20.0, -50.0, 80.0, 120.0}) {
            sim::SceneState s;
            s.detector_arm_rad = det_deg * kPi / 180;
            s.light_arm_rad = (det_deg + rel_deg) * kPi / 180;
            s.irradiance_w_m2 = 2.5;
            s.filter = brdf::Rgbd(1, 0, 0);
            const cv::Mat img = render(*f, s, size, size, full);
            ASSERT_EQ(img.rows, size);
            ASSERT_EQ(img.cols, size);
            const double want = 0.6 / kPi * 2.5 * std::max(0.0, std::cos(rel_deg * kPi / 180));
            EXPECT_NEAR(img.at<float>(size / 2, size / 2), want, 1e-6 * (1 + want))
                << "detector " << det_deg << ", light " << det_deg + rel_deg << " deg";
            // Shutter closed: black.
            s.shutter_open = false;
            EXPECT_EQ(cv::countNonZero(render(*f, s, size, size, full)), 0);
        }
    }
}

TEST(ImageSimCamera, TurningBothArmsTogetherLeavesAnIsotropicSphereUnchanged) {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd(0.3, 0.2, 0.1);
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.2;
    l.shadowing = brdf::Shadowing::kSmithCorrelated;
    l.fresnel.type = brdf::FresnelType::kNone;
    l.scale = brdf::Rgbd::Constant(0.2);
    m.lobes.push_back(l);
    const auto f = brdf::make_analytic_brdf(m);
    const int size = 48;
    const sim::RadianceFn render = sim::sphere_renderer(imaging(size));
    const devices::Roi full{0, 0, size, size};
    sim::SceneState s0;
    s0.light_arm_rad = 40 * kPi / 180;
    const cv::Mat ref = render(*f, s0, size, size, full);
    ASSERT_GT(cv::countNonZero(ref), size * size / 4);
    double peak = 0;
    cv::minMaxLoc(ref, nullptr, &peak);
    for (const double turn_deg : {25.0, -60.0, 170.0}) {
        sim::SceneState s = s0;
        s.light_arm_rad += turn_deg * kPi / 180;
        s.detector_arm_rad += turn_deg * kPi / 180;
        const cv::Mat img = render(*f, s, size, size, full);
        double worst = 0;
        cv::minMaxLoc(cv::abs(img - ref), nullptr, &worst);
        EXPECT_LT(worst, 1e-5 * peak) << "turn " << turn_deg << " deg";
    }
}

TEST(ImageSimCamera, RegionOfInterestIsACropOfTheFullImage) {
    const int size = 40;
    const sim::RadianceFn render = sim::sphere_renderer(imaging(size));
    const auto f = lambert(0.8);
    sim::SceneState s;
    s.light_arm_rad = 0.3;
    const cv::Mat full = render(*f, s, size, size, devices::Roi{0, 0, size, size});
    const devices::Roi roi{7, 11, 20, 13};
    const cv::Mat part = render(*f, s, size, size, roi);
    ASSERT_EQ(part.cols, roi.width);
    ASSERT_EQ(part.rows, roi.height);
    EXPECT_EQ(cv::norm(part, full(cv::Rect(roi.x, roi.y, roi.width, roi.height)), cv::NORM_INF),
              0.0);
    // A region reaching past the sensor's edge is black there.
    const cv::Mat edge = render(*f, s, size, size, devices::Roi{30, 30, 16, 16});
    EXPECT_EQ(cv::norm(edge(cv::Rect(0, 0, 10, 10)), full(cv::Rect(30, 30, 10, 10)), cv::NORM_INF),
              0.0);
    EXPECT_EQ(cv::countNonZero(edge(cv::Rect(10, 0, 6, 16))), 0);
}

/// A zoomed placement as both sides see it: the virtual camera renders the scene through
/// sim::zoomed_camera, acquisition maps pixels to normals through placement_camera and
/// placement_sphere. Every pixel acquisition keeps must hit the rendered sphere at the same normal
/// and with the same local directions; the principal point sees the point of the sphere at the
/// offset from the axis (closed form n = (ox, oy, -sqrt(R^2 - ox^2 - oy^2)) / R in the camera
/// frame, for a telecentric camera); the sphere's outline is magnified.
void expect_same_zoomed_pixels(bool perspective, double detector_deg) {
    const int size = 64;
    const double kDeg = kPi / 180;
    const acquisition::CameraModel at_zero =
        acquisition::default_image_camera(size, perspective, 0.02);
    const acquisition::CameraModel wide = acquisition::camera_on_detector_arm(
        at_zero.intrinsics, at_zero.projection, detector_deg * kDeg, 0.5);
    acquisition::Placement p;
    p.magnification = 6;
    p.offset_m = {0.009, -0.004};
    const acquisition::CameraModel cam = acquisition::placement_camera(wide, p);

    sim::SphereImaging im;
    im.camera = tools::to_sphere_camera(at_zero);
    im.radius_m = 0.02;
    im.supersample = 1;
    im.placements.push_back({p.magnification, p.offset_m});
    sim::SceneState state;
    state.detector_arm_rad = detector_deg * kDeg;
    state.light_arm_rad = (detector_deg + 40) * kDeg;
    state.placement = 1;
    const std::vector<sim::SpherePixelTruth> truth =
        sim::sphere_truth(sim::sphere_scene(im, state));

    acquisition::SphereGeometry wide_sphere;
    wide_sphere.radius_m = 0.02;
    const Eigen::Vector2d c = wide.project(wide_sphere.centre);
    wide_sphere.silhouette.cx = c.x();
    wide_sphere.silhouette.cy = c.y();
    wide_sphere.silhouette.r = perspective ? wide.intrinsics.fx * std::tan(std::asin(0.02 / 0.5))
                                           : 0.02 * wide.intrinsics.fx;
    const acquisition::SphereGeometry g =
        acquisition::placement_sphere(wide_sphere, cam, p.magnification);
    EXPECT_NEAR(g.silhouette.r, 6 * wide_sphere.silhouette.r, 1e-9);
    const acquisition::ExclusionRules rules =
        acquisition::placement_rules(acquisition::ExclusionRules{}, p.magnification);
    EXPECT_EQ(rules.edge_margin_px, 12);
    const std::vector<acquisition::SpherePixel> pixels =
        acquisition::sphere_pixels(cam, g, rules, nullptr);
    // The patch fills the frame: every pixel is on the sphere, within 80 degrees of the view.
    ASSERT_GT(pixels.size(), static_cast<std::size_t>(size * size * 9 / 10));
    const brdf::Vec3d light = brdf::arm_direction(state.light_arm_rad);
    for (const acquisition::SpherePixel& px : pixels) {
        const sim::SpherePixelTruth& t = truth[static_cast<std::size_t>(px.y) * size + px.x];
        ASSERT_TRUE(t.hit) << px.x << "," << px.y;
        EXPECT_LT((px.normal - t.normal_world).norm(), 1e-9) << "pixel " << px.x << "," << px.y;
        const auto [wi, wo] = acquisition::local_directions(px, light);
        // The renderer's tangent is its own reference: compare what an isotropic BRDF sees.
        EXPECT_NEAR(wi.z(), t.wi.z(), 1e-9);
        EXPECT_NEAR(wo.z(), t.wo.z(), 1e-9);
        EXPECT_NEAR(wi.dot(wo), t.wi.dot(t.wo), 1e-9);
    }
    if (!perspective) {
        const Eigen::Vector3d n_cam(
            0.009 / 0.02, -0.004 / 0.02, -std::sqrt(1 - (0.45 * 0.45 + 0.2 * 0.2)));
        const brdf::Vec3d want = cam.rotation.transpose() * n_cam;
        // The pixel centres straddle the principal point (63 / 2): the mean of the four.
        brdf::Vec3d got = brdf::Vec3d::Zero();
        for (const int x : {31, 32}) {
            for (const int y : {31, 32}) {
                got += truth[static_cast<std::size_t>(y) * size + x].normal_world;
            }
        }
        EXPECT_LT((got.normalized() - want).norm(), 1e-3) << "detector " << detector_deg;
    }
}

TEST(ImageSimCamera, ZoomedPlacementMapsPixelsToTheRenderersNormals) {
    for (const bool perspective : {false, true}) {
        for (const double detector_deg : {0.0, 35.0, -120.0}) {
            SCOPED_TRACE(std::string(perspective ? "perspective" : "telecentric") + ", detector " +
                         std::to_string(detector_deg));
            expect_same_zoomed_pixels(perspective, detector_deg);
        }
    }
}

TEST(ImageSimCamera, PlacementSeesTheHighlightWhereTheHalfVectorMeetsTheSphere) {
    // Telecentric camera on the detector arm at 0: the highlight of a light at arm angle a lies
    // sin(a / 2) sphere radii from the centre along the image's x axis.
    const acquisition::CameraModel wide = acquisition::default_image_camera(100, false, 0.02);
    acquisition::SphereGeometry g;
    g.radius_m = 0.02;
    g.silhouette = {49.5, 49.5, 40};
    acquisition::Placement p;
    p.magnification = 8;
    p.offset_m = {0.02 * std::sin(30 * kPi / 180), 0};  // the highlight of a = 60 deg
    const acquisition::CameraModel cam = acquisition::placement_camera(wide, p);
    const acquisition::SphereGeometry z = acquisition::placement_sphere(g, cam, 8);
    // Field: 100 px / (8 * 40 px per radius) = 0.3125 radii across.
    for (const double a_deg : {60.0, 55.0, 65.0}) {
        EXPECT_TRUE(
            acquisition::placement_sees_highlight(cam, z, brdf::arm_direction(a_deg * kPi / 180)))
            << a_deg;
    }
    for (const double a_deg : {-60.0, 20.0, 100.0, 180.0}) {
        EXPECT_FALSE(
            acquisition::placement_sees_highlight(cam, z, brdf::arm_direction(a_deg * kPi / 180)))
            << a_deg;
    }
}

}  // namespace
}  // namespace gonio
