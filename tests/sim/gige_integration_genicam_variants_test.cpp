// `gonio camera info` against Aravis's own simulated GigE Vision device (arv-fake-gv-camera-0.8 on
// 127.0.0.1) serving GenICam descriptions written for these tests (tests/data/genicam): one without
// SensorWidth/SensorHeight, as several real cameras describe themselves (the size comes from
// WidthMax/HeightMax), and one whose GainRaw range has its minimum above its maximum (reported as
// the camera's fault, naming the feature), and two whose Width and Height have no maximum (a plain
// register; an Integer without Max), whose size is their current value. The fake device listens on
// port 3956 of 127.0.0.1, so like every test that serves a GigE camera it runs with the 'stream'
// tests, one at a time.

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <string>
#include <thread>

#include "gige_test_support.h"

namespace {

using gige_test::run;

/// arv-fake-gv-camera-0.8 serving `xml` on 127.0.0.1 for the test's duration.
class FakeCamera {
  public:
    explicit FakeCamera(const std::string& xml) {
        pid_ = fork();
        if (pid_ == 0) {
            const int null = ::open("/dev/null", O_WRONLY);
            dup2(null, 1);
            dup2(null, 2);
            execlp("arv-fake-gv-camera-0.8",
                   "arv-fake-gv-camera-0.8",
                   "-i",
                   "127.0.0.1",
                   "-g",
                   xml.c_str(),
                   static_cast<char*>(nullptr));
            _exit(127);
        }
        // Ready once it answers a READREG of the bootstrap version register (bounded tries; each
        // waits up to 2 s for the answer).
        gige_test::RawHost host("127.0.0.1");
        namespace gvcp = gige_test::gvcp;
        for (std::uint16_t i = 1; i <= 20 && !ready_; ++i) {
            const auto reply = host.exchange(gvcp::encode(gvcp::make_read_reg(i, {0})));
            auto ack = gvcp::parse_ack(reply.data(), reply.size());
            ready_ = ack && ack->status == gvcp::Status::kSuccess;
        }
    }
    ~FakeCamera() {
        if (pid_ > 0) {
            kill(pid_, SIGTERM);
            int status = 0;
            waitpid(pid_, &status, 0);
        }
    }
    FakeCamera(const FakeCamera&) = delete;
    FakeCamera& operator=(const FakeCamera&) = delete;
    bool ready() const { return ready_; }

  private:
    pid_t pid_ = -1;
    bool ready_ = false;
};

std::string data(const std::string& name) {
    return std::string(GONIO_SOURCE_DIR) + "/tests/data/genicam/" + name;
}

const std::string kGonio = std::string(GONIO_BINARY_DIR) + "/tools/gonio";

TEST(GenicamVariants, CameraWithoutSensorSizeIsMeasuredFromWidthMaxAndHeightMax) {
    FakeCamera cam(data("no_sensor_size.xml"));
    ASSERT_TRUE(cam.ready());
    // The description has no SensorWidth: Aravis's own tool says so.
    const auto arv = run("arv-tool-0.8 -a 127.0.0.1 control SensorWidth WidthMax");
    EXPECT_NE(arv.out.find("'SensorWidth' not found"), std::string::npos) << arv.out;
    const auto r = run(kGonio + " camera --connect gige://127.0.0.1 info");
    ASSERT_EQ(r.status, 0) << r.out;
    // The fake device's full frame is 2048 x 2048; the image is 512 x 512 Mono8.
    EXPECT_NE(r.out.find("sensor: 2048 x 2048"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("bit_depth: 8"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("gain_feature: GainRaw (unit raw, range 0..10 raw)"), std::string::npos)
        << r.out;
}

TEST(GenicamVariants, ReversedFeatureRangeIsTheCamerasFaultNamingTheFeature) {
    FakeCamera cam(data("gain_range_reversed.xml"));
    ASSERT_TRUE(cam.ready());
    const auto r = run(kGonio + " camera --connect gige://127.0.0.1 info");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("sensor: 2048 x 2048"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("gain_feature: none ("), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("gives GainRaw the range [10, 0], minimum above maximum"),
              std::string::npos)
        << r.out;
    EXPECT_EQ(r.out.find("range 10..0"), std::string::npos) << r.out;
    // A capture that needs the gain stops with the same reason before any frame.
    const auto c = run(kGonio + " camera --connect gige://127.0.0.1 capture --camera-gain 5 " +
                       std::string(GONIO_BINARY_DIR) + "/genicam_variants_never_written.exr");
    EXPECT_NE(c.status, 0) << c.out;
    EXPECT_NE(c.out.find("GainRaw the range [10, 0]"), std::string::npos) << c.out;
}

/// `gonio camera info` on a description whose Width and Height have no maximum: Aravis's own tool
/// sees the register's top, 4294967295; gonio opens the camera at the current 512 x 512 (the
/// fake device's image registers) and says where the size came from.
void expect_opened_from_the_current_size(const std::string& xml) {
    FakeCamera cam(data(xml));
    ASSERT_TRUE(cam.ready());
    const auto arv = run("arv-tool-0.8 -a 127.0.0.1 control Width Height WidthMax");
    EXPECT_NE(arv.out.find("Width = 512"), std::string::npos) << arv.out;
    EXPECT_NE(arv.out.find("max:4294967295"), std::string::npos) << arv.out;
    EXPECT_NE(arv.out.find("'WidthMax' not found"), std::string::npos) << arv.out;
    const auto r = run(kGonio + " camera --connect gige://127.0.0.1 info");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("sensor: 512 x 512 (from the current Width and Height; the camera's "
                         "description gives them no maximum)"),
              std::string::npos)
        << r.out;
    EXPECT_EQ(r.out.find("4294967295"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("bit_depth: 8"), std::string::npos) << r.out;
}

TEST(GenicamVariants, WidthAsAPlainRegisterOpensFromTheCurrentSize) {
    expect_opened_from_the_current_size("width_plain_register.xml");
}

TEST(GenicamVariants, WidthWithoutMaximumOpensFromTheCurrentSize) {
    expect_opened_from_the_current_size("width_without_max.xml");
}

TEST(GenicamVariants, SensorSizeSaysWhereItCameFrom) {
    FakeCamera cam(data("no_sensor_size.xml"));
    ASSERT_TRUE(cam.ready());
    const auto r = run(kGonio + " camera --connect gige://127.0.0.1 info");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("sensor: 2048 x 2048 (from WidthMax and HeightMax)"), std::string::npos)
        << r.out;
}

}  // namespace
