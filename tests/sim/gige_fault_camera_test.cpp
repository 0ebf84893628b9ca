// Faults of the simulated GigE Vision camera: lost stream packets (recovered by PACKETRESEND, or
// reported incomplete by Aravis when the camera refuses to resend), a host that stops its
// heartbeat losing control, a second host getting read access but no control, SIGTERM stopping
// `gonio camera serve`.

#include <signal.h>
#include <sys/wait.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <thread>

#include "gige_test_support.h"
#include "gonio/devices/aravis_camera.h"

namespace {

using gige_test::arv_value;
using gige_test::RawHost;
using gige_test::run;
using gige_test::ServedCamera;
using gonio::sim::GigeCamera;
using gonio::sim::GigeCameraConfig;
namespace gvcp = gonio::devices::gvcp;
namespace gvbs = gonio::devices::gvbs;
namespace gm = gonio::sim::gige_map;

GigeCameraConfig camera_config() {
    GigeCameraConfig c;
    c.sensor.width = 256;
    c.sensor.height = 192;
    c.sensor.seed = 11;
    c.packet_size = 1500;  // many packets per frame
    return c;
}

TEST(GigeCameraFault, DroppedPacketsAreResent) {
    ServedCamera cam(camera_config());
    gonio::sim::GigeFaults f;
    f.drop_every_nth_packet = 9;
    cam.camera->set_faults(f);
    const int n = 5;
    const auto c = gige_test::capture_with_aravis(cam.ip(), n, 3000, 20);
    ASSERT_TRUE(c.error.empty()) << c.error;
    EXPECT_EQ(c.complete, n);
    const auto st = cam.server->stats();
    EXPECT_GT(st.packets_dropped, 0u);
    EXPECT_GT(st.resend_requests, 0u);
    EXPECT_GE(st.packets_resent,
              st.packets_dropped * static_cast<std::uint64_t>(n) /
                  static_cast<std::uint64_t>(st.frames_sent) / 2);
}

// A frame the camera never sends: gonio's capture reports it, closes that stream and takes the
// next frame on a new one (a stream that lost its frames is not trusted again).
TEST(GigeCameraFault, CaptureAfterALostFrameRunsOnANewStream) {
    ServedCamera cam(camera_config());
    auto c = gonio::devices::AravisCamera::open_gige(cam.ip());
    ASSERT_TRUE(c) << c.error().message;
    ASSERT_TRUE((*c)->set_exposure_us(2000));
    gonio::sim::GigeFaults f;
    f.drop_frames = 1;
    cam.camera->set_faults(f);
    const auto lost = (*c)->capture(std::chrono::milliseconds(400));
    ASSERT_FALSE(lost);
    EXPECT_NE(lost.error().message.find("no frame within 400 ms"), std::string::npos)
        << lost.error().message;
    EXPECT_EQ((*c)->stream_stats().streams_opened, 1u);
    const auto next = (*c)->capture(std::chrono::milliseconds(5000));
    ASSERT_TRUE(next) << next.error().message;
    EXPECT_EQ(next->image.cols, 256);
    const auto s = (*c)->stream_stats();
    EXPECT_EQ(s.streams_opened, 2u);
    EXPECT_EQ(s.frames_missing, 1u);
    EXPECT_EQ(s.frames_completed, 1u);
    EXPECT_EQ(cam.server->stats().frames_dropped, 1u);
}

// A frame that comes after its capture timed out (the camera took longer than the timeout) is not
// taken for the next trigger's: the capture latches the camera's clock before it triggers and sets
// aside a frame stamped earlier. Each frame here is rendered at its own level (1, 2, 3 times a
// base radiance), the first one late; without the check the second capture returns the first
// frame, and every capture after it the one before its own.
// The first frame is held back until the camera has received the second trigger (the scene is
// read at each trigger), so it is late for its own capture and arrives after the next capture
// latched the camera's clock, however slowly a loaded machine runs either side.
TEST(GigeCameraFault, LateFrameOfATimedOutCaptureIsNotTakenForTheNextTrigger) {
    ServedCamera cam(camera_config());
    struct Gate {
        std::mutex m;
        std::condition_variable cv;
        int triggers = 0;
    };
    auto gate = std::make_shared<Gate>();
    const gonio::sim::SceneState scene = cam.scene;
    cam.camera->set_scene([gate, scene] {
        {
            std::lock_guard<std::mutex> lock(gate->m);
            ++gate->triggers;
        }
        gate->cv.notify_all();
        return scene;
    });
    auto calls = std::make_shared<std::atomic<int>>(0);
    cam.camera->set_renderer([calls, gate](const gonio::brdf::Brdf&,
                                           const gonio::sim::SceneState&,
                                           int,
                                           int,
                                           const gonio::devices::Roi& roi) {
        const int k = ++*calls;
        if (k == 1) {
            // Bounded, so that a camera that never sees the second trigger cannot hang the test.
            std::unique_lock<std::mutex> lock(gate->m);
            gate->cv.wait_for(lock, std::chrono::seconds(60), [&] { return gate->triggers >= 2; });
        }
        return cv::Mat(roi.height, roi.width, CV_32F, cv::Scalar(0.05 * k));
    });
    auto c = gonio::devices::AravisCamera::open_gige(cam.ip());
    ASSERT_TRUE(c) << c.error().message;
    ASSERT_TRUE((*c)->set_exposure_us(2000));
    const auto late = (*c)->capture(std::chrono::milliseconds(400));
    ASSERT_FALSE(late);
    std::vector<double> levels;
    for (int i = 0; i < 3; ++i) {
        const auto f = (*c)->capture(std::chrono::milliseconds(8000));
        ASSERT_TRUE(f) << f.error().message;
        levels.push_back(cv::mean(f->image)[0] - f->black_level);
    }
    // Frames 2, 3 and 4 at levels 2, 3 and 4 times the first: each capture got its own.
    ASSERT_GT(levels[0], 0);
    EXPECT_NEAR(levels[1] / levels[0], 1.5, 0.05);
    EXPECT_NEAR(levels[2] / levels[0], 2.0, 0.05);
    EXPECT_EQ((*c)->stream_stats().frames_stale, 1u);
    EXPECT_EQ((*c)->stream_stats().frames_completed, 3u);
    EXPECT_EQ(calls->load(), 4);
}

TEST(GigeCameraFault, UnrecoverablePacketsMakeIncompleteFrames) {
    ServedCamera cam(camera_config());
    gonio::sim::GigeFaults f;
    f.drop_every_nth_packet = 9;
    f.refuse_resend = true;
    cam.camera->set_faults(f);
    const int n = 3;
    const auto c = gige_test::capture_with_aravis(cam.ip(), n, 3000, 20);
    ASSERT_TRUE(c.error.empty()) << c.error;
    EXPECT_EQ(c.complete, 0);
    EXPECT_EQ(c.incomplete, n);
}

TEST(GigeCameraFault, SilentControllerLosesControlAfterTheHeartbeatTimeout) {
    // Device logic with explicit time: no waiting.
    GigeCameraConfig cfg = camera_config();
    cfg.heartbeat_timeout_ms = 800;
    GigeCamera cam(cfg, nullptr, {});
    const gonio::sim::HostId a{0x7F000001, 40000}, b{0x7F000001, 40001};
    const auto t0 = GigeCamera::Clock::now();
    const auto cmd = [&](const gonio::sim::HostId& h,
                         const gvcp::CommandPacket& c,
                         GigeCamera::Clock::time_point t) {
        const auto bytes = gvcp::encode(c);
        auto reply = cam.handle_gvcp(bytes.data(), bytes.size(), h, t);
        EXPECT_TRUE(reply.has_value());
        return gvcp::parse_ack(reply->data(), reply->size())->status;
    };
    const auto ms = [](int v) { return std::chrono::milliseconds(v); };
    EXPECT_EQ(cmd(a, gvcp::make_write_reg(1, {{gvbs::kControlChannelPrivilege, 2}}), t0),
              gvcp::Status::kSuccess);
    // A keeps talking within the timeout: it keeps control.
    EXPECT_EQ(cmd(a, gvcp::make_read_reg(2, {gvbs::kControlChannelPrivilege}), t0 + ms(700)),
              gvcp::Status::kSuccess);
    EXPECT_FALSE(cam.check_heartbeat(t0 + ms(1400)));
    EXPECT_EQ(cmd(b, gvcp::make_write_reg(3, {{gvbs::kControlChannelPrivilege, 2}}), t0 + ms(1400)),
              gvcp::Status::kAccessDenied);
    // A falls silent: 800 ms after its last command control is released.
    EXPECT_FALSE(cam.check_heartbeat(t0 + ms(1500)));
    EXPECT_TRUE(cam.check_heartbeat(t0 + ms(1501)));
    EXPECT_FALSE(cam.controller().has_value());
    EXPECT_EQ(cmd(b, gvcp::make_write_reg(4, {{gvbs::kControlChannelPrivilege, 2}}), t0 + ms(1600)),
              gvcp::Status::kSuccess);
    // A's writes are now refused.
    EXPECT_EQ(cmd(a, gvcp::make_write_reg(5, {{gm::kExposureTicks, 5000}}), t0 + ms(1700)),
              gvcp::Status::kAccessDenied);
}

TEST(GigeCameraFault, SilentHostLosesControlOverTheNetwork) {
    ServedCamera cam(camera_config());
    RawHost a(cam.ip()), b(cam.ip());
    ASSERT_EQ(a.write_reg(gvbs::kHeartbeatTimeout, 500), gvcp::Status::kSuccess);
    ASSERT_EQ(a.write_reg(gvbs::kControlChannelPrivilege, gvbs::kCcpControl),
              gvcp::Status::kSuccess);
    ASSERT_EQ(b.write_reg(gvbs::kControlChannelPrivilege, gvbs::kCcpControl),
              gvcp::Status::kAccessDenied);
    // A sends nothing more. B asks again until the device has released A (bounded attempts).
    gvcp::Status st = gvcp::Status::kAccessDenied;
    for (int attempt = 0; attempt < 200 && st != gvcp::Status::kSuccess; ++attempt) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        st = b.write_reg(gvbs::kControlChannelPrivilege, gvbs::kCcpControl);
    }
    EXPECT_EQ(st, gvcp::Status::kSuccess);
    EXPECT_EQ(a.write_reg(gm::kExposureTicks, 5000), gvcp::Status::kAccessDenied);
    std::uint32_t ccp = 99;
    EXPECT_EQ(a.read_reg(gvbs::kControlChannelPrivilege, &ccp), gvcp::Status::kSuccess);
    EXPECT_EQ(ccp, 0u);  // A learns it lost control
}

TEST(GigeCameraFault, SecondHostReadsButCannotControl) {
    ServedCamera cam(camera_config());
    GError* err = nullptr;
    ArvCamera* first = arv_camera_new(cam.ip().c_str(), &err);
    ASSERT_NE(first, nullptr) << (err ? err->message : "");
    arv_camera_set_exposure_time(first, 3000, &err);
    ASSERT_EQ(err, nullptr);
    // arv-tool is a second application: it reads, but its write is refused.
    const auto r = run("arv-tool-0.8 -a " + cam.ip() + " control Width ExposureTime=7000");
    EXPECT_EQ(arv_value(r.out, "Width"), "256") << r.out;
    EXPECT_DOUBLE_EQ(cam.camera->exposure_settings().exposure_us, 3000.0) << r.out;
    RawHost other(cam.ip());
    std::uint32_t width = 0;
    EXPECT_EQ(other.read_reg(gm::kRoiBlock, &width), gvcp::Status::kSuccess);
    EXPECT_EQ(width, 256u);
    EXPECT_EQ(other.write_reg(gm::kRoiBlock, 128), gvcp::Status::kAccessDenied);
    EXPECT_EQ(other.write_reg(gvbs::kControlChannelPrivilege, gvbs::kCcpControl),
              gvcp::Status::kAccessDenied);
    g_object_unref(first);
    // Closing the first application released control: now the other host may take it.
    EXPECT_EQ(other.write_reg(gvbs::kControlChannelPrivilege, gvbs::kCcpControl),
              gvcp::Status::kSuccess);
}

TEST(GigeCameraFault, SigtermStopsCameraServeWhileStreaming) {
    int out[2];
    ASSERT_EQ(pipe(out), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        dup2(out[1], 1);
        close(out[0]);
        execl(GONIO_BINARY_DIR "/tools/gonio",
              "gonio",
              "camera",
              "serve",
              "--ip",
              "auto",
              "--width",
              "256",
              "--height",
              "192",
              static_cast<char*>(nullptr));
        _exit(127);
    }
    close(out[1]);
    std::string line;
    char ch;
    while (read(out[0], &ch, 1) == 1 && ch != '\n') {
        line += ch;
    }
    ASSERT_EQ(line.rfind("gige://127.", 0), 0u) << line;
    const std::string ip = line.substr(std::string("gige://").size());
    // A host streams from it, then the server is told to stop mid-acquisition.
    GError* err = nullptr;
    ArvCamera* cam = arv_camera_new(ip.c_str(), &err);
    ASSERT_NE(cam, nullptr) << (err ? err->message : "");
    ArvStream* stream = arv_camera_create_stream(cam, nullptr, nullptr, &err);
    ASSERT_NE(stream, nullptr);
    const guint payload = arv_camera_get_payload(cam, &err);
    for (int i = 0; i < 2; ++i) {
        arv_stream_push_buffer(stream, arv_buffer_new(payload, nullptr));
    }
    arv_camera_start_acquisition(cam, &err);
    // Streaming is under way once a complete frame has arrived (bounded number of tries).
    bool streamed = false;
    for (int i = 0; i < 10 && !streamed; ++i) {
        ArvBuffer* b = arv_stream_timeout_pop_buffer(stream, 10000000);
        ASSERT_NE(b, nullptr);
        streamed = arv_buffer_get_status(b) == ARV_BUFFER_STATUS_SUCCESS;
        arv_stream_push_buffer(stream, b);
    }
    EXPECT_TRUE(streamed);
    ASSERT_EQ(kill(pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    close(out[0]);
    g_object_unref(stream);
    g_object_unref(cam);
    // The address is free again: a new camera can be served on it.
    auto again_camera =
        std::make_shared<gonio::sim::GigeCamera>(camera_config(), nullptr, gonio::sim::SceneFn());
    gonio::sim::GigeServer again(again_camera);
    ASSERT_TRUE(again.start(ip)) << ip;
    RawHost h(ip);
    std::uint32_t v = 0;
    EXPECT_EQ(h.read_reg(gvbs::kNumberOfStreamChannels, &v), gvcp::Status::kSuccess);
}

}  // namespace
