// The U3V camera driver against the simulated device, in-process and over TCP on 127.0.0.1.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "gonio/devices/camera_factory.h"
#include "gonio/devices/u3v_camera.h"
#include "gonio/devices/u3v_tcp.h"
#include "gonio/sim/camera_render.h"
#include "gonio/sim/u3v_device.h"
#include "gonio/sim/u3v_tcp_server.h"

namespace {

using gonio::devices::PixelFormat;
using gonio::devices::U3vCamera;
using namespace std::chrono_literals;

// f = rho / pi in every channel (Lambert 1760): an independent closed form for the expected signal.
class ConstantBrdf : public gonio::brdf::Brdf {
  public:
    explicit ConstantBrdf(double rho) : rho_(rho) {}
    gonio::brdf::Rgbd eval(const gonio::brdf::Vec3d& wi,
                           const gonio::brdf::Vec3d& wo) const override {
        if (wi.z() <= 0 || wo.z() <= 0) {
            return gonio::brdf::Rgbd::Zero();
        }
        return gonio::brdf::Rgbd::Constant(rho_ / M_PI);
    }
    bool isotropic() const override { return true; }
    std::string describe() const override { return "constant"; }

  private:
    double rho_;
};

gonio::sim::U3vDeviceConfig small_config(bool zipped) {
    gonio::sim::U3vDeviceConfig c;
    c.sensor.width = 160;
    c.sensor.height = 120;
    c.sensor.seed = 7;
    c.zipped_xml = zipped;
    return c;
}

std::shared_ptr<gonio::sim::U3vDevice> make_device(bool zipped, double rho = 0.5) {
    return std::make_shared<gonio::sim::U3vDevice>(
        small_config(zipped), std::make_shared<ConstantBrdf>(rho), nullptr);
}

std::unique_ptr<U3vCamera> open_mem(std::shared_ptr<gonio::sim::U3vDevice> d) {
    auto cam = U3vCamera::open(gonio::sim::make_memory_transport(std::move(d)));
    EXPECT_TRUE(cam.has_value()) << (cam ? "" : cam.error().message);
    return cam ? std::move(*cam) : nullptr;
}

double patch_mean(const cv::Mat& img, int sensor_w, int sensor_h) {
    double sum = 0;
    int n = 0;
    for (int y = 0; y < img.rows; ++y) {
        for (int x = 0; x < img.cols; ++x) {
            if (gonio::sim::in_point_patch(x + 0.5, y + 0.5, sensor_w, sensor_h)) {
                sum += img.at<std::uint16_t>(y, x);
                ++n;
            }
        }
    }
    return sum / n;
}

class U3vBothXml : public ::testing::TestWithParam<bool> {};

TEST_P(U3vBothXml, OpensAndReadsIdentityAndFeatures) {
    auto cam = open_mem(make_device(GetParam()));
    ASSERT_TRUE(cam);
    EXPECT_EQ(cam->xml_was_zipped(), GetParam());
    auto info = cam->info();
    ASSERT_TRUE(info);
    EXPECT_EQ(info->vendor, "gonio");
    EXPECT_EQ(info->serial, "SIM0001");
    EXPECT_EQ(info->sensor_width, 160);
    EXPECT_EQ(info->sensor_height, 120);
    EXPECT_EQ(info->bit_depth, 16);
    auto serial = cam->node_map().get_string("DeviceSerialNumber");
    ASSERT_TRUE(serial) << serial.error().message;
    EXPECT_EQ(*serial, "SIM0001");

    ASSERT_TRUE(cam->set_exposure_us(2500.0));
    auto e = cam->exposure_us();
    ASSERT_TRUE(e);
    EXPECT_DOUBLE_EQ(*e, 2500.0);
    ASSERT_TRUE(cam->set_gain(2.0));
    auto g = cam->gain();
    ASSERT_TRUE(g);
    EXPECT_NEAR(*g, 2.0, 1e-12);
    auto db = cam->node_map().get_float("Gain");
    ASSERT_TRUE(db);
    EXPECT_NEAR(*db, 20 * std::log10(2.0), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(PlainAndZipped, U3vBothXml, ::testing::Values(false, true));

TEST(U3vCamera, OutOfRangeFeatureIsRejectedWithItsName) {
    auto cam = open_mem(make_device(false));
    ASSERT_TRUE(cam);
    auto r = cam->set_exposure_us(1e9);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("ExposureTime"), std::string::npos) << r.error().message;
    auto w = cam->node_map().set_int("Width", 10000);
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("Width"), std::string::npos);
    auto ro = cam->node_map().set_int("WidthMax", 10);
    ASSERT_FALSE(ro);
    EXPECT_NE(ro.error().message.find("read-only"), std::string::npos) << ro.error().message;
}

TEST(U3vCamera, DeviceStatusErrorsCarryTheGenCpName) {
    auto cam = open_mem(make_device(false));
    ASSERT_TRUE(cam);
    auto r = cam->read_memory(0x7000000, 4);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("GENCP_INVALID_ADDRESS"), std::string::npos)
        << r.error().message;
    auto w = cam->write_memory(0x0, {1, 2, 3, 4});
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("GENCP_WRITE_PROTECT"), std::string::npos);
}

class U3vFormats : public ::testing::TestWithParam<PixelFormat> {};

TEST_P(U3vFormats, CapturedMeanMatchesTheRadiometricChain) {
    const PixelFormat f = GetParam();
    const double rho = 0.5;
    const double exposure_us = 4000;
    const double gain = 1.5;
    auto dev = make_device(false, rho);
    gonio::sim::SceneState scene;
    const double theta_i = 0.6;
    scene.wi = {std::sin(theta_i), 0, std::cos(theta_i)};
    scene.wo = {-std::sin(0.3), 0, std::cos(0.3)};
    scene.irradiance_w_m2 = 2.0;
    dev->set_scene([scene] { return scene; });
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    ASSERT_TRUE(cam->set_pixel_format(f));
    ASSERT_TRUE(cam->set_exposure_us(exposure_us));
    ASSERT_TRUE(cam->set_gain(gain));
    auto frame = cam->capture(1000ms);
    ASSERT_TRUE(frame) << frame.error().message;
    const auto& p = dev->config().sensor;
    const int bits = f == PixelFormat::kMono8 ? 8 : f == PixelFormat::kMono12 ? 12 : 16;
    EXPECT_EQ(frame->bit_depth, bits);
    EXPECT_EQ(frame->image.type(), CV_16U);
    EXPECT_EQ(frame->image.cols, 160);
    EXPECT_DOUBLE_EQ(frame->saturation_level, std::ldexp(1.0, bits) - 1);
    EXPECT_DOUBLE_EQ(frame->exposure_us, exposure_us);
    EXPECT_NEAR(frame->gain, gain, 1e-12);
    EXPECT_DOUBLE_EQ(frame->black_level, p.black_level16 * std::ldexp(1.0, bits - 16));
    // Independent closed form: counts = black + (R f E cos(theta_i) t + D t) g / K_b.
    const double t = exposure_us * 1e-6;
    const double K = p.e_per_count16 * std::ldexp(1.0, 16 - bits);
    const double L = rho / M_PI * scene.irradiance_w_m2 * std::cos(theta_i);
    const double mu_e = p.responsivity_e_per_s * L * t + p.dark_current_e_per_s * t;
    const double expected = frame->black_level + mu_e * gain / K;
    const double var =
        (gain / K) * (gain / K) * (mu_e + p.read_noise_e * p.read_noise_e) + 1.0 / 12;
    const double r = 0.25 * 120;
    const double n = M_PI * r * r;
    const double mean = patch_mean(frame->image, 160, 120);
    EXPECT_NEAR(mean, expected, 5 * std::sqrt(var / n) + 0.5) << "seed 7, format " << bits;
}

INSTANTIATE_TEST_SUITE_P(Mono,
                         U3vFormats,
                         ::testing::Values(PixelFormat::kMono8,
                                           PixelFormat::kMono12,
                                           PixelFormat::kMono16));

TEST(U3vCamera, RoiFramesHaveTheRequestedSizeAndOffset) {
    auto cam = open_mem(make_device(false));
    ASSERT_TRUE(cam);
    ASSERT_TRUE(cam->set_roi({40, 30, 64, 48}));
    auto frame = cam->capture(1000ms);
    ASSERT_TRUE(frame) << frame.error().message;
    EXPECT_EQ(frame->image.cols, 64);
    EXPECT_EQ(frame->image.rows, 48);
    // The patch centre (80, 60) of the sensor is at (40, 30) in the ROI and is lit.
    EXPECT_GT(frame->image.at<std::uint16_t>(30, 40), frame->black_level + 100);
    EXPECT_LT(frame->image.at<std::uint16_t>(0, 0), frame->black_level + 100);
    ASSERT_TRUE(cam->set_roi({}));
    auto full = cam->capture(1000ms);
    ASSERT_TRUE(full);
    EXPECT_EQ(full->image.cols, 160);
}

TEST(U3vCamera, StreamDeliversConsecutiveBlocks) {
    auto dev = make_device(false);
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    ASSERT_TRUE(cam->start_stream());
    std::uint64_t last = 0;
    for (int i = 0; i < 5; ++i) {
        auto f = cam->next_frame(1000ms);
        ASSERT_TRUE(f) << f.error().message;
        if (i > 0) {
            EXPECT_EQ(f->frame_id, last + 1);
        }
        last = f->frame_id;
    }
    ASSERT_TRUE(cam->stop_stream());
    EXPECT_FALSE(dev->streaming_continuous());
    // Back to single frames after a stream.
    auto one = cam->capture(1000ms);
    ASSERT_TRUE(one) << one.error().message;
}

TEST(U3vCamera, ShutterClosedGivesTheDarkLevel) {
    auto dev = make_device(false, 0.9);
    gonio::sim::SceneState dark;
    dark.shutter_open = false;
    dev->set_scene([dark] { return dark; });
    auto cam = open_mem(dev);
    ASSERT_TRUE(cam);
    ASSERT_TRUE(cam->set_exposure_us(1e5));
    auto f = cam->capture(1000ms);
    ASSERT_TRUE(f);
    const auto& p = dev->config().sensor;
    const double expected = p.black_level16 + p.dark_current_e_per_s * 0.1 / p.e_per_count16;
    EXPECT_NEAR(cv::mean(f->image)[0], expected, 0.5);
}

TEST(U3vTcp, SameBytesOverLoopbackFromAnotherConnection) {
    auto dev = make_device(true);
    gonio::sim::U3vTcpServer server(dev);
    ASSERT_TRUE(server.start(0));
    ASSERT_GT(server.port(), 0);
    auto cam = gonio::devices::open_camera(server.address());
    ASSERT_TRUE(cam) << cam.error().message;
    auto info = (*cam)->info();
    ASSERT_TRUE(info);
    EXPECT_EQ(info->serial, "SIM0001");
    ASSERT_TRUE((*cam)->set_exposure_us(1000));
    auto f = (*cam)->capture(2000ms);
    ASSERT_TRUE(f) << f.error().message;
    EXPECT_EQ(f->image.rows, 120);
    ASSERT_TRUE((*cam)->start_stream());
    for (int i = 0; i < 3; ++i) {
        auto s = (*cam)->next_frame(2000ms);
        ASSERT_TRUE(s) << s.error().message;
    }
    ASSERT_TRUE((*cam)->stop_stream());
    cam->reset();
    // A second host can connect after the first left.
    auto again = gonio::devices::open_camera(server.address());
    ASSERT_TRUE(again) << again.error().message;
}

TEST(U3vFactory, InProcessRegistryAndBadAddresses) {
    auto dev = make_device(false);
    gonio::sim::register_in_process_camera("bench-a", dev);
    auto cam = gonio::devices::open_camera("u3v-mem:bench-a");
    ASSERT_TRUE(cam) << cam.error().message;
    auto missing = gonio::devices::open_camera("u3v-mem:nope");
    ASSERT_FALSE(missing);
    EXPECT_NE(missing.error().message.find("nope"), std::string::npos);
    auto bad = gonio::devices::open_camera("ftp:1");
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("unknown scheme"), std::string::npos);
    auto port = gonio::devices::open_camera("u3v-tcp://127.0.0.1:99999");
    ASSERT_FALSE(port);
}

}  // namespace
