// The simulated GigE Vision camera through software we did not write: arv-tool-0.8 reads and
// writes its features, Aravis's C API captures frames whose mean signal matches the EMVA model of
// the ground truth computed here, and raw GVCP bytes written from the specification get the
// specified answers.

#include <cmath>
#include <cstring>

#include "gige_test_support.h"

namespace {

using gige_test::arv_value;
using gige_test::RawHost;
using gige_test::run;
using gige_test::ServedCamera;
using gonio::sim::ExposureNaming;
using gonio::sim::GigeCameraConfig;
namespace gvcp = gonio::devices::gvcp;
namespace gvbs = gonio::devices::gvbs;

GigeCameraConfig small_camera(ExposureNaming naming = ExposureNaming::kSfnc) {
    GigeCameraConfig c;
    c.sensor.width = 320;
    c.sensor.height = 240;
    c.sensor.seed = 7;
    c.exposure_naming = naming;
    return c;
}

TEST(GigeCamera, ArvToolReadsTheFeatures) {
    ServedCamera cam(small_camera());
    const auto r =
        run("arv-tool-0.8 -a " + cam.ip() + " control Width Height PixelFormat ExposureTime");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(arv_value(r.out, "Width"), "320") << r.out;
    EXPECT_EQ(arv_value(r.out, "Height"), "240") << r.out;
    EXPECT_EQ(arv_value(r.out, "PixelFormat"), "Mono16") << r.out;
    // Power-up exposure: 100000 ticks of 100 ns through the Converter.
    EXPECT_EQ(arv_value(r.out, "ExposureTime"), "10000") << r.out;
}

TEST(GigeCamera, ArvToolWritesReachTheSensorSettings) {
    ServedCamera cam(small_camera());
    const auto r = run("arv-tool-0.8 -a " + cam.ip() +
                       " control Width=200 Height=100 OffsetX=16 PixelFormat=Mono12 "
                       "ExposureTime=2500 GainSelector=DigitalAll Gain=6");
    ASSERT_EQ(r.status, 0) << r.out;
    const gonio::sim::ExposureSettings s = cam.camera->exposure_settings();
    EXPECT_DOUBLE_EQ(s.exposure_us, 2500.0);
    EXPECT_NEAR(s.gain, std::pow(10.0, 6.0 / 20.0), 1e-12);
    EXPECT_EQ(s.format, gonio::devices::PixelFormat::kMono12);
    // Read back in a second session: the registers kept the values (ROI through pAddress).
    const auto back = run("arv-tool-0.8 -a " + cam.ip() +
                          " control Width Height OffsetX PayloadSize GainSelector Gain");
    ASSERT_EQ(back.status, 0) << back.out;
    EXPECT_EQ(arv_value(back.out, "Width"), "200") << back.out;
    EXPECT_EQ(arv_value(back.out, "Height"), "100") << back.out;
    EXPECT_EQ(arv_value(back.out, "OffsetX"), "16") << back.out;
    // IntSwissKnife: 200 x 100 pixels of a 16-bit container.
    EXPECT_EQ(arv_value(back.out, "PayloadSize"), "40000") << back.out;
    EXPECT_EQ(arv_value(back.out, "GainSelector"), "DigitalAll") << back.out;
    EXPECT_EQ(arv_value(back.out, "Gain"), "6") << back.out;
}

// The trigger input: arv-tool writes TriggerMode, TriggerSource and TriggerActivation through the
// StructReg; a second session reads them back, the register holds the fields where the map says
// (bit 0 mode, bits 15..8 source, 23..16 activation), and a pulse on Line1 starts a frame only
// while the camera acquires with that source.
TEST(GigeCamera, ArvToolSetsTheLineTrigger) {
    ServedCamera cam(small_camera());
    const auto r = run("arv-tool-0.8 -a " + cam.ip() +
                       " control TriggerSelector=FrameStart TriggerMode=On TriggerSource=Line1 "
                       "TriggerActivation=FallingEdge");
    ASSERT_EQ(r.status, 0) << r.out;
    const auto back =
        run("arv-tool-0.8 -a " + cam.ip() + " control TriggerMode TriggerSource TriggerActivation");
    ASSERT_EQ(back.status, 0) << back.out;
    EXPECT_EQ(arv_value(back.out, "TriggerMode"), "On") << back.out;
    EXPECT_EQ(arv_value(back.out, "TriggerSource"), "Line1") << back.out;
    EXPECT_EQ(arv_value(back.out, "TriggerActivation"), "FallingEdge") << back.out;
    RawHost host(cam.ip());
    std::uint32_t v = 0;
    ASSERT_EQ(host.read_reg(gonio::sim::gige_map::kTriggerControl, &v), gvcp::Status::kSuccess);
    EXPECT_EQ(v, 0x00010101u);
    // Not acquiring: the pulse is ignored.
    const auto now = gonio::sim::GigeCamera::Clock::now();
    EXPECT_FALSE(cam.camera->line_pulse(now, std::chrono::microseconds(100), nullptr));
    // A source the map does not have is refused.
    EXPECT_NE(host.write_reg(gonio::sim::gige_map::kTriggerControl, 0x00000201u),
              gvcp::Status::kSuccess);
    const auto sw = run("arv-tool-0.8 -a " + cam.ip() + " control TriggerSource=Software");
    ASSERT_EQ(sw.status, 0) << sw.out;
    ASSERT_EQ(host.read_reg(gonio::sim::gige_map::kTriggerControl, &v), gvcp::Status::kSuccess);
    EXPECT_EQ(v, 0x00010001u);
}

TEST(GigeCamera, ArvToolUsesTheAbsNaming) {
    ServedCamera cam(small_camera(ExposureNaming::kAbs));
    const auto r =
        run("arv-tool-0.8 -a " + cam.ip() + " control ExposureTimeAbs=1234.5 ExposureTimeRaw");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_DOUBLE_EQ(cam.camera->exposure_settings().exposure_us, 1234.5);
    EXPECT_EQ(arv_value(r.out, "ExposureTimeRaw"), "12345") << r.out;
    // The SFNC name is absent from this XML.
    const auto sfnc = run("arv-tool-0.8 -a " + cam.ip() + " control ExposureTime");
    EXPECT_EQ(sfnc.out.find("ExposureTime = "), std::string::npos) << sfnc.out;
}

TEST(GigeCamera, SelectorsIndexTheirTables) {
    GigeCameraConfig c = small_camera();
    c.sensor_temperature_c = 51.25;
    c.mainboard_temperature_c = -3.5;
    ServedCamera cam(c);
    const auto s = run("arv-tool-0.8 -a " + cam.ip() +
                       " control DeviceTemperatureSelector=Sensor "
                       "DeviceTemperature");
    EXPECT_EQ(arv_value(s.out, "DeviceTemperature"), "51.25") << s.out;
    const auto m = run("arv-tool-0.8 -a " + cam.ip() +
                       " control DeviceTemperatureSelector=Mainboard "
                       "DeviceTemperature");
    EXPECT_EQ(arv_value(m.out, "DeviceTemperature"), "-3.5") << m.out;
}

// Mean counts of a Lambertian patch, written from the EMVA 1288 linear model and the
// collimated-beam radiance L = rho / pi * E cos(theta_i), independently of the sensor code.
double expected_mean(
    const gonio::sim::SensorParams& p, double rho, double theta_i, double exposure_us, bool lit) {
    const double L = lit ? rho / M_PI * 1.0 * std::cos(theta_i) : 0.0;
    const double t = exposure_us * 1e-6;
    const double electrons = p.responsivity_e_per_s * L * t + p.dark_current_e_per_s * t;
    return p.black_level16 + electrons / p.e_per_count16;
}

TEST(GigeCamera, AravisCapturesCompleteFramesWithTheExpectedSignal) {
    const GigeCameraConfig cfg = small_camera();
    const double rho = 0.8, theta_i = 0.5, exposure_us = 4000;
    ServedCamera cam(cfg, rho, theta_i);
    const int n = 6;
    const auto c = gige_test::capture_with_aravis(cam.ip(), n, exposure_us, 50);
    ASSERT_TRUE(c.error.empty()) << c.error;
    EXPECT_EQ(c.complete, n);
    EXPECT_EQ(c.incomplete, 0);
    ASSERT_EQ(c.width, 320);
    ASSERT_EQ(c.height, 240);
    // The patch is the central disc of radius 0.25 * 240 = 60 px; average a 60 x 60 box inside it
    // and a 40 x 40 corner of the black background.
    double patch = 0, dark = 0;
    std::size_t np = 0, nd = 0;
    for (const auto& f : c.frames) {
        ASSERT_EQ(f.size(), 320u * 240u);
        for (int y = 90; y < 150; ++y) {
            for (int x = 130; x < 190; ++x) {
                patch += f[static_cast<std::size_t>(y) * 320 + x];
                ++np;
            }
        }
        for (int y = 0; y < 40; ++y) {
            for (int x = 0; x < 40; ++x) {
                dark += f[static_cast<std::size_t>(y) * 320 + x];
                ++nd;
            }
        }
    }
    patch /= static_cast<double>(np);
    dark /= static_cast<double>(nd);
    const double mu_patch = expected_mean(cfg.sensor, rho, theta_i, exposure_us, true);
    const double mu_dark = expected_mean(cfg.sensor, rho, theta_i, exposure_us, false);
    // Standard error of the mean: sqrt(variance / n) with the EMVA variance in counts.
    const double k = 1.0 / cfg.sensor.e_per_count16;
    const double e_patch = (mu_patch - cfg.sensor.black_level16) / k;
    const double read2 = cfg.sensor.read_noise_e * cfg.sensor.read_noise_e;
    const double se_patch = std::sqrt((k * k * (e_patch + read2) + 1.0 / 12.0) / np);
    EXPECT_NEAR(patch, mu_patch, 6 * se_patch) << "seed 7";
    EXPECT_NEAR(dark, mu_dark, 0.5) << "seed 7";
    EXPECT_GT(cam.server->stats().frames_sent, 0u);
}

// Raw GVCP bytes written from the GigE Vision specification (ch. 15), not through our encoder.
TEST(GigeCamera, AnswersRawGvcpFromTheSpecification) {
    ServedCamera cam(small_camera());
    RawHost host(cam.ip());
    // DISCOVERY_CMD, flags 0x11 (acknowledge + allow broadcast ack), req_id 0x0001.
    auto d = host.exchange({0x42, 0x11, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01});
    ASSERT_EQ(d.size(), 8u + 0xF8u);
    const std::vector<std::uint8_t> d_head(d.begin(), d.begin() + 8);
    EXPECT_EQ(d_head, (std::vector<std::uint8_t>{0x00, 0x00, 0x00, 0x03, 0x00, 0xF8, 0x00, 0x01}));
    const std::uint8_t* boot = d.data() + 8;
    EXPECT_EQ(boot[0x00], 0x00);  // version 2.0: major in the upper half
    EXPECT_EQ(boot[0x01], 0x02);
    EXPECT_EQ(boot[0x04] & 0x80, 0x80);  // big-endian device
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(boot + 0x48)), "gonio");
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(boot + 0x68)), "SimCam GigE");
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(boot + 0xD8)), "SIM0001");
    EXPECT_EQ((std::vector<std::uint8_t>(boot + 0x24, boot + 0x28)),
              (std::vector<std::uint8_t>{127, 0, 0, 1}));
    // READREG_CMD of the number of stream channels (0x0904), req_id 0x0002.
    auto r =
        host.exchange({0x42, 0x01, 0x00, 0x80, 0x00, 0x04, 0x00, 0x02, 0x00, 0x00, 0x09, 0x04});
    EXPECT_EQ(r,
              (std::vector<std::uint8_t>{
                  0x00, 0x00, 0x00, 0x81, 0x00, 0x04, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01}));
    // READMEM_CMD of the first URL (0x0200), 64 bytes.
    auto m = host.exchange({0x42,
                            0x01,
                            0x00,
                            0x84,
                            0x00,
                            0x08,
                            0x00,
                            0x03,
                            0x00,
                            0x00,
                            0x02,
                            0x00,
                            0x00,
                            0x00,
                            0x00,
                            0x40});
    ASSERT_EQ(m.size(), 8u + 4u + 64u);
    EXPECT_EQ(m[3], 0x85);
    const std::string url(reinterpret_cast<const char*>(m.data() + 12), 64);
    auto u = gvbs::parse_local_url(url);
    ASSERT_TRUE(u.has_value()) << url;
    EXPECT_EQ(u->length, cam.camera->xml().size());
    // The XML itself, first 16 bytes.
    auto x = host.command(gvcp::make_read_mem(9, static_cast<std::uint32_t>(u->address), 16));
    ASSERT_EQ(x.status, gvcp::Status::kSuccess);
    EXPECT_EQ(std::string(x.data.begin() + 4, x.data.end()), "<?xml version=\"1");
    // READREG of an unaligned address: GEV_STATUS_BAD_ALIGNMENT (0x8005).
    auto bad =
        host.exchange({0x42, 0x01, 0x00, 0x80, 0x00, 0x04, 0x00, 0x04, 0x00, 0x00, 0x00, 0x02});
    ASSERT_GE(bad.size(), 8u);
    EXPECT_EQ(bad[0], 0x80);
    EXPECT_EQ(bad[1], 0x05);
    // An unknown command (0x0100): GEV_STATUS_NOT_IMPLEMENTED (0x8001), answer 0x0101.
    auto ni = host.exchange({0x42, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x05});
    EXPECT_EQ(ni, (std::vector<std::uint8_t>{0x80, 0x01, 0x01, 0x01, 0x00, 0x00, 0x00, 0x05}));
    // A command whose length field exceeds the datagram: GEV_STATUS_INVALID_HEADER (0x800E).
    auto ih =
        host.exchange({0x42, 0x01, 0x00, 0x80, 0x00, 0x08, 0x00, 0x06, 0x00, 0x00, 0x00, 0x00});
    ASSERT_GE(ih.size(), 8u);
    EXPECT_EQ(ih[0], 0x80);
    EXPECT_EQ(ih[1], 0x0E);
    // WRITEREG_CMD of the control channel privilege (0x0A00) = 0x2 (control): success, index 1.
    auto w = host.exchange({0x42,
                            0x01,
                            0x00,
                            0x82,
                            0x00,
                            0x08,
                            0x00,
                            0x07,
                            0x00,
                            0x00,
                            0x0A,
                            0x00,
                            0x00,
                            0x00,
                            0x00,
                            0x02});
    EXPECT_EQ(w,
              (std::vector<std::uint8_t>{
                  0x00, 0x00, 0x00, 0x83, 0x00, 0x04, 0x00, 0x07, 0x00, 0x00, 0x00, 0x01}));
    // A command without the acknowledge flag gets no answer; its write still happens.
    EXPECT_TRUE(host.exchange({0x42,
                               0x00,
                               0x00,
                               0x82,
                               0x00,
                               0x08,
                               0x00,
                               0x08,
                               0x00,
                               0x00,
                               0x0A,
                               0x00,
                               0x00,
                               0x00,
                               0x00,
                               0x00})
                    .empty());
    EXPECT_FALSE(cam.camera->controller().has_value());
}

}  // namespace
