// gonio against Aravis's simulated GigE Vision camera (arv-fake-gv-camera-0.8 on 127.0.0.1):
// `gonio camera --connect gige://127.0.0.1 info|capture` through the real GVCP/GVSP stack. The
// expected frames come from what the fake camera is documented to serve and from the feature
// values Aravis's own arv-tool-0.8 reads back, never from gonio's output.
//
// The fake camera's image (Aravis 0.8, src/arvfakecamera.c, arv_fake_camera_diagonal_ramp): with
// frame id n, scale s = 1 + GainRaw + log10(ExposureTimeAbs / 10000 us), pixel (x, y) of the
// transmitted region is
//   Mono8:  clamp(((x + y + n) mod 255) * s, 0, 255)
//   Mono16: clamp(((256 x + 256 n + 256 y) mod 65535) * s, 0, 65535)
// (x, y counted from the region's corner, values truncated to integers).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>

#include "../cli_run.h"
#include "exr_frame.h"
#include "fake_gv_camera.h"

namespace {

using gonio::testing::arv_tool;
using gonio::testing::arv_value;
using gonio::testing::CliRun;
using gonio::testing::ExrFrame;
using gonio::testing::FakeGvCamera;
using gonio::testing::run_gonio;

double arv_number(const std::string& out, const std::string& feature) {
    std::string v;
    EXPECT_TRUE(arv_value(out, feature, &v)) << feature << " not in:\n" << out;
    return std::strtod(v.c_str(), nullptr);
}

/// The ramp offset k (frame id modulo the period) for which every pixel equals expected(x, y, k),
/// or -1. Candidates come from pixel (0, 0); all pixels are then compared.
long find_ramp_offset(const ExrFrame& f,
                      long period,
                      const std::function<double(long x, long y, long k)>& expected,
                      long* mismatches) {
    *mismatches = -1;
    for (long k = 0; k < period; ++k) {
        if (expected(0, 0, k) != f.at(0, 0) || expected(1, 0, k) != f.at(1, 0)) {
            continue;
        }
        long bad = 0;
        for (int y = 0; y < f.height; ++y) {
            for (int x = 0; x < f.width; ++x) {
                bad += expected(x, y, k) != f.at(x, y) ? 1 : 0;
            }
        }
        if (bad == 0) {
            *mismatches = 0;
            return k;
        }
        *mismatches = bad;
    }
    return -1;
}

TEST(GigeCameraCli, InfoReportsWhatArvToolReads) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    std::string ref;
    ASSERT_EQ(arv_tool("control DeviceVendorName DeviceModelName SensorWidth SensorHeight "
                       "ExposureTimeAbs PixelFormat",
                       &ref),
              0)
        << ref;
    std::string vendor, model, format;
    ASSERT_TRUE(arv_value(ref, "DeviceVendorName", &vendor)) << ref;
    ASSERT_TRUE(arv_value(ref, "DeviceModelName", &model)) << ref;
    ASSERT_TRUE(arv_value(ref, "PixelFormat", &format)) << ref;

    const CliRun info = run_gonio("camera --connect gige://127.0.0.1 info");
    ASSERT_EQ(info.status, 0) << info.out;
    EXPECT_NE(info.out.find("vendor: " + vendor + "\n"), std::string::npos) << info.out;
    EXPECT_NE(info.out.find("model: " + model + "\n"), std::string::npos) << info.out;
    const std::string sensor =
        "sensor: " + std::to_string(static_cast<long>(arv_number(ref, "SensorWidth"))) + " x " +
        std::to_string(static_cast<long>(arv_number(ref, "SensorHeight")));
    EXPECT_NE(info.out.find(sensor), std::string::npos) << info.out;
    EXPECT_NE(info.out.find("pixel_format: " + format + "\n"), std::string::npos) << info.out;
    const std::size_t at = info.out.find("exposure_us: ");
    ASSERT_NE(at, std::string::npos) << info.out;
    EXPECT_DOUBLE_EQ(std::strtod(info.out.c_str() + at + 13, nullptr),
                     arv_number(ref, "ExposureTimeAbs"));
    // The fake camera names its exposure ExposureTimeAbs (no ExposureTime) and has TriggerSoftware.
    EXPECT_NE(info.out.find("exposure_feature: ExposureTimeAbs"), std::string::npos) << info.out;
    EXPECT_NE(info.out.find("trigger: software trigger"), std::string::npos) << info.out;
}

TEST(GigeCameraCli, Mono8CaptureIsTheRampTheCameraServes) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    const auto dir = gonio::testing::fresh_test_dir("gige");
    const std::string exr = (dir / "mono8.exr").string();
    // 100 ms is ten times the fake camera's reference exposure: every ramp value doubles.
    const CliRun cap = run_gonio(
        "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --format Mono8 --exposure-us "
        "100000 "
        "--roi 0,0,320,240 " +
        exr);
    ASSERT_EQ(cap.status, 0) << cap.out;

    std::string ref;
    ASSERT_EQ(arv_tool("control Width Height OffsetX OffsetY PixelFormat ExposureTimeAbs GainRaw "
                       "TLParamsLocked",
                       &ref),
              0);
    std::string format;
    ASSERT_TRUE(arv_value(ref, "PixelFormat", &format)) << ref;
    EXPECT_EQ(format, "Mono8");
    // The capture left the transport layer unlocked (it locks only while acquiring).
    EXPECT_EQ(arv_number(ref, "TLParamsLocked"), 0) << ref;
    const double scale =
        1 + arv_number(ref, "GainRaw") + std::log10(arv_number(ref, "ExposureTimeAbs") / 10000);

    ExrFrame f;
    std::string why;
    ASSERT_TRUE(gonio::testing::read_exr_frame(exr, &f, &why)) << why;
    EXPECT_EQ(f.width, static_cast<int>(arv_number(ref, "Width")));
    EXPECT_EQ(f.height, static_cast<int>(arv_number(ref, "Height")));
    EXPECT_EQ(f.width, 320);
    EXPECT_EQ(f.height, 240);
    EXPECT_EQ(f.pixel_format, "Mono8");
    EXPECT_TRUE(f.cfa.empty());

    auto expected = [scale](long x, long y, long k) {
        const double v = static_cast<double>((x + y + k) % 255) * scale;
        return std::floor(std::clamp(v, 0.0, 255.0));
    };
    long mismatches = 0;
    const long k = find_ramp_offset(f, 255, expected, &mismatches);
    ASSERT_GE(k, 0) << "the frame is not the fake camera's ramp at scale " << scale
                    << " (best candidate had " << mismatches << " pixels wrong)";
    // The frame id kept with the frame is the one the pixels were drawn with.
    EXPECT_EQ(std::strtoull(f.frame_id.c_str(), nullptr, 10) % 255, static_cast<unsigned long>(k))
        << f.frame_id;
    // The statistics follow: the mean of the served ramp over the frame.
    double mean = 0, mean_expected = 0;
    for (int y = 0; y < f.height; ++y) {
        for (int x = 0; x < f.width; ++x) {
            mean += f.at(x, y);
            mean_expected += expected(x, y, k);
        }
    }
    EXPECT_NEAR(mean / (f.width * f.height), mean_expected / (f.width * f.height), 1e-9);
    EXPECT_NE(cap.out.find("0 incomplete, 0 missing"), std::string::npos) << cap.out;
}

TEST(GigeCameraCli, Mono16CaptureWithOffsetRegion) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    const auto dir = gonio::testing::fresh_test_dir("gige");
    const std::string exr = (dir / "mono16.exr").string();
    const CliRun cap = run_gonio(
        "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --format Mono16 "
        "--exposure-us 10000 "
        "--camera-gain 0 --roi 8,4,200,100 " +
        exr);
    ASSERT_EQ(cap.status, 0) << cap.out;
    std::string ref;
    ASSERT_EQ(
        arv_tool("control Width Height OffsetX OffsetY PixelFormat ExposureTimeAbs GainRaw", &ref),
        0);
    EXPECT_EQ(arv_number(ref, "OffsetX"), 8) << ref;
    EXPECT_EQ(arv_number(ref, "OffsetY"), 4) << ref;
    const double scale =
        1 + arv_number(ref, "GainRaw") + std::log10(arv_number(ref, "ExposureTimeAbs") / 10000);
    ExrFrame f;
    std::string why;
    ASSERT_TRUE(gonio::testing::read_exr_frame(exr, &f, &why)) << why;
    EXPECT_EQ(f.width, static_cast<int>(arv_number(ref, "Width")));
    EXPECT_EQ(f.height, static_cast<int>(arv_number(ref, "Height")));
    EXPECT_EQ(f.width, 200);
    EXPECT_EQ(f.height, 100);
    EXPECT_EQ(f.pixel_format, "Mono16");
    auto expected = [scale](long x, long y, long k) {
        const double v = static_cast<double>((256 * x + 256 * k + 256 * y) % 65535) * scale;
        return std::floor(std::clamp(v, 0.0, 65535.0));
    };
    long mismatches = 0;
    const long k = find_ramp_offset(f, 65535, expected, &mismatches);
    ASSERT_GE(k, 0) << "not the fake camera's Mono16 ramp at scale " << scale << " (" << mismatches
                    << " pixels wrong)";
    EXPECT_EQ(std::strtoull(f.frame_id.c_str(), nullptr, 10) % 65535,
              static_cast<unsigned long>(k));
}

TEST(GigeCameraCli, BayerFrameIsKeptAsRawMosaic) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    const auto dir = gonio::testing::fresh_test_dir("gige");
    const std::string exr = (dir / "bayer.exr").string();
    const CliRun cap = run_gonio(
        "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --format BayerRG8 --roi "
        "0,0,64,48 " +
        exr);
    ASSERT_EQ(cap.status, 0) << cap.out;
    std::string ref;
    ASSERT_EQ(arv_tool("control PixelFormat Width Height", &ref), 0);
    std::string format;
    ASSERT_TRUE(arv_value(ref, "PixelFormat", &format)) << ref;
    EXPECT_EQ(format, "BayerRG8");
    ExrFrame f;
    std::string why;
    ASSERT_TRUE(gonio::testing::read_exr_frame(exr, &f, &why)) << why;
    // One value per photosite (not three demosaiced channels), labelled with its filter pattern.
    EXPECT_EQ(f.width, 64);
    EXPECT_EQ(f.height, 48);
    EXPECT_EQ(f.pixel_format, "BayerRG8");
    EXPECT_EQ(f.cfa, "RGGB");
}

TEST(GigeCameraCli, BlackLevelInDnIsTakenFromTheCamera) {
    // gonio's own simulated GigE Vision camera states BlackLevel as a Float in DN.
    FakeGvCamera cam(
        FakeGvCamera::Command{{GONIO_EXE, "camera", "serve", "--width", "64", "--height", "48"}});
    ASSERT_TRUE(cam.ready()) << cam.error();
    const auto dir = gonio::testing::fresh_test_dir("gige");
    const std::string exr = (dir / "black.exr").string();
    const CliRun cap =
        run_gonio("camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --format Mono16 " +
                  std::string("--exposure-us 1000 ") + exr);
    ASSERT_EQ(cap.status, 0) << cap.out;
    std::string ref;
    ASSERT_EQ(arv_tool("control BlackLevel PixelFormat", &ref), 0);
    std::string format;
    ASSERT_TRUE(arv_value(ref, "PixelFormat", &format)) << ref;
    ASSERT_EQ(format, "Mono16");
    const double black = arv_number(ref, "BlackLevel");
    EXPECT_GT(black, 0) << ref;
    const std::size_t at = cap.out.find("black ");
    ASSERT_NE(at, std::string::npos) << cap.out;
    EXPECT_DOUBLE_EQ(std::strtod(cap.out.c_str() + at + 6, nullptr), black) << cap.out;
}

TEST(GigeCameraCli, DevicesListsWhatAravisFinds) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    // arv-tool-0.8 without a command lists the devices as "ID (ADDRESS)".
    std::string list;
    ASSERT_EQ(gonio::testing::run_command("arv-tool-0.8", &list), 0) << list;
    const std::size_t open = list.find(" (127.0.0.1)");
    ASSERT_NE(open, std::string::npos) << list;
    const std::size_t line = list.rfind('\n', open);
    const std::string id = list.substr(line == std::string::npos ? 0 : line + 1,
                                       open - (line == std::string::npos ? 0 : line + 1));
    const CliRun r = run_gonio("devices");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("GigEVision gige://127.0.0.1"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("aravis:" + id), std::string::npos) << id << "\n" << r.out;
    // The id it prints opens the same camera.
    const CliRun info = run_gonio("camera --connect aravis:" + id + " info");
    ASSERT_EQ(info.status, 0) << info.out;
    EXPECT_NE(info.out.find("trigger: software trigger"), std::string::npos) << info.out;
}

TEST(GigeCameraCli, AddressesOfAbsentCamerasFailWithAMessage) {
    const CliRun u3v = run_gonio("camera --connect u3v://NO-SUCH-SERIAL info");
    EXPECT_NE(u3v.status, 0);
    EXPECT_NE(u3v.out.find("no USB3 Vision camera with serial NO-SUCH-SERIAL"), std::string::npos)
        << u3v.out;
    EXPECT_NE(u3v.out.find("gonio devices"), std::string::npos) << u3v.out;
    const CliRun id = run_gonio("camera --connect aravis:No-Such-Camera info");
    EXPECT_NE(id.status, 0);
    EXPECT_NE(id.out.find("aravis:No-Such-Camera"), std::string::npos) << id.out;
    const CliRun empty = run_gonio("camera --connect gige:// info");
    EXPECT_NE(empty.status, 0);
    EXPECT_NE(empty.out.find("empty host"), std::string::npos) << empty.out;
}

}  // namespace
