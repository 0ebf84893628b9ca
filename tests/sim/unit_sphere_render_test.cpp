// The simulated sphere: Lambertian radiance against the closed form at every pixel, perspective
// silhouette size, dark frames, and frame counts against the sensor model's own statistics.

#include <gtest/gtest.h>

#include <cmath>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/sim/sphere_render.h"

namespace gonio::sim {
namespace {

using brdf::kPi;
using brdf::Vec3d;

/// Camera on the world +x axis looking at the origin; image x = world +y, image y = world -z.
SphereCamera camera_on_x(SphereProjection proj, int size, double f, double distance) {
    SphereCamera c;
    c.projection = proj;
    c.width = c.height = size;
    c.fx = c.fy = f;
    c.cx = c.cy = (size - 1) / 2.0;
    c.rotation << 0, 1, 0, 0, 0, -1, -1, 0, 0;
    c.translation = -c.rotation * Vec3d(distance, 0, 0);
    return c;
}

std::shared_ptr<brdf::Brdf> lambert(double rho) {
    brdf::ModelD m;
    m.diffuse = brdf::Rgbd::Constant(rho);
    return brdf::make_analytic_brdf(m);
}

TEST(SphereRender, LambertRadianceMatchesClosedFormAtEveryPixel) {
    SphereScene s;
    s.camera = camera_on_x(SphereProjection::kOrthographic, 64, 1500, 1.0);
    s.radius_m = 0.02;  // 30 px
    s.light_world = Vec3d(std::cos(0.7), std::sin(0.7), 0);
    s.irradiance_w_m2 = 2.5;
    s.filter = brdf::Rgbd(1, 0, 0);
    s.supersample = 1;
    const auto f = lambert(0.6);
    const cv::Mat img = render_sphere_radiance(*f, s);
    int on = 0;
    for (int y = 0; y < 64; ++y) {
        for (int x = 0; x < 64; ++x) {
            // Normal of the visible hemisphere in world coordinates: image x -> +y, image y -> -z,
            // toward the camera +x.
            const double u = (x - s.camera.cx) / 30.0;
            const double v = (y - s.camera.cy) / 30.0;
            const double rho2 = u * u + v * v;
            double expected = 0;
            if (rho2 < 1) {
                ++on;
                const Vec3d n(std::sqrt(1 - rho2), u, -v);
                // L = (rho / pi) E max(0, n . l).
                expected = 0.6 / kPi * 2.5 * std::max(0.0, n.dot(s.light_world));
            }
            ASSERT_NEAR(img.at<float>(y, x), expected, 1e-5 * std::max(1.0, expected))
                << "pixel " << x << "," << y;
        }
    }
    EXPECT_GT(on, 2500);
}

TEST(SphereRender, RowTilesRenderEveryRowOfALargeFrame) {
    // 1050 x 1100 px at one ray per pixel: the rays are traced in tiles of whole rows (five here,
    // the last one short); every pixel must be rendered once, by its own ray.
    SphereScene s;
    s.camera = camera_on_x(SphereProjection::kOrthographic, 1050, 25000, 1.0);
    s.camera.height = 1100;
    s.camera.cy = (1100 - 1) / 2.0;
    s.radius_m = 0.02;  // 500 px
    s.light_world = Vec3d(std::cos(0.4), std::sin(0.4), 0);
    s.filter = brdf::Rgbd(1, 0, 0);
    s.supersample = 1;
    const auto f = lambert(0.5);
    const cv::Mat img = render_sphere_radiance(*f, s);
    ASSERT_EQ(img.rows, 1100);
    double worst = 0;
    long on = 0;
    for (int y = 0; y < img.rows; ++y) {
        for (int x = 0; x < img.cols; ++x) {
            const double u = (x - s.camera.cx) / 500.0;
            const double v = (y - s.camera.cy) / 500.0;
            const double rho2 = u * u + v * v;
            double expected = 0;
            if (rho2 < 1) {
                ++on;
                const Vec3d n(std::sqrt(1 - rho2), u, -v);
                expected = 0.5 / kPi * std::max(0.0, n.dot(s.light_world));
            }
            worst = std::max(worst, std::abs(img.at<float>(y, x) - expected));
        }
    }
    EXPECT_LT(worst, 1e-6);
    // pi 500^2 pixels on the sphere.
    EXPECT_NEAR(static_cast<double>(on), kPi * 500 * 500, 2 * kPi * 500);
}

TEST(SphereRender, TruthDirectionsKeepTheirAngle) {
    SphereScene s;
    s.camera = camera_on_x(SphereProjection::kOrthographic, 48, 1000, 1.0);
    s.light_world = Vec3d(std::cos(1.2), std::sin(1.2), 0);
    const std::vector<SpherePixelTruth> t = sphere_truth(s);
    int hits = 0;
    for (const SpherePixelTruth& p : t) {
        if (!p.hit) {
            continue;
        }
        ++hits;
        // wi . wo is the cosine of the angle between the light and the camera, 1.2 rad.
        EXPECT_NEAR(p.wi.dot(p.wo), std::cos(1.2), 1e-12);
        EXPECT_NEAR(p.wi.z(), p.normal_world.dot(s.light_world), 1e-12);
        EXPECT_GT(p.wo.z(), 0.0);
    }
    EXPECT_GT(hits, 1000);
}

TEST(SphereRender, PerspectiveSilhouetteHasTheApparentRadius) {
    SphereScene s;
    s.camera = camera_on_x(SphereProjection::kPerspective, 101, 2000, 0.5);
    s.radius_m = 0.01;
    const std::vector<SpherePixelTruth> t = sphere_truth(s);
    // On the optical axis the outline is a circle of radius f tan(asin(R / D)) = 40.0 px.
    const double r = 2000 * std::tan(std::asin(0.01 / 0.5));
    int hits = 0;
    int expected = 0;
    for (int y = 0; y < 101; ++y) {
        for (int x = 0; x < 101; ++x) {
            hits += t[y * 101 + x].hit ? 1 : 0;
            expected += std::hypot(x - 50.0, y - 50.0) < r ? 1 : 0;
        }
    }
    // Pixel centres within 1e-3 px of the outline could go either way.
    EXPECT_NEAR(hits, expected, 4);
}

TEST(SphereRender, ShutterClosedIsDark) {
    SphereScene s;
    s.camera = camera_on_x(SphereProjection::kOrthographic, 32, 1000, 1.0);
    s.shutter_open = false;
    const cv::Mat img = render_sphere_radiance(*lambert(0.9), s);
    EXPECT_EQ(cv::countNonZero(img), 0);
}

TEST(SphereRender, FrameCountsFollowTheSensorModel) {
    SphereScene s;
    s.camera = camera_on_x(SphereProjection::kOrthographic, 96, 2000, 1.0);
    s.radius_m = 0.02;
    s.light_world = Vec3d(std::cos(0.3), std::sin(0.3), 0);
    s.filter = brdf::Rgbd(0, 1, 0);
    SensorParams p;
    p.width = p.height = 96;
    p.seed = 31;
    SensorModel sensor(p);
    ExposureSettings e;
    e.exposure_us = 5000;
    const auto f = lambert(0.8);
    const devices::Frame frame = render_sphere_frame(*f, s, sensor, e);
    ASSERT_EQ(frame.image.type(), CV_16U);
    EXPECT_DOUBLE_EQ(frame.exposure_us, 5000);
    EXPECT_DOUBLE_EQ(frame.black_level, sensor.black_level(e.format));
    const cv::Mat radiance = render_sphere_radiance(*f, s);
    double sum_z = 0;
    double sum_z2 = 0;
    int n = 0;
    for (int y = 0; y < 96; ++y) {
        for (int x = 0; x < 96; ++x) {
            const double l = radiance.at<float>(y, x);
            const double z = (frame.image.at<std::uint16_t>(y, x) - sensor.mean_counts(l, e)) /
                             std::sqrt(sensor.variance_counts(l, e));
            sum_z += z;
            sum_z2 += z * z;
            ++n;
        }
    }
    const double mean = sum_z / n;
    const double var = sum_z2 / n - mean * mean;
    // n = 9216 standardised counts: mean within 4 / sqrt(n), variance within 10%.
    EXPECT_NEAR(mean, 0.0, 4.0 / std::sqrt(n)) << "seed " << p.seed;
    EXPECT_NEAR(var, 1.0, 0.1) << "seed " << p.seed;
}

}  // namespace
}  // namespace gonio::sim
