// The sensor model's statistics and the renderer's geometry against closed forms.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <map>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>

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

// The sensor draws a run of equal radiance (a patch, the background) from its tabulated count
// distribution and short runs (a sphere's shading) pixel by pixel; both must follow the model.
enum class Runs { kLong, kShort };

// A frame of radiance L: uniform (one run per row), or alternating between L and the next float
// above it (runs of one pixel; the two means differ by 6e-8 relative).
cv::Mat radiance_frame(int w, int h, double radiance, Runs runs) {
    cv::Mat m(h, w, CV_32F, cv::Scalar(radiance));
    if (runs == Runs::kShort) {
        const float up = std::nextafter(static_cast<float>(radiance), 1e30f);
        for (int y = 0; y < h; ++y) {
            for (int x = 1; x < w; x += 2) {
                m.at<float>(y, x) = up;
            }
        }
    }
    return m;
}

class SensorStats : public ::testing::TestWithParam<std::tuple<PixelFormat, double, double, Runs>> {
};

TEST_P(SensorStats, MeanAndVarianceMatchTheEmvaModel) {
    const auto [format, radiance, gain, runs] = GetParam();
    SensorParams p;
    p.width = 512;
    p.height = 512;
    p.seed = 12345;
    SensorModel s(p);
    ExposureSettings e{2000, gain, format};
    const cv::Mat counts = s.expose(radiance_frame(512, 512, radiance, runs), e);
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
    // Sample variance: its variance is (kappa_4 + 2 sigma^4) / n, with the fourth cumulant
    // kappa_4 = k^4 mu_e of the Poisson shot noise (normal read noise and the rounding's
    // -1/120 add nothing and a little less).
    const double kappa4 = std::pow(k, 4) * mu_e;
    EXPECT_NEAR(m.var, var, 5 * std::sqrt((kappa4 + 2 * var * var) / n)) << "seed 12345";
}

std::string grid_name(
    const ::testing::TestParamInfo<std::tuple<PixelFormat, double, double, Runs>>& info) {
    const PixelFormat f = std::get<0>(info.param);
    const char* name = f == PixelFormat::kMono8    ? "Mono8"
                       : f == PixelFormat::kMono12 ? "Mono12"
                                                   : "Mono16";
    return std::string(name) + "_" + std::to_string(info.index / 2) +
           (std::get<3>(info.param) == Runs::kLong ? "_long_runs" : "_short_runs");
}

// (format, radiance, gain): dark frame, Poisson regime (mu_e 0.05 and 20), normal regime.
const std::tuple<PixelFormat, double, double> kGrid[] = {
    {PixelFormat::kMono16, 0.0, 1.0},
    {PixelFormat::kMono16, 0.002, 1.0},
    {PixelFormat::kMono16, 0.05, 1.0},
    {PixelFormat::kMono16, 0.5, 2.0},
    {PixelFormat::kMono12, 0.5, 1.0},
    {PixelFormat::kMono12, 0.2, 4.0},
    {PixelFormat::kMono8, 0.1, 8.0},
};

std::vector<std::tuple<PixelFormat, double, double, Runs>> grid() {
    std::vector<std::tuple<PixelFormat, double, double, Runs>> g;
    for (const auto& [f, radiance, gain] : kGrid) {
        for (Runs r : {Runs::kLong, Runs::kShort}) {
            g.emplace_back(f, radiance, gain, r);
        }
    }
    return g;
}

INSTANTIATE_TEST_SUITE_P(Grid, SensorStats, ::testing::ValuesIn(grid()), grid_name);

// Chi-square statistic of observed code counts against expected probabilities, with every code of
// expected count below 20 pooled into one bin; returns the statistic and its degrees of freedom.
std::pair<double, int> chi_square(const std::map<int, long>& observed,
                                  const std::function<double(int)>& pmf,
                                  int lo,
                                  int hi,
                                  double n) {
    double chi2 = 0, pooled_expected = 0;
    long pooled_observed = 0;
    int bins = 0;
    for (int c = lo; c <= hi; ++c) {
        const double expected = n * pmf(c);
        const auto it = observed.find(c);
        const long o = it == observed.end() ? 0 : it->second;
        if (expected < 20) {
            pooled_expected += expected;
            pooled_observed += o;
            continue;
        }
        chi2 += (o - expected) * (o - expected) / expected;
        ++bins;
    }
    // Codes outside [lo, hi] join the pool.
    for (const auto& [c, o] : observed) {
        if (c < lo || c > hi) {
            pooled_observed += o;
        }
    }
    pooled_expected = n - [&] {
        double inside = 0;
        for (int c = lo; c <= hi; ++c) {
            if (n * pmf(c) >= 20) {
                inside += n * pmf(c);
            }
        }
        return inside;
    }();
    if (pooled_expected > 0) {
        chi2 += (pooled_observed - pooled_expected) * (pooled_observed - pooled_expected) /
                pooled_expected;
        ++bins;
    }
    return {chi2, bins - 1};
}

// Upper 1e-6 quantile of the chi-square distribution (Wilson and Hilferty 1931 cube-root normal
// approximation; z = 4.753 is the standard normal's 1 - 1e-6 quantile).
double chi_square_limit(int dof) {
    const double v = dof, a = 2.0 / (9.0 * v);
    return v * std::pow(1 - a + 4.753 * std::sqrt(a), 3);
}

std::map<int, long> histogram(const cv::Mat& counts) {
    std::map<int, long> h;
    for (auto it = counts.begin<std::uint16_t>(); it != counts.end<std::uint16_t>(); ++it) {
        ++h[*it];
    }
    return h;
}

class SensorShape : public ::testing::TestWithParam<Runs> {};

// Without read noise the counts of a dim pixel are black + k * Poisson(mu_e) exactly: the shot
// noise has the Poisson distribution itself (not its normal limit), in both sampling paths.
TEST_P(SensorShape, DimPixelsFollowThePoissonDistribution) {
    SensorParams p;
    p.read_noise_e = 0;
    p.seed = 777;
    SensorModel s(p);
    const ExposureSettings e{2000, 1, PixelFormat::kMono16};  // k = 2 counts per electron
    const double t = 2000e-6, mu_e = 3.0;
    const double radiance = (mu_e - p.dark_current_e_per_s * t) / (p.responsivity_e_per_s * t);
    const cv::Mat counts = s.expose(radiance_frame(512, 512, radiance, GetParam()), e);
    const double n = static_cast<double>(counts.total());
    const auto h = histogram(counts);
    const int black = static_cast<int>(p.black_level16);
    for (const auto& [c, o] : h) {
        EXPECT_EQ((c - black) % 2, 0) << "code " << c << " is not black + 2 k (" << o << " pixels)";
    }
    const auto pmf = [&](int c) {
        if (c < black || (c - black) % 2 != 0) {
            return 0.0;
        }
        const int k = (c - black) / 2;
        return std::exp(k * std::log(mu_e) - mu_e - std::lgamma(k + 1.0));
    };
    const auto [chi2, dof] = chi_square(h, pmf, black, black + 60, n);
    EXPECT_LT(chi2, chi_square_limit(dof)) << "dof " << dof << ", seed 777";
}

// Far from the full well the counts are the rounded normal black + k N(mu_e, mu_e + read^2):
// P(c) = Phi((c + 1/2 - m) / s) - Phi((c - 1/2 - m) / s), checked where the rounding matters
// (s = 4 codes, Mono12).
TEST_P(SensorShape, BrightPixelsFollowTheRoundedNormal) {
    SensorParams p;
    p.seed = 4242;
    SensorModel s(p);
    const ExposureSettings e{2000, 1, PixelFormat::kMono12};
    const double radiance = 0.1;
    const cv::Mat counts = s.expose(radiance_frame(512, 512, radiance, GetParam()), e);
    const double m = s.mean_counts(radiance, e);
    const double k = 1 / s.e_per_count(e);
    const double t = 2000e-6;
    const double mu_e = p.responsivity_e_per_s * radiance * t + p.dark_current_e_per_s * t;
    const double sd = k * std::sqrt(mu_e + p.read_noise_e * p.read_noise_e);
    const auto phi = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
    const auto pmf = [&](int c) { return phi((c + 0.5 - m) / sd) - phi((c - 0.5 - m) / sd); };
    const auto [chi2, dof] = chi_square(histogram(counts),
                                        pmf,
                                        static_cast<int>(m - 8 * sd),
                                        static_cast<int>(m + 8 * sd),
                                        static_cast<double>(counts.total()));
    EXPECT_GT(dof, 20);
    EXPECT_LT(chi2, chi_square_limit(dof)) << "dof " << dof << ", seed 4242";
}

INSTANTIATE_TEST_SUITE_P(
    Paths, SensorShape, ::testing::Values(Runs::kLong, Runs::kShort), [](const auto& info) {
        return std::string(info.param == Runs::kLong ? "LongRuns" : "ShortRuns");
    });

// Far above the full well every pixel holds the full well, and only the read noise varies.
TEST_P(SensorShape, OverexposedPixelsHoldTheFullWellPlusReadNoise) {
    SensorParams p;
    p.seed = 5;
    SensorModel s(p);
    const ExposureSettings e{2000, 1, PixelFormat::kMono16};
    const cv::Mat counts = s.expose(radiance_frame(512, 512, 100.0, GetParam()), e);
    const Moments mo = moments(counts);
    const double n = static_cast<double>(counts.total());
    const double k = 1 / s.e_per_count(e);
    const double mean = p.black_level16 + k * p.full_well_e;
    const double var = k * k * p.read_noise_e * p.read_noise_e + 1.0 / 12.0;
    ASSERT_LT(mean + 10 * std::sqrt(var), s.saturation_level(e.format));
    EXPECT_NEAR(mo.mean, mean, 5 * std::sqrt(var / n));
    EXPECT_NEAR(mo.var, var, 5 * std::sqrt(2 * var * var / n));
}

// A mean far above the converter's top code: every pixel reads exactly 2^b - 1 (Mono8, gain 8:
// 5000 e- would be 316 counts).
TEST_P(SensorShape, MeanAboveTheTopCodeReadsTheTopCode) {
    SensorParams p;
    p.seed = 8;
    SensorModel s(p);
    const ExposureSettings e{2000, 8, PixelFormat::kMono8};
    ASSERT_GT(s.mean_counts(0.5, e) - 10 * std::sqrt(s.variance_counts(0.5, e)),
              s.saturation_level(e.format));
    const cv::Mat counts = s.expose(radiance_frame(256, 256, 0.5, GetParam()), e);
    double lo = 0, hi = 0;
    cv::minMaxLoc(counts, &lo, &hi);
    EXPECT_EQ(lo, 255.0);
    EXPECT_EQ(hi, 255.0);
}

TEST(SensorModel, FrameDependsOnTheSeedNotOnTheThreadCount) {
    SensorParams p;
    p.seed = 31;
    const int threads = cv::getNumThreads();
    // A patch on a background with a shaded band: long runs and short runs in one frame.
    cv::Mat L(300, 400, CV_32F, cv::Scalar(0));
    cv::circle(L, {200, 150}, 80, cv::Scalar(0.3), cv::FILLED);
    for (int x = 0; x < 400; ++x) {
        L.at<float>(20, x) = 0.001f * static_cast<float>(x);
    }
    SensorModel a(p), b(p);
    cv::setNumThreads(1);
    const cv::Mat one = a.expose(L, {});
    cv::setNumThreads(std::max(2, threads));
    const cv::Mat many = b.expose(L, {});
    cv::setNumThreads(threads);
    EXPECT_EQ(cv::norm(one, many, cv::NORM_INF), 0.0);
}

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

// The point-mode fast path (one BRDF evaluation, the disc filled row by row in parallel) renders
// exactly what the general per-pixel path renders from the same geometry, for full frames and
// ROIs cut anywhere (even and odd sizes, the disc's edge inside and outside the ROI).
TEST(CameraRender, PointModeFastPathEqualsThePerPixelGeometry) {
    ConstantBrdf f;
    gonio::sim::SceneState s;
    s.wi = {std::sin(0.7), 0, std::cos(0.7)};
    s.wo = {0, std::sin(0.2), std::cos(0.2)};
    s.irradiance_w_m2 = 2.0;
    s.filter = {0.2, 0.5, 0.3};
    for (const auto& [w, h] : {std::pair{100, 80}, std::pair{257, 191}, std::pair{64, 64}}) {
        const auto geometry = gonio::sim::scene_geometry(s, w, h);
        for (const gonio::devices::Roi roi : {gonio::devices::Roi{0, 0, w, h},
                                              gonio::devices::Roi{w / 3, h / 4, w / 2, h / 2},
                                              gonio::devices::Roi{1, 0, w - 1, h / 2 + 1},
                                              gonio::devices::Roi{0, 0, 5, 5}}) {
            const cv::Mat fast = gonio::sim::render_scene(f, s, w, h, roi);
            const cv::Mat slow =
                gonio::sim::render_radiance(f, geometry, s.irradiance_w_m2, s.filter, roi);
            EXPECT_EQ(cv::norm(fast, slow, cv::NORM_INF), 0.0)
                << w << " x " << h << ", roi " << roi.x << "," << roi.y << " " << roi.width << " x "
                << roi.height;
            if (roi.width == w && roi.height == h) {
                // The disc of radius r = min(W, H) / 4 holds pi r^2 pixel centres, to within
                // its perimeter.
                const double r = 0.25 * std::min(w, h);
                EXPECT_NEAR(cv::countNonZero(fast), M_PI * r * r, 2 * M_PI * r);
            }
        }
    }
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
