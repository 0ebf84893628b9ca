// The image-mode virtual rig's camera against acquisition's camera model: the simulator turns the
// camera at detector arm 0 about world z (sim::sphere_camera_at_arm), acquisition builds the
// camera on the arm from the arm direction (camera_on_detector_arm); both must give the same pose.
// The sphere renderer plugged into the GigE camera reads the light and detector arm angles from
// the rig state: a Lambertian sphere's centre pixel against the closed form, the image's invariance
// under turning both arms together, and the ROI crop.

#include <gtest/gtest.h>

#include <cmath>

#include "embedded_rig.h"
#include "gonio/acquisition/camera_model.h"
#include "gonio/brdf/analytic_brdf.h"
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

}  // namespace
}  // namespace gonio
