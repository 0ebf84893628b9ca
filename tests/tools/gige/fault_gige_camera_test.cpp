// Faults of a GenICam camera seen through gonio, against Aravis's simulated GigE Vision camera
// (arv-fake-gv-camera-0.8 on 127.0.0.1): settings outside the camera's range, features the
// camera does not have, a camera killed mid-stream, packets lost on the wire. Ranges and values
// are read with Aravis's own arv-tool-0.8.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "../cli_run.h"
#include "exr_frame.h"
#include "fake_gv_camera.h"
#include "gonio/devices/aravis_camera.h"
#include "gonio/devices/camera_factory.h"

namespace {

using gonio::testing::arv_bounds;
using gonio::testing::arv_tool;
using gonio::testing::arv_value;
using gonio::testing::CliRun;
using gonio::testing::FakeGvCamera;
using gonio::testing::run_gonio;
using std::chrono::milliseconds;

/// The two numbers of "[A, B]" after `from` in a message.
bool bracket_range(const std::string& msg, std::size_t from, double* lo, double* hi) {
    const std::size_t open = msg.find('[', from);
    if (open == std::string::npos) {
        return false;
    }
    char* end = nullptr;
    *lo = std::strtod(msg.c_str() + open + 1, &end);
    if (end == nullptr || *end != ',') {
        return false;
    }
    *hi = std::strtod(end + 1, &end);
    return end != nullptr && *end == ']';
}

TEST(GigeCameraFaults, ExposureOutsideTheRangeNamesRangeAndUnit) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    std::string ref;
    ASSERT_EQ(arv_tool("control ExposureTimeAbs", &ref), 0);
    double lo = 0, hi = 0;
    ASSERT_TRUE(arv_bounds(ref, "ExposureTimeAbs", &lo, &hi)) << ref;
    const auto dir = gonio::testing::fresh_test_dir("gige_fault");
    for (const double bad : {lo / 2, hi * 2}) {
        std::ostringstream arg;
        arg << bad;
        const CliRun r = run_gonio(
            "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --exposure-us " +
            arg.str() + " --format Mono8 " + (dir / "x.exr").string());
        EXPECT_NE(r.status, 0) << r.out;
        const std::size_t at = r.out.find("outside the range");
        ASSERT_NE(at, std::string::npos) << r.out;
        double mlo = 0, mhi = 0;
        ASSERT_TRUE(bracket_range(r.out, at, &mlo, &mhi)) << r.out;
        EXPECT_NEAR(mlo, lo, 1e-6 * std::abs(lo)) << r.out;
        EXPECT_NEAR(mhi, hi, 1e-6 * std::abs(hi)) << r.out;
        EXPECT_NE(r.out.find("] us of ExposureTimeAbs"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find("gige://127.0.0.1"), std::string::npos) << r.out;
        EXPECT_FALSE(std::filesystem::exists(dir / "x.exr"));
    }
    // Nothing was written to the camera: it still has the exposure it had.
    std::string after;
    ASSERT_EQ(arv_tool("control ExposureTimeAbs", &after), 0);
    std::string before_v, after_v;
    ASSERT_TRUE(arv_value(ref, "ExposureTimeAbs", &before_v));
    ASSERT_TRUE(arv_value(after, "ExposureTimeAbs", &after_v));
    EXPECT_EQ(before_v, after_v);
}

TEST(GigeCameraFaults, GainInRawUnitsOnlyIsSaidAndRangeChecked) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    std::string ref;
    ASSERT_EQ(arv_tool("control GainRaw", &ref), 0);
    double lo = 0, hi = 0;
    ASSERT_TRUE(arv_bounds(ref, "GainRaw", &lo, &hi)) << ref;
    const auto dir = gonio::testing::fresh_test_dir("gige_fault");
    const std::string exr = (dir / "g.exr").string();
    // A linear factor cannot be turned into raw units: refused, naming the feature.
    const CliRun linear = run_gonio(
        "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --gain 2 --format Mono8 " +
        exr);
    EXPECT_NE(linear.status, 0);
    EXPECT_NE(linear.out.find("only GainRaw"), std::string::npos) << linear.out;
    EXPECT_NE(linear.out.find("Aravis Fake"), std::string::npos) << linear.out;
    // Above the raw range: the range and the unit are named.
    std::ostringstream too_high;
    too_high << hi + 1;
    const CliRun high =
        run_gonio("camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --camera-gain " +
                  too_high.str() + " --format Mono8 " + exr);
    EXPECT_NE(high.status, 0);
    const std::size_t at = high.out.find("outside the range");
    ASSERT_NE(at, std::string::npos) << high.out;
    double mlo = 0, mhi = 0;
    ASSERT_TRUE(bracket_range(high.out, at, &mlo, &mhi)) << high.out;
    EXPECT_EQ(mlo, lo);
    EXPECT_EQ(mhi, hi);
    EXPECT_NE(high.out.find("] raw of GainRaw"), std::string::npos) << high.out;
    // Inside the range it is written as asked, as Aravis's tool reads back.
    const CliRun ok = run_gonio(
        "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --camera-gain 3 --format "
        "Mono8 " +
        exr);
    ASSERT_EQ(ok.status, 0) << ok.out;
    ASSERT_EQ(arv_tool("control GainRaw", &ref), 0);
    std::string v;
    ASSERT_TRUE(arv_value(ref, "GainRaw", &v)) << ref;
    EXPECT_EQ(v, "3");
}

/// The fake camera's own GenICam XML with some features renamed away, served with -g.
std::string xml_without(const std::string& dir, const std::vector<std::string>& features) {
    std::string xml;
    {
        FakeGvCamera cam;
        if (!cam.ready() || arv_tool("genicam", &xml) != 0) {
            return {};
        }
    }
    for (const auto& f : features) {
        for (const std::string& pattern : {"Name=\"" + f + "\"", ">" + f + "<"}) {
            std::size_t at = 0;
            const std::string hidden =
                pattern.substr(0, pattern.size() - 1) + "Hidden" + pattern.back();
            while ((at = xml.find(pattern, at)) != std::string::npos) {
                xml.replace(at, pattern.size(), hidden);
                at += hidden.size();
            }
        }
    }
    const std::string path = dir + "/fake-camera.xml";
    std::ofstream(path) << xml;
    return path;
}

TEST(GigeCameraFaults, MissingExposureFeatureIsNamed) {
    const auto dir = gonio::testing::fresh_test_dir("gige_fault");
    const std::string xml = xml_without(dir.string(), {"ExposureTimeAbs"});
    ASSERT_FALSE(xml.empty());
    FakeGvCamera cam({"-g", xml});
    ASSERT_TRUE(cam.ready()) << cam.error();
    const CliRun r =
        run_gonio("camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --format Mono8 " +
                  (dir / "x.exr").string());
    EXPECT_NE(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("has no exposure feature (looked for ExposureTime, ExposureTimeAbs, "
                         "ExposureTimeRaw)"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("Aravis Fake"), std::string::npos) << r.out;
}

TEST(GigeCameraFaults, WithoutSoftwareTriggerEachCaptureIsOneSingleFrameAcquisition) {
    const auto dir = gonio::testing::fresh_test_dir("gige_fault");
    const std::string xml = xml_without(dir.string(), {"TriggerSoftware"});
    ASSERT_FALSE(xml.empty());
    FakeGvCamera cam({"-g", xml});
    ASSERT_TRUE(cam.ready()) << cam.error();
    const CliRun info = run_gonio("camera --connect gige://127.0.0.1 info");
    ASSERT_EQ(info.status, 0) << info.out;
    EXPECT_NE(info.out.find("trigger: single frame"), std::string::npos) << info.out;
    const std::string exr = (dir / "single.exr").string();
    const CliRun cap = run_gonio(
        "camera --connect gige://127.0.0.1 capture --timeout-ms 20000 --format Mono8 --roi "
        "0,0,100,50 " +
        exr);
    ASSERT_EQ(cap.status, 0) << cap.out;
    std::string ref;
    ASSERT_EQ(arv_tool("control AcquisitionMode TriggerMode", &ref), 0);
    std::string mode;
    ASSERT_TRUE(arv_value(ref, "AcquisitionMode", &mode)) << ref;
    EXPECT_EQ(mode, "SingleFrame");
    gonio::testing::ExrFrame f;
    std::string why;
    ASSERT_TRUE(gonio::testing::read_exr_frame(exr, &f, &why)) << why;
    EXPECT_EQ(f.width, 100);
    EXPECT_EQ(f.height, 50);
}

TEST(GigeCameraFaults, CameraKilledMidStreamGivesAClearErrorNotAHang) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    auto opened = gonio::devices::open_camera("gige://127.0.0.1");
    ASSERT_TRUE(opened) << opened.error().message;
    auto* c = dynamic_cast<gonio::devices::AravisCamera*>(opened->get());
    ASSERT_NE(c, nullptr);
    ASSERT_TRUE(c->set_pixel_format_name("Mono8"));
    ASSERT_TRUE(c->set_roi({0, 0, 128, 64}));
    ASSERT_TRUE(c->start_stream());
    auto first = c->next_frame(milliseconds(3000));
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_EQ(first->image.cols, 128);
    EXPECT_EQ(first->image.rows, 64);

    cam.kill_now();
    // Frames already in flight may still arrive; within a bounded number of waits the camera's
    // absence must be reported.
    std::string message;
    for (int i = 0; i < 50 && message.empty(); ++i) {
        auto f = c->next_frame(milliseconds(300));
        if (!f) {
            message = f.error().message;
        }
    }
    ASSERT_FALSE(message.empty()) << "frames kept coming from a killed camera";
    EXPECT_NE(message.find("no frame within 300 ms"), std::string::npos) << message;
    EXPECT_TRUE(message.find("no longer answers") != std::string::npos ||
                message.find("control of the camera was lost") != std::string::npos)
        << message;
    EXPECT_NE(message.find("gige://127.0.0.1"), std::string::npos) << message;
    EXPECT_GE(c->stream_stats().frames_missing, 1u);
    // Stopping a stream of a vanished camera reports, and returns.
    (void)c->stop_stream();
}

TEST(GigeCameraFaults, CameraKilledBetweenTriggeredCapturesGivesAClearError) {
    FakeGvCamera cam;
    ASSERT_TRUE(cam.ready()) << cam.error();
    auto opened = gonio::devices::AravisCamera::open_gige("127.0.0.1");
    ASSERT_TRUE(opened) << opened.error().message;
    auto& c = **opened;
    ASSERT_TRUE(c.set_pixel_format_name("Mono8"));
    ASSERT_TRUE(c.set_roi({0, 0, 64, 32}));
    auto first = c.capture(milliseconds(5000));
    ASSERT_TRUE(first) << first.error().message;
    cam.kill_now();
    auto second = c.capture(milliseconds(1000));
    ASSERT_FALSE(second) << "a frame from a killed camera";
    const std::string& m = second.error().message;
    EXPECT_NE(m.find("gige://127.0.0.1"), std::string::npos) << m;
    EXPECT_TRUE(m.find("no longer answers") != std::string::npos ||
                m.find("control of the camera was lost") != std::string::npos)
        << m;
}

TEST(GigeCameraFaults, LostPacketsAreCountedAndNoBrokenFrameIsHandedOut) {
    // The fake camera drops 30 % of its GVSP packets (and does not honour resend requests), so
    // nearly every frame of ~50 packets arrives incomplete.
    FakeGvCamera cam({"-r", "300"});
    ASSERT_TRUE(cam.ready()) << cam.error();
    auto opened = gonio::devices::AravisCamera::open_gige("127.0.0.1");
    ASSERT_TRUE(opened) << opened.error().message;
    auto& c = **opened;
    ASSERT_TRUE(c.set_pixel_format_name("Mono8"));
    ASSERT_TRUE(c.set_roi({0, 0, 256, 256}));
    ASSERT_TRUE(c.start_stream());
    int failures = 0, successes = 0;
    for (int i = 0; i < 12; ++i) {
        auto f = c.next_frame(milliseconds(2000));
        if (!f) {
            ++failures;
            EXPECT_TRUE(f.error().message.find("incomplete") != std::string::npos ||
                        f.error().message.find("no frame within") != std::string::npos)
                << f.error().message;
            continue;
        }
        ++successes;
        // A frame handed out is whole: the fake camera's Mono8 ramp at scale 1 everywhere.
        const int k = f->image.at<std::uint16_t>(0, 0);
        for (int y = 0; y < f->image.rows; ++y) {
            for (int x = 0; x < f->image.cols; ++x) {
                ASSERT_EQ(f->image.at<std::uint16_t>(y, x), (x + y + k) % 255)
                    << "pixel " << x << "," << y << " of frame " << f->frame_id;
            }
        }
    }
    (void)c.stop_stream();
    const auto s = c.stream_stats();
    EXPECT_GE(failures, 1);
    EXPECT_EQ(s.frames_incomplete + s.frames_missing, static_cast<std::uint64_t>(failures));
    EXPECT_EQ(s.frames_completed, static_cast<std::uint64_t>(successes));
    EXPECT_GE(s.missing_packets, 1u);
}

}  // namespace
