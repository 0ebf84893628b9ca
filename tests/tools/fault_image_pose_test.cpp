// Pose integrity of image-mode captures on the virtual rig (motor controllers on Modbus TCP, the
// camera a GigE Vision device through Aravis): the light arm's position is read back before and
// after every exposure. A second Modbus client moving the light arm during exposures makes those
// captures repeat and the table stays true to the ground truth; one that keeps moving it fails
// the campaign with an error naming the arm; an arm pushed away between captures is moved back
// before the next exposure; a drive alarm in the middle of a move (the motor controller's fault
// injection) fails the capture with the drive's error; a frame the camera loses (its fault
// injection) is captured again.

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>

#include "embedded_rig.h"
#include "gonio/acquisition/image/image_journal.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_json.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "image_test_support.h"

namespace gonio::tools {
namespace {

using brdf::kPi;

/// Bound on one frame's median relative error (see worst_frame_median).
constexpr double kFrameMedianBound = 0.05;

brdf::ModelD truth_model() {
    return image_test::lambert_ggx(brdf::Rgbd(0.3, 0.25, 0.2), 0.1);
}

struct Live {
    std::unique_ptr<acquisition::ImageRig> rig;
    std::shared_ptr<devices::ModbusBus> bus;
    std::unique_ptr<devices::ModbusAxis> intruder;  ///< A second client on the light arm.
};

Live start(std::uint64_t seed) {
    Live l;
    const std::string model =
        std::string(GONIO_BINARY_DIR) + "/image_pose_truth_" + std::to_string(::getpid()) + ".json";
    std::ofstream(model) << brdf::model_to_json(truth_model());
    acquisition::ImageRigOptions o;
    o.brdf_path = model;
    o.image_size = 96;
    o.supersample = 1;
    o.seed = seed;
    o.time_scale = 500;
    auto rig = acquisition::start_image_rig(o, embedded_rig_starter());
    std::filesystem::remove(model);
    EXPECT_TRUE(rig) << rig.error().message;
    if (!rig) {
        return l;
    }
    l.rig = std::move(*rig);
    auto bus =
        devices::ModbusBus::open(*devices::parse_bus_address(simulator(*l.rig)->motor_address()));
    EXPECT_TRUE(bus) << bus.error().message;
    l.bus = *bus;
    auto profile = devices::load_axis_profile("generic");
    EXPECT_TRUE(profile);
    l.intruder = std::make_unique<devices::ModbusAxis>(l.bus,
                                                       simulator(*l.rig)->units().light,
                                                       *profile,
                                                       "intruder",
                                                       devices::SoftLimits{-178, 178},
                                                       devices::Motion{30, 60, 0});
    return l;
}

/// The pose-check notes (not the camera retries).
std::vector<std::string> pose_notes(const acquisition::ImageRig& rig) {
    std::vector<std::string> out;
    for (const std::string& n : rig.pose_log.notes) {
        if (n.rfind("pose check", 0) == 0) {
            out.push_back(n);
        }
    }
    return out;
}

/// The worst, over the frames of a journal and the channels, of the median |mean / truth - 1| of
/// the frame's own bins (at least 10 samples, both directions 78 deg or more from grazing). A frame
/// taken with the arm away from where the campaign believes it is shifts every bin it fills: its
/// median stands out, where the median over the whole table (3 frames of ~40) would not move.
double worst_frame_median(const std::string& journal_path, const brdf::Brdf& truth) {
    auto j = acquisition::ImageJournal::open(journal_path);
    EXPECT_TRUE(j) << j.error().message;
    if (!j) {
        return std::nan("");
    }
    double worst = 0;
    for (const acquisition::ImageJournalFrame& f : j->frames()) {
        for (int c = 0; c < 3; ++c) {
            std::vector<double> rel;
            for (const acquisition::BinAggregate& a : f.bins) {
                const brdf::HalfDiff<double> hd{a.position[0], 0.0, a.position[1], a.position[2]};
                const auto [wi, wo] = brdf::from_half_diff(hd);
                if (a.count < 10 || wi.z() < 0.2 || wo.z() < 0.2) {
                    continue;
                }
                rel.push_back(std::abs(a.mean[c] / truth.eval(wi, wo)[c] - 1));
            }
            if (rel.size() >= 20) {
                worst = std::max(worst, image_test::median(rel));
            }
        }
    }
    return worst;
}

/// Moves the light arm by `by_deg` (away from the nearer limit) and waits until it stands.
bool push(devices::ModbusAxis& a, double by_deg) {
    auto at = a.position_deg();
    if (!at) {
        return false;
    }
    return static_cast<bool>(
        a.move_to(*at > 0 ? *at - by_deg : *at + by_deg, std::chrono::milliseconds(10000)));
}

TEST(ImagePose, ArmMovedDuringExposuresRepeatsThoseCapturesAndTheTableStaysTrue) {
    Live l = start(11);
    ASSERT_TRUE(l.rig && l.intruder);
    // The intruder moves the light arm by 3 degrees while exposures 8, 20 and 32 are taken (the
    // camera asks the world for the rig state when the software trigger arrives).
    std::mutex mu;
    int intrusions = 0;
    simulator(*l.rig)->world().set_exposure_hook([&](std::uint64_t n) {
        if (n == 8 || n == 20 || n == 32) {
            std::lock_guard<std::mutex> lock(mu);
            intrusions += push(*l.intruder, 3) ? 1 : 0;
        }
    });
    const acquisition::ImageCampaignConfig cfg =
        acquisition::image_campaign_config(l.rig->rig, l.rig->camera, 6, 0.5, 40);
    // The frames are journaled so that each one can be judged on its own.
    const std::string journal = std::string(GONIO_BINARY_DIR) + "/image_pose_journal_" +
                                std::to_string(::getpid()) + ".journal";
    std::filesystem::remove(journal);
    auto res = acquisition::run_image_campaign(
        acquisition::image_rig_capture(*l.rig, 0.0), cfg, {}, journal);
    ASSERT_TRUE(res) << res.error().message;
    EXPECT_EQ(intrusions, 3);
    EXPECT_EQ(l.rig->pose_log.repeats, 3u);
    EXPECT_EQ(l.rig->pose_log.corrections, 0u);
    const std::vector<std::string> notes = pose_notes(*l.rig);
    ASSERT_EQ(notes.size(), 3u);
    for (const std::string& n : notes) {
        EXPECT_NE(n.find("light arm"), std::string::npos) << n;
        EXPECT_NE(n.find("repeated"), std::string::npos) << n;
    }
    // Every frame the camera rendered was captured: the campaign's count plus the 3 repeats (and
    // any capture retried after a lost frame).
    EXPECT_EQ(simulator(*l.rig)->camera().frames_rendered(),
              res->captures + 3 + l.rig->pose_log.capture_retries);
    // No frame taken while the arm moved reached the table.
    const auto truth = brdf::make_analytic_brdf(truth_model());
    const std::vector<double> rel = image_test::table_relative_errors(res->table, *truth, 1);
    ASSERT_GT(rel.size(), 100u);
    EXPECT_LT(image_test::median(rel), 0.02);
    // Nor into any frame: the worst frame's own median is at the noise level too.
    const double worst = worst_frame_median(journal, *truth);
    std::printf("worst frame median %.4f over %zu frames\n", worst, res->frames.size());
    EXPECT_LT(worst, kFrameMedianBound);
    std::filesystem::remove(journal);
}

TEST(ImagePose, ArmThatKeepsMovingFailsTheCampaignNamingIt) {
    Live l = start(12);
    ASSERT_TRUE(l.rig && l.intruder);
    simulator(*l.rig)->world().set_exposure_hook([&](std::uint64_t n) {
        if (n >= 10) {
            (void)push(*l.intruder, 2);
        }
    });
    const acquisition::ImageCampaignConfig cfg =
        acquisition::image_campaign_config(l.rig->rig, l.rig->camera, 6, 0.5, 40);
    auto res = acquisition::run_image_campaign(acquisition::image_rig_capture(*l.rig, 0.0), cfg);
    ASSERT_FALSE(res);
    const std::string& m = res.error().message;
    EXPECT_NE(m.find("pose check"), std::string::npos) << m;
    EXPECT_NE(m.find("keep moving"), std::string::npos) << m;
    EXPECT_NE(m.find("light arm"), std::string::npos) << m;
    const acquisition::DeviceCaptureOptions defaults;
    EXPECT_EQ(l.rig->pose_log.repeats, static_cast<std::size_t>(defaults.max_pose_repeats));
}

TEST(ImagePose, ArmPushedAwayBetweenCapturesIsMovedBackBeforeTheExposure) {
    Live l = start(13);
    ASSERT_TRUE(l.rig && l.intruder);
    acquisition::CaptureFn capture = acquisition::image_rig_capture(*l.rig, 0.0);
    acquisition::CaptureRequest r;
    r.light_arm_rad = 40 * kPi / 180;
    r.exposure_us = 2000;
    auto first = capture(r);
    ASSERT_TRUE(first) << first.error().message;
    const sim::MotorControllerServer& motors = simulator(*l.rig)->motors();
    const int light = simulator(*l.rig)->units().light;
    EXPECT_NEAR(motors.position_deg(light), 40, 0.01);
    // Between captures another client moves the arm 5 degrees; the next capture at the same
    // position (no move commanded: the arm should still be there) finds it off target first.
    ASSERT_TRUE(push(*l.intruder, 5));
    EXPECT_NEAR(motors.position_deg(light), 35, 0.01);
    std::atomic<double> at_exposure{0};
    simulator(*l.rig)->world().set_exposure_hook(
        [&](std::uint64_t) { at_exposure.store(motors.position_deg(light)); });
    auto second = capture(r);
    ASSERT_TRUE(second) << second.error().message;
    EXPECT_NEAR(at_exposure.load(), 40, 0.01);
    EXPECT_EQ(l.rig->pose_log.corrections, 1u);
    EXPECT_EQ(l.rig->pose_log.repeats, 0u);
    const std::vector<std::string> notes = pose_notes(*l.rig);
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_NE(notes[0].find("light arm at 35.0"), std::string::npos) << notes[0];
    // The two frames of the same request agree (same pose, same light): the sum of the pixels
    // differs by the noise only.
    const double s1 = cv::sum(first->image)[0];
    const double s2 = cv::sum(second->image)[0];
    EXPECT_NEAR(s2 / s1, 1.0, 0.01);
}

TEST(ImagePose, DriveAlarmMidMoveFailsTheCaptureWithTheDrivesError) {
    Live l = start(14);
    ASSERT_TRUE(l.rig);
    acquisition::CaptureFn capture = acquisition::image_rig_capture(*l.rig, 0.0);
    // The motor controller's fault injection: the light arm's next move stops half way with an
    // overload alarm.
    sim::Fault f;
    f.kind = sim::FaultKind::kAlarmMidMove;
    f.unit = simulator(*l.rig)->units().light;
    f.fraction = 0.5;
    simulator(*l.rig)->motors().inject(f);
    acquisition::CaptureRequest r;
    r.light_arm_rad = -60 * kPi / 180;
    r.exposure_us = 2000;
    const std::uint64_t rendered = simulator(*l.rig)->camera().frames_rendered();
    auto frame = capture(r);
    ASSERT_FALSE(frame);
    EXPECT_NE(frame.error().message.find("alarm"), std::string::npos) << frame.error().message;
    EXPECT_NE(frame.error().message.find("light arm"), std::string::npos) << frame.error().message;
    // Nothing was exposed at the wrong place.
    EXPECT_EQ(simulator(*l.rig)->camera().frames_rendered(), rendered);
}

TEST(ImagePose, FrameLostByTheCameraIsCapturedAgain) {
    Live l = start(15);
    ASSERT_TRUE(l.rig);
    l.rig->rig.capture.timeout_ms = 1500;  // the wait for the lost frame
    acquisition::CaptureFn capture = acquisition::image_rig_capture(*l.rig, 0.0);
    acquisition::CaptureRequest r;
    r.light_arm_rad = 30 * kPi / 180;
    r.exposure_us = 2000;
    ASSERT_TRUE(capture(r));
    const std::size_t retries_before = l.rig->pose_log.capture_retries;
    const std::uint64_t rendered_before = simulator(*l.rig)->camera().frames_rendered();
    // The camera's fault injection: the next frame is exposed but none of its packets is sent.
    sim::GigeFaults f;
    f.drop_frames = 1;
    simulator(*l.rig)->camera().set_faults(f);
    auto frame = capture(r);
    ASSERT_TRUE(frame) << frame.error().message;
    // One retry for the dropped frame (more only if the loaded machine lost another one: each
    // retry is one more exposure either way).
    const std::size_t retries = l.rig->pose_log.capture_retries - retries_before;
    EXPECT_GE(retries, 1u);
    EXPECT_EQ(l.rig->pose_log.repeats + l.rig->pose_log.corrections, 0u);
    ASSERT_EQ(l.rig->pose_log.notes.size(), l.rig->pose_log.capture_retries);
    for (const std::string& n : l.rig->pose_log.notes) {
        EXPECT_NE(n.find("captured again"), std::string::npos) << n;
    }
    EXPECT_EQ(simulator(*l.rig)->camera().frames_rendered(), rendered_before + 1 + retries);
    // Every frame lost: the error comes back after the retries.
    f.drop_frames = 1000;
    simulator(*l.rig)->camera().set_faults(f);
    l.rig->rig.retries = 1;
    l.rig->rig.capture.timeout_ms = 300;
    acquisition::CaptureFn once = acquisition::image_rig_capture(*l.rig, 0.0);
    const std::size_t before_lost = l.rig->pose_log.capture_retries;
    auto lost = once(r);
    ASSERT_FALSE(lost);
    EXPECT_NE(lost.error().message.find("no frame"), std::string::npos) << lost.error().message;
    EXPECT_EQ(l.rig->pose_log.capture_retries, before_lost + 1);
}

}  // namespace
}  // namespace gonio::tools
