// The sensor model's statistics and the renderer's geometry against closed forms.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "gonio/sim/camera_render.h"
#include "gonio/sim/sensor_model.h"

namespace {

using gonio::devices::PixelFormat;
using gonio::sim::ExposureSettings;
using gonio::sim::SensorModel;
using gonio::sim::SensorParams;

class ConstantBrdf : public gonio::brdf::Brdf {
  public:
    gonio::brdf::Rgbd eval(const gonio::brdf::Vec3d& wi,
                           const gonio::brdf::Vec3d& wo) const override {
        if (wi.z() <= 0 || wo.z() <= 0) {
            return gonio::brdf::Rgbd::Zero();
        }
        return gonio::brdf::Rgbd(0.1, 0.2, 0.3);
    }
    bool isotropic() const override { return true; }
    std::string describe() const override { return "constant"; }
};

struct Moments {
    double mean = 0, var = 0;
};

Moments moments(const cv::Mat& m) {
    cv::Scalar mean, sd;
    cv::meanStdDev(m, mean, sd);
    const double n = static_cast<double>(m.total());
    return {mean[0], sd[0] * sd[0] * n / (n - 1)};
}

class SensorStats : public ::testing::TestWithParam<std::tuple<PixelFormat, double, double>> {};

TEST_P(SensorStats, MeanAndVarianceMatchTheEmvaModel) {
    const auto [format, radiance, gain] = GetParam();
    SensorParams p;
    p.width = 256;
    p.height = 256;
    p.seed = 12345;
    SensorModel s(p);
    ExposureSettings e{2000, gain, format};
    const cv::Mat L(256, 256, CV_32F, cv::Scalar(radiance));
    const cv::Mat counts = s.expose(L, e);
    const Moments m = moments(counts);
    const double n = static_cast<double>(counts.total());
    // Independent closed form (EMVA 1288): mu = black + K^-1 (R L t + D t).
    const int bits = format == PixelFormat::kMono8 ? 8 : format == PixelFormat::kMono12 ? 12 : 16;
    const double k = gain / (p.e_per_count16 * std::ldexp(1.0, 16 - bits));
    const double t = 2000e-6;
    const double mu_e = p.responsivity_e_per_s * radiance * t + p.dark_current_e_per_s * t;
    const double mu = p.black_level16 * std::ldexp(1.0, bits - 16) + k * mu_e;
    const double var = k * k * (mu_e + p.read_noise_e * p.read_noise_e) + 1.0 / 12.0;
    EXPECT_DOUBLE_EQ(s.mean_counts(radiance, e), mu);
    EXPECT_DOUBLE_EQ(s.variance_counts(radiance, e), var);
    EXPECT_NEAR(m.mean, mu, 5 * std::sqrt(var / n)) << "seed 12345";
    // Sample variance: relative standard error sqrt(2 / (n - 1)) for a near-normal population.
    EXPECT_NEAR(m.var / var, 1.0, 5 * std::sqrt(2.0 / (n - 1)) + 0.02) << "seed 12345";
}

INSTANTIATE_TEST_SUITE_P(Grid,
                         SensorStats,
                         ::testing::Values(std::make_tuple(PixelFormat::kMono16, 0.0, 1.0),
                                           std::make_tuple(PixelFormat::kMono16, 0.05, 1.0),
                                           std::make_tuple(PixelFormat::kMono16, 0.5, 2.0),
                                           std::make_tuple(PixelFormat::kMono12, 0.5, 1.0),
                                           std::make_tuple(PixelFormat::kMono12, 0.2, 4.0)));

TEST(SensorModel, SaturatesAtTheBitDepthAndFullWell) {
    SensorParams p;
    p.seed = 3;
    SensorModel s(p);
    const cv::Mat L(16, 16, CV_32F, cv::Scalar(1e6));
    for (PixelFormat f : {PixelFormat::kMono8, PixelFormat::kMono12, PixelFormat::kMono16}) {
        const cv::Mat c = s.expose(L, {10000, 1, f});
        double lo, hi;
        cv::minMaxLoc(c, &lo, &hi);
        EXPECT_LE(hi, s.saturation_level(f));
        // Whichever clips first: the full well (then read noise) or the converter's top code.
        const double k = 1 / s.e_per_count({10000, 1, f});
        const double full_well = s.black_level(f) + p.full_well_e * k;
        const double expected = std::min(s.saturation_level(f), full_well);
        EXPECT_NEAR(lo, expected, 5 * p.read_noise_e * k + 1);
    }
}

TEST(SensorModel, SameSeedSameFrame) {
    SensorParams p;
    p.seed = 99;
    SensorModel a(p), b(p);
    const cv::Mat L(32, 32, CV_32F, cv::Scalar(0.2));
    const cv::Mat fa = a.expose(L, {}), fb = b.expose(L, {});
    EXPECT_EQ(cv::norm(fa, fb, cv::NORM_INF), 0.0);
    const cv::Mat fc = a.expose(L, {});
    EXPECT_GT(cv::norm(fa, fc, cv::NORM_INF), 0.0);
}

TEST(CameraRender, PointPatchRadianceIsFilterDotBrdfTimesIrradianceTimesCosine) {
    ConstantBrdf f;
    gonio::sim::SceneState s;
    const double theta_i = 1.0;
    s.wi = {std::sin(theta_i), 0, std::cos(theta_i)};
    s.wo = {0, std::sin(0.4), std::cos(0.4)};
    s.irradiance_w_m2 = 3.0;
    s.filter = {1, 0, 0};
    const cv::Mat L = gonio::sim::render_scene(f, s, 100, 80, {0, 0, 100, 80});
    EXPECT_NEAR(L.at<float>(40, 50), 0.1 * 3.0 * std::cos(theta_i), 1e-6);
    EXPECT_EQ(L.at<float>(0, 0), 0.0f);  // outside the field stop
    s.filter = {1.0 / 3, 1.0 / 3, 1.0 / 3};
    s.wi = {std::sin(2.0), 0, std::cos(2.0)};  // light below the horizon
    EXPECT_EQ(gonio::sim::render_scene(f, s, 100, 80, {0, 0, 100, 80}).at<float>(40, 50), 0.0f);
    s.wi = {0, 0, 1};
    s.shutter_open = false;
    EXPECT_EQ(cv::countNonZero(gonio::sim::render_scene(f, s, 100, 80, {0, 0, 100, 80})), 0);
}

TEST(CameraRender, SphereCosineFollowsTheSurfaceNormal) {
    ConstantBrdf f;
    gonio::sim::SceneState s;
    s.shape = gonio::sim::SampleShape::kSphere;
    s.wi = {0, 0, 1};
    s.wo = {0, 0, 1};
    s.filter = {0, 1, 0};
    s.sphere_radius_fraction = 1.0;
    const int w = 201, h = 201;
    const cv::Mat L = gonio::sim::render_scene(f, s, w, h, {0, 0, w, h});
    const double radius = 100.5;
    for (int x : {100, 130, 160, 190}) {
        // Light and camera along the view axis: cos(theta_i) = sqrt(1 - u^2) at offset u.
        const double u = (x + 0.5 - 100.5) / radius;
        EXPECT_NEAR(L.at<float>(100, x), 0.2 * std::sqrt(1 - u * u), 1e-5) << "x = " << x;
    }
    EXPECT_EQ(L.at<float>(0, 0), 0.0f);
}

}  // namespace
