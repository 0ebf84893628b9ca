// Capture math on synthetic frames with known signal: dark subtraction, saturation exclusion,
// uncertainty against the noise the frames were made with, HDR merge of a scene no single exposure
// holds, auto exposure's linear step; the white-reference calibration against its closed form; the
// journal's durability rules.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <random>

#include "gonio/acquisition/point/calibration.h"
#include "gonio/acquisition/point/capture.h"
#include "gonio/acquisition/point/journal.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::Rgbd;

/// A Mono16 frame: black + rate * t per pixel (rate_img in counts/us) + Gaussian noise of sigma
/// counts, clipped at 65535.
devices::Frame make_frame(
    const cv::Mat& rate_img, double t_us, double black, double sigma, std::mt19937_64& rng) {
    std::normal_distribution<double> n(0.0, sigma);
    devices::Frame f;
    f.image = cv::Mat(rate_img.rows, rate_img.cols, CV_16U);
    for (int y = 0; y < rate_img.rows; ++y) {
        for (int x = 0; x < rate_img.cols; ++x) {
            const double c = black + rate_img.at<float>(y, x) * t_us + n(rng);
            f.image.at<std::uint16_t>(y, x) =
                static_cast<std::uint16_t>(std::clamp(std::round(c), 0.0, 65535.0));
        }
    }
    f.exposure_us = t_us;
    f.gain = 1;
    f.black_level = black;
    f.saturation_level = 65535;
    f.bit_depth = 16;
    return f;
}

TEST(Capture, RoiMeanAndUncertaintyMatchTheNoiseTheFrameWasMadeWith) {
    const std::uint64_t seed = 11;
    std::mt19937_64 rng(seed);
    cv::Mat rate(64, 64, CV_32F, cv::Scalar(2.0f));  // 2 counts/us
    const double sigma = 20;
    devices::Frame f = make_frame(rate, 1000, 1000, sigma, rng);
    cv::Mat dark(64, 64, CV_32F, cv::Scalar(1000.0f));
    const PixelRoi roi{16, 16, 32, 32};
    auto st = roi_stats(f, dark, roi, NoiseModel{0, 0});
    ASSERT_TRUE(st) << st.error().message;
    // Mean 2000 counts; the standard error of 1024 pixels of sigma 20 is 0.625.
    EXPECT_NEAR(st->mean[0], 2000, 4 * 0.625) << "seed " << seed;
    EXPECT_NEAR(st->sigma[0], 0.625, 0.625 * 0.1);
    EXPECT_EQ(st->valid, 1024u);
    EXPECT_EQ(st->saturated, 0u);
    // 99th percentile of 2000 + N(0, 20) counts above black: 2000 + 2.326 * 20, over 65535 - 1000.
    EXPECT_NEAR(st->high_fraction, (2000 + 2.326 * 20) / 64535.0, 0.0005);
    // The noise model dominates when it predicts more: 2000 counts at 0.5 e/count -> variance
    // 2000 * 1 / 0.5 = 4000 counts^2 plus read noise 2 * 10^2.
    auto st2 = roi_stats(f, dark, roi, NoiseModel{0.5, 10});
    ASSERT_TRUE(st2);
    EXPECT_NEAR(st2->sigma[0], std::sqrt((4000.0 + 200.0) / 1024.0), 0.05);
    // ROI outside the frame.
    EXPECT_FALSE(roi_stats(f, dark, PixelRoi{40, 40, 32, 32}, NoiseModel{}));
}

TEST(Capture, SaturatedPixelsAreExcluded) {
    std::mt19937_64 rng(3);
    cv::Mat rate(32, 32, CV_32F, cv::Scalar(1.0f));
    rate(cv::Rect(0, 0, 32, 8)).setTo(1000.0f);  // a quarter of the ROI far beyond full scale
    devices::Frame f = make_frame(rate, 1000, 500, 0, rng);
    cv::Mat dark(32, 32, CV_32F, cv::Scalar(500.0f));
    auto st = roi_stats(f, dark, PixelRoi{0, 0, 32, 32}, NoiseModel{});
    ASSERT_TRUE(st);
    EXPECT_EQ(st->saturated, 256u);
    EXPECT_EQ(st->valid, 768u);
    EXPECT_DOUBLE_EQ(st->mean[0], 1000.0);
    EXPECT_GE(st->high_fraction, 1.0);
}

TEST(Capture, HdrMergeRecoversASceneNoSingleExposureHolds) {
    const std::uint64_t seed = 17;
    std::mt19937_64 rng(seed);
    // Half the ROI at 100 counts/us, half at 0.05: ratio 2000, beyond one 16-bit exposure with
    // noise of 20 counts.
    cv::Mat rate(40, 40, CV_32F, cv::Scalar(0.05f));
    rate(cv::Rect(0, 0, 40, 20)).setTo(100.0f);
    const double truth = (100.0 + 0.05) / 2;
    std::vector<devices::Frame> frames;
    std::vector<cv::Mat> darks;
    for (double t : {500.0, 4000.0, 32000.0}) {
        frames.push_back(make_frame(rate, t, 1000, 20, rng));
        darks.emplace_back(40, 40, CV_32F, cv::Scalar(1000.0f));
    }
    auto m = merge_hdr(frames, darks, PixelRoi{0, 0, 40, 40}, NoiseModel{});
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_TRUE(m->hdr);
    EXPECT_FALSE(m->saturated);
    // The bright half comes from the short exposure (clipped in the others), the dark half mostly
    // from the longest: the dark half's mean is good to 20 / 32000 / sqrt(800) counts/us.
    EXPECT_NEAR(m->rate[0], truth, 0.05) << "seed " << seed;
    // A single long exposure clips half the ROI: flagged, and the value is a lower bound.
    auto single = merge_hdr({frames[2]}, {darks[2]}, PixelRoi{0, 0, 40, 40}, NoiseModel{});
    ASSERT_TRUE(single);
    EXPECT_TRUE(single->saturated);
    EXPECT_LT(single->rate[0], truth);
    EXPECT_FALSE(merge_hdr({}, {}, PixelRoi{0, 0, 4, 4}, NoiseModel{}));
}

TEST(Capture, AutoExposureStep) {
    // Linear response: 0.15 of range at 1000 us -> 0.6 at 4000 us.
    EXPECT_DOUBLE_EQ(next_exposure_us(1000, 0.15, 0.6, 10, 1e6), 4000);
    EXPECT_DOUBLE_EQ(next_exposure_us(1000, 1.0, 0.6, 10, 1e6), 125);    // clipped: / 8
    EXPECT_DOUBLE_EQ(next_exposure_us(1000, 0.0, 0.6, 10, 1e6), 8000);   // nothing: x 8
    EXPECT_DOUBLE_EQ(next_exposure_us(1000, 0.001, 0.6, 10, 2e5), 2e5);  // clamped
}

TEST(Calibration, WhiteReferenceClosedForm) {
    // A Lambertian sample of albedo 0.5 under the same lamp and detector: its rate is half the
    // white standard's (rho = 1) at the same incidence, and cos theta_i scales both alike.
    WhiteCalibration w;
    w.reflectance = 1.0;
    w.cos_theta_w = 1.0;
    w.rate = Rgbd(8.0, 4.0, 2.0);
    const double cos_i = std::cos(0.6);
    const Rgbd sample_rate = 0.5 * w.rate * cos_i;  // radiance ~ f E cos(theta_i)
    auto v = rate_to_brdf(w, sample_rate, Rgbd::Constant(0.01), cos_i);
    ASSERT_TRUE(v);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(v->value[c], 0.5 / kPi, 1e-15);
    }
    EXPECT_NEAR(v->sigma[0], 0.01 / 8.0 / kPi / cos_i, 1e-15);
    EXPECT_FALSE(rate_to_brdf(w, sample_rate, Rgbd::Zero(), 0.0));
    WhiteCalibration dead = w;
    dead.rate[1] = 0;
    EXPECT_FALSE(rate_to_brdf(dead, sample_rate, Rgbd::Zero(), 0.5));
}

std::string temp_path(const char* name) {
    return std::string(GONIO_BINARY_DIR) + "/" + name + "_" + std::to_string(::getpid());
}

TEST(Journal, RoundTripAndTornTail) {
    const std::string path = temp_path("journal_test.log");
    std::remove(path.c_str());
    JournalRecord a;
    a.pass = 1;
    a.index = 42;
    a.wi = brdf::Vec3d(0.1, 0.2, std::sqrt(0.95));
    a.value = Rgbd(0.1, 1.0 / 3.0, 12.5);
    a.flags = 9;
    {
        auto j = Journal::open(path);
        ASSERT_TRUE(j) << j.error().message;
        EXPECT_TRUE(j->records().empty());
        ASSERT_TRUE(j->append(a));
        a.index = 43;
        ASSERT_TRUE(j->append(a));
    }
    // Simulate a write cut short: half a record without its newline.
    const std::string partial = encode_record(a).substr(0, 40);
    {
        std::ofstream f(path, std::ios::app);
        f << partial;
    }
    {
        auto j = Journal::open(path);
        ASSERT_TRUE(j) << j.error().message;
        EXPECT_TRUE(j->torn_tail());
        ASSERT_EQ(j->records().size(), 2u);
        EXPECT_EQ(j->records()[0].index, 42u);
        EXPECT_EQ(j->records()[1].pass, 1);
        EXPECT_EQ(j->records()[1].value[1], 1.0 / 3.0);  // exact round trip
        EXPECT_EQ(j->records()[1].wi, a.wi);
        a.index = 44;
        ASSERT_TRUE(j->append(a));
    }
    {
        auto j = Journal::open(path);
        ASSERT_TRUE(j);
        EXPECT_FALSE(j->torn_tail());
        ASSERT_EQ(j->records().size(), 3u);
        EXPECT_EQ(j->records()[2].index, 44u);
    }
    // A damaged line in the middle is corruption, not a torn tail.
    {
        std::ifstream in(path);
        std::string l1, l2, l3;
        std::getline(in, l1);
        std::getline(in, l2);
        std::getline(in, l3);
        l2[5] = l2[5] == 'x' ? 'y' : 'x';
        std::ofstream out(path, std::ios::trunc);
        out << l1 << "\n" << l2 << "\n" << l3 << "\n";
    }
    auto bad = Journal::open(path);
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find(":2:"), std::string::npos) << bad.error().message;
    std::remove(path.c_str());
}

}  // namespace
}  // namespace gonio::acquisition
