// gonio camera / gonio devices end to end: the simulated GigE Vision camera served by a child
// process on a loopback address of its own, used by another gonio process through Aravis.

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cli_run.h"

extern char** environ;

namespace {

using gonio::testing::CliRun;
using gonio::testing::run_gonio;

// A served camera: child process whose first stdout line is its address.
class ServedCamera {
  public:
    explicit ServedCamera(std::vector<std::string> extra) {
        int fds[2];
        if (pipe(fds) != 0) {
            return;
        }
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
        posix_spawn_file_actions_addclose(&fa, fds[0]);
        std::vector<std::string> args = {GONIO_EXE, "camera", "serve", "--ip", "auto"};
        args.insert(args.end(), extra.begin(), extra.end());
        std::vector<char*> argv;
        for (auto& a : args) {
            argv.push_back(a.data());
        }
        argv.push_back(nullptr);
        if (posix_spawn(&pid_, GONIO_EXE, &fa, nullptr, argv.data(), environ) != 0) {
            pid_ = -1;
        }
        posix_spawn_file_actions_destroy(&fa);
        close(fds[1]);
        char c;
        while (read(fds[0], &c, 1) == 1 && c != '\n') {
            address_ += c;
        }
        close(fds[0]);
    }
    ~ServedCamera() { stop(); }
    int stop() {
        if (pid_ <= 0) {
            return -1;
        }
        kill(pid_, SIGTERM);
        int st = 0;
        waitpid(pid_, &st, 0);
        pid_ = -1;
        return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    }
    const std::string& address() const { return address_; }

  private:
    pid_t pid_ = -1;
    std::string address_;
};

// Reads one double attribute from an OpenEXR header (magic, version, then name\0 type\0 size value
// triples up to an empty name; OpenEXR file layout, "Technical Introduction", Header section).
bool exr_double_attribute(const std::string& path, const std::string& name, double* value) {
    std::ifstream f(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (bytes.size() < 8 || static_cast<unsigned char>(bytes[0]) != 0x76 ||
        static_cast<unsigned char>(bytes[1]) != 0x2f ||
        static_cast<unsigned char>(bytes[2]) != 0x31 ||
        static_cast<unsigned char>(bytes[3]) != 0x01) {
        return false;
    }
    std::size_t at = 8;
    while (at < bytes.size() && bytes[at] != '\0') {
        const std::string attr = bytes.c_str() + at;
        at += attr.size() + 1;
        const std::string type = bytes.c_str() + at;
        at += type.size() + 1;
        if (at + 4 > bytes.size()) {
            return false;
        }
        std::int32_t size;
        std::memcpy(&size, bytes.data() + at, 4);
        at += 4;
        if (attr == name && type == "double" && size == 8) {
            std::memcpy(value, bytes.data() + at, 8);
            return true;
        }
        at += static_cast<std::size_t>(size);
    }
    return false;
}

TEST(CameraCli, ServeThenInfoAndCaptureFromAnotherProcess) {
    ServedCamera server({"--width", "128", "--height", "96", "--exposure-abs", "--seed", "5"});
    ASSERT_EQ(server.address().rfind("gige://127.", 0), 0u) << server.address();

    const CliRun info = run_gonio("camera --connect " + server.address() + " info");
    ASSERT_EQ(info.status, 0) << info.out;
    EXPECT_NE(info.out.find("sensor: 128 x 96"), std::string::npos) << info.out;
    EXPECT_NE(info.out.find("serial: SIM0001"), std::string::npos) << info.out;
    EXPECT_NE(info.out.find("exposure_feature: ExposureTimeAbs"), std::string::npos) << info.out;

    const std::string exr = std::string(GONIO_BINARY_DIR) + "/camera_cli_frame.exr";
    const CliRun cap = run_gonio("camera --connect " + server.address() +
                                 " capture --exposure-us 2500 --gain 2 " + exr);
    ASSERT_EQ(cap.status, 0) << cap.out;
    double exposure = 0, gain = 0, black = 0;
    ASSERT_TRUE(exr_double_attribute(exr, "gonio.exposure_us", &exposure));
    ASSERT_TRUE(exr_double_attribute(exr, "gonio.gain", &gain));
    ASSERT_TRUE(exr_double_attribute(exr, "gonio.black_level", &black));
    EXPECT_DOUBLE_EQ(exposure, 2500);
    // The simulated camera's gain register counts 0.01 dB: the frame reports the gain applied,
    // 2 rounded to the nearest step.
    EXPECT_LE(std::abs(20 * std::log10(gain / 2)), 0.005 + 1e-9) << gain;
    EXPECT_DOUBLE_EQ(black, 1024);
    EXPECT_EQ(server.stop(), 0);
}

TEST(CameraCli, EmbeddedSimulatedCameraCaptures) {
    const std::string exr = std::string(GONIO_BINARY_DIR) + "/camera_cli_embedded.exr";
    const CliRun cap =
        run_gonio("camera --connect sim capture --width 64 --height 48 --format Mono12 " + exr);
    ASSERT_EQ(cap.status, 0) << cap.out;
    EXPECT_NE(cap.out.find("12 bits"), std::string::npos) << cap.out;
    // Through the GigE Vision stream: one complete frame, nothing lost.
    EXPECT_NE(cap.out.find("1 complete, 0 incomplete, 0 missing"), std::string::npos) << cap.out;
}

TEST(CameraCli, UnreachableAddressFailsWithAMessage) {
    // 127.2.0.1: a loopback address nothing serves on.
    const CliRun r = run_gonio("camera --connect gige://127.2.0.1 info");
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.out.find("gige://127.2.0.1"), std::string::npos) << r.out;
    const CliRun bad = run_gonio("camera --connect bogus:3 info");
    EXPECT_NE(bad.status, 0);
    EXPECT_NE(bad.out.find("unknown scheme"), std::string::npos) << bad.out;
}

TEST(DevicesCli, ListsOrSaysNoneFound) {
    const CliRun r = run_gonio("devices");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(r.out.find("no USB3 Vision camera") != std::string::npos ||
                r.out.find("usb:") != std::string::npos)
        << r.out;
}

}  // namespace
