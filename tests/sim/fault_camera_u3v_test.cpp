// Injected device faults are recovered or reported clearly, within bounded time.

#include <gtest/gtest.h>

#include <memory>

#include "gonio/devices/camera_factory.h"
#include "gonio/devices/u3v_camera.h"
#include "gonio/sim/u3v_device.h"
#include "gonio/sim/u3v_tcp_server.h"

namespace {

using gonio::devices::U3vCamera;
using gonio::sim::U3vDevice;
using gonio::sim::U3vFaults;
using namespace std::chrono_literals;

std::shared_ptr<U3vDevice> make_device() {
    gonio::sim::U3vDeviceConfig c;
    c.sensor.width = 96;
    c.sensor.height = 64;
    return std::make_shared<U3vDevice>(c, nullptr, nullptr);
}

std::unique_ptr<U3vCamera> open_mem(std::shared_ptr<U3vDevice> d,
                                    gonio::devices::U3vOptions o = {}) {
    auto cam = U3vCamera::open(gonio::sim::make_memory_transport(std::move(d)), o);
    EXPECT_TRUE(cam.has_value()) << (cam ? "" : cam.error().message);
    return cam ? std::move(*cam) : nullptr;
}

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

TEST(U3vFault, DroppedFrameIsReportedAndTheNextCaptureWorks) {
    auto dev = make_device();
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    U3vFaults f;
    f.drop_frames = 1;
    dev->set_faults(f);
    auto lost = cam->capture(200ms);
    ASSERT_FALSE(lost);
    EXPECT_TRUE(contains(lost.error().message, "no frame within")) << lost.error().message;
    auto ok = cam->capture(200ms);
    ASSERT_TRUE(ok) << ok.error().message;
}

TEST(U3vFault, CorruptedTrailerRejectsTheFrameOnly) {
    auto dev = make_device();
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    U3vFaults f;
    f.corrupt_trailers = 1;
    dev->set_faults(f);
    auto bad = cam->capture(200ms);
    ASSERT_FALSE(bad);
    EXPECT_TRUE(contains(bad.error().message, "U3V trailer: magic")) << bad.error().message;
    EXPECT_EQ(cam->stats().bad_frames, 1u);
    auto ok = cam->capture(200ms);
    ASSERT_TRUE(ok) << ok.error().message;
}

TEST(U3vFault, PendingAcknowledgesExtendTheDeadline) {
    auto dev = make_device();
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    U3vFaults f;
    f.pending_acks = 3;
    f.pending_ms = 100;
    dev->set_faults(f);
    const auto commands = cam->stats().commands;
    ASSERT_TRUE(cam->set_exposure_us(1234));
    auto e = cam->exposure_us();
    ASSERT_TRUE(e);
    EXPECT_DOUBLE_EQ(*e, 1234);
    // Three commands (write, read back, read) each waited through one PENDING_ACK.
    EXPECT_EQ(cam->stats().commands - commands, 3u);
    EXPECT_EQ(cam->stats().pending_acks, 3u);
    EXPECT_EQ(cam->stats().retries, 0u);
}

TEST(U3vFault, EndlessPendingIsBoundedByMaxPendingTotal) {
    auto dev = make_device();
    gonio::devices::U3vOptions o;
    o.max_pending_total = 20ms;
    auto cam = open_mem(dev, o);
    ASSERT_TRUE(cam);
    U3vFaults f;
    f.pending_acks = 1000;
    f.pending_ms = 5000;
    dev->set_faults(f);
    auto r = cam->exposure_us();
    ASSERT_FALSE(r);
    EXPECT_TRUE(contains(r.error().message, "PENDING_ACK")) << r.error().message;
}

TEST(U3vFault, LostAcknowledgeIsRetriedWithTheSameRequest) {
    auto dev = make_device();
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    const auto retries = cam->stats().retries;
    U3vFaults f;
    f.lose_acks = 1;
    dev->set_faults(f);
    auto e = cam->exposure_us();
    ASSERT_TRUE(e) << e.error().message;
    EXPECT_EQ(cam->stats().retries, retries + 1);
    f = {};
    f.never_answer_after_pending = 1;
    dev->set_faults(f);
    auto again = cam->exposure_us();
    ASSERT_TRUE(again) << again.error().message;
}

TEST(U3vFault, TooManyLostAcknowledgesGiveUpAfterMaxAttempts) {
    auto dev = make_device();
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    U3vFaults f;
    f.lose_acks = 10;
    dev->set_faults(f);
    auto r = cam->exposure_us();
    ASSERT_FALSE(r);
    EXPECT_TRUE(contains(r.error().message, "no acknowledge after 3 attempts"))
        << r.error().message;
    dev->set_faults({});
    EXPECT_TRUE(cam->exposure_us());
}

TEST(U3vFault, VanishedDeviceInProcessIsReported) {
    auto dev = make_device();
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    U3vFaults f;
    f.disappeared = true;
    dev->set_faults(f);
    auto r = cam->capture(100ms);
    ASSERT_FALSE(r);
    EXPECT_TRUE(contains(r.error().message, "not responding")) << r.error().message;
}

TEST(U3vFault, VanishedDeviceOverTcpClosesTheConnection) {
    auto dev = make_device();
    gonio::sim::U3vTcpServer server(dev);
    ASSERT_TRUE(server.start(0));
    auto cam = gonio::devices::open_camera(server.address());
    ASSERT_TRUE(cam) << cam.error().message;
    U3vFaults f;
    f.disappeared = true;
    dev->set_faults(f);
    auto r = (*cam)->capture(1000ms);
    ASSERT_FALSE(r);
    EXPECT_TRUE(contains(r.error().message, "closed") ||
                contains(r.error().message, "not responding"))
        << r.error().message;
    // While gone, nobody can connect a working camera.
    auto again = gonio::devices::open_camera(server.address());
    EXPECT_FALSE(again);
}

TEST(U3vFault, FaultsOverTcpAreRecoveredLikeInProcess) {
    auto dev = make_device();
    gonio::sim::U3vTcpServer server(dev);
    ASSERT_TRUE(server.start(0));
    auto opened = gonio::devices::open_camera(server.address());
    ASSERT_TRUE(opened) << opened.error().message;
    auto& cam = *opened;
    U3vFaults f;
    f.pending_acks = 2;
    f.pending_ms = 200;
    f.corrupt_trailers = 1;
    dev->set_faults(f);
    ASSERT_TRUE(cam->set_exposure_us(500));
    auto bad = cam->capture(2000ms);
    ASSERT_FALSE(bad);
    EXPECT_TRUE(contains(bad.error().message, "trailer")) << bad.error().message;
    auto ok = cam->capture(2000ms);
    ASSERT_TRUE(ok) << ok.error().message;
}

}  // namespace
