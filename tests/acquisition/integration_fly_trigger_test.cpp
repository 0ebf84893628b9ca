// A fly-scan sweep triggered by the drive's position compare (fly_sweep.h) on the virtual rig: the
// compare table written through Modbus TCP, the camera line-triggered through Aravis (GigE Vision
// on loopback), the frames streamed. The client thread stalls for 200 ms mid-sweep (a loaded
// host); every frame is still exposed at its position, its mid-exposure on the planned angle to
// the encoder's step, since the exposures start when the drive's output pulses, not when the host
// gets round to it. (Triggered by polling, the same stall takes the frame after it late.)

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <thread>

#include "campaign_fixture.h"
#include "gonio/acquisition/point/capture_session.h"
#include "gonio/acquisition/point/fly_sweep.h"

namespace gonio::acquisition {
namespace {

using testing::make_campaign_fixture;
using testing::start_live_rig;
constexpr double kDegRad = brdf::kPi / 180;
const char* kTriggerTruth = R"({"diffuse": [0.3, 0.3, 0.3],
    "lobes": [{"distribution": "ggx", "alpha": 0.2, "shadowing": "smith-correlated",
               "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

/// The rig's camera, its host stalling `stall` once, inside the first frame request made while
/// `when()` holds: the client thread is busy elsewhere for that long.
class StallingCamera : public devices::Camera {
  public:
    StallingCamera(devices::Camera* camera,
                   std::function<bool()> when,
                   std::chrono::milliseconds stall)
        : cam_(camera), when_(std::move(when)), stall_(stall) {}
    bool stalled() const { return stalled_; }

    Expected<devices::CameraInfo> info() override { return cam_->info(); }
    Expected<void> set_exposure_us(double us) override { return cam_->set_exposure_us(us); }
    Expected<double> exposure_us() override { return cam_->exposure_us(); }
    Expected<void> set_gain(double gain) override { return cam_->set_gain(gain); }
    Expected<void> set_pixel_format(devices::PixelFormat f) override {
        return cam_->set_pixel_format(f);
    }
    Expected<void> set_roi(const devices::Roi& roi) override { return cam_->set_roi(roi); }
    Expected<devices::Frame> capture(std::chrono::milliseconds timeout) override {
        stall_once();
        return cam_->capture(timeout);
    }
    Expected<void> start_stream() override { return cam_->start_stream(); }
    Expected<devices::Frame> next_frame(std::chrono::milliseconds timeout) override {
        stall_once();
        return cam_->next_frame(timeout);
    }
    Expected<void> stop_stream() override { return cam_->stop_stream(); }
    Expected<void> start_line_stream(const std::string& line) override {
        return cam_->start_line_stream(line);
    }

  private:
    void stall_once() {
        if (!stalled_ && when_()) {
            stalled_ = true;
            std::this_thread::sleep_for(stall_);
        }
    }
    devices::Camera* cam_;
    std::function<bool()> when_;
    std::chrono::milliseconds stall_;
    bool stalled_ = false;
};

/// A detector-arm sweep over 20, 25, ..., 40 deg at 20 deg/s (light arm at 0), its exposure at
/// most 10 ms (0.2 deg of travel).
Sweep detector_sweep(std::vector<double>* targets_deg) {
    Sweep s;
    s.axis = static_cast<int>(AxisRole::kDetector);
    *targets_deg = {20, 25, 30, 35, 40};
    for (std::size_t k = 0; k < targets_deg->size(); ++k) {
        s.members.push_back(k);
    }
    s.speed = 20 * kDegRad;
    s.max_exposure_s = 0.010;
    s.smear_rad = 0.2 * kDegRad;
    // Lead-in and lead-out: the ramp (v^2 / 2a = 400 / 120 deg) and a margin.
    s.from = (20 - 4.0) * kDegRad;
    s.to = (40 + 4.0) * kDegRad;
    s.stand = brdf::RigPosed{0, s.from, 0, 0};
    return s;
}

TEST(FlyTrigger, PositionCompareFramesKeepTheirPositionsThroughAHostStall) {
    auto f = make_campaign_fixture(
        "fly_trigger", kTriggerTruth, default_campaign_spec("fly-trigger"), true, "sim4-mono.json");
    auto live = start_live_rig(f, 1);
    ASSERT_TRUE(live.sim);
    std::vector<double> targets;
    const Sweep s = detector_sweep(&targets);
    devices::Axis& arm = *live.dev.axes[s.axis];
    ASSERT_TRUE(arm.move_to(s.from / kDegRad, std::chrono::seconds(30)));
    sim::MotorControllerServer& motors = live.sim->motors();
    const int unit = f.rig.axes[s.axis].unit;
    // Mid-sweep, 3 deg before the third configuration.
    StallingCamera camera(
        live.dev.camera.get(),
        [&] { return motors.position_deg(unit) >= 27; },
        std::chrono::milliseconds(200));
    CaptureSession session(&camera, live.dev.shutter.get(), f.rig.capture, f.rig.noise);
    ASSERT_TRUE(session.prepare());
    double exposure_us = 2000;
    auto frames = run_sweep(arm,
                            session,
                            s,
                            targets,
                            &exposure_us,
                            std::chrono::seconds(30),
                            SweepTrigger::kPositionCompare);
    ASSERT_TRUE(frames) << frames.error().message;
    EXPECT_TRUE(camera.stalled()) << "the host never stalled";
    EXPECT_TRUE(frames->missed.empty()) << frames->missed.size() << " missed";
    ASSERT_EQ(frames->frames.size(), targets.size());
    for (const FlyFrame& fr : frames->frames) {
        const double t_us = fr.frame.exposure_us;
        ASSERT_GT(t_us, 0);
        ASSERT_LE(t_us, s.max_exposure_s * 1e6 * (1 + 1e-9));
        const double mid = 0.5 * (fr.latch_deg[0] + fr.latch_deg[1]);
        // The exposure spans the cruise's travel over it, centred on the configuration (to the
        // encoder's step, 0.001 deg, at either latch).
        EXPECT_NEAR(mid, targets[fr.member], 0.0011) << "member " << fr.member;
        EXPECT_NEAR(fr.latch_deg[1] - fr.latch_deg[0], 20 * t_us * 1e-6, 0.0021)
            << "member " << fr.member;
    }
    EXPECT_GT(exposure_us, 0);
    EXPECT_TRUE(std::isfinite(exposure_us));
}

}  // namespace
}  // namespace gonio::acquisition
