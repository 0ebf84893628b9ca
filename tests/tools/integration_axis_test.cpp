// `gonio axis` end to end: the real executable against simulated controllers (in this process, or
// the executable's own `gonio axis serve` child).

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <string>

#include "gonio/devices/axis_profile.h"
#include "gonio/sim/motor_controller_server.h"

namespace {

struct Run {
    int status = -1;
    std::string out;
};

Run run(const std::string& args) {
    Run r;
    const std::string cmd = std::string(GONIO_EXE) + " " + args + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) {
        return r;
    }
    std::array<char, 512> buf{};
    while (std::fgets(buf.data(), static_cast<int>(buf.size()), p) != nullptr) {
        r.out += buf.data();
    }
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

class AxisCli : public ::testing::Test {
  protected:
    void SetUp() override {
        auto p = gonio::devices::load_axis_profile("oriental-az");
        ASSERT_TRUE(p) << p.error().message;
        gonio::sim::MotorSimConfig cfg;
        cfg.time_scale = 50;
        cfg.initial_deg = 7;
        ASSERT_TRUE(server_.add_unit(1, *p, cfg));
        ASSERT_TRUE(server_.start());
        bus_ = "axis --connect " + server_.address() + " --unit 1";
        base_ = bus_ + " --profile oriental-az --name arm";
    }
    gonio::sim::MotorControllerServer server_;
    std::string bus_;  ///< what `fault` takes: the bus and the unit
    std::string base_;
};

TEST_F(AxisCli, HomeMoveStatusStop) {
    auto st = run(base_ + " status");
    ASSERT_EQ(st.status, 0) << st.out;
    EXPECT_NE(st.out.find("homed no"), std::string::npos) << st.out;

    auto h = run(base_ + " home");
    ASSERT_EQ(h.status, 0) << h.out;
    EXPECT_NE(h.out.find("idle, position 0.0000 deg, homed yes"), std::string::npos) << h.out;
    EXPECT_NEAR(server_.position_deg(1), 0, 1e-9);

    auto m = run(base_ + " move 12.5");
    ASSERT_EQ(m.status, 0) << m.out;
    EXPECT_NE(m.out.find("position 12.5000 deg"), std::string::npos) << m.out;
    EXPECT_NEAR(server_.position_deg(1), 12.5, 1e-9);

    auto s = run(base_ + " stop");
    EXPECT_EQ(s.status, 0) << s.out;
}

TEST_F(AxisCli, RefusalsAndAlarmsExitNonZeroWithTheReason) {
    const auto before = server_.request_count();
    auto far = run(base_ + " --max 90 move 120");
    EXPECT_NE(far.status, 0);
    EXPECT_NE(far.out.find("axis \"arm\""), std::string::npos) << far.out;
    EXPECT_NE(far.out.find("outside soft limits"), std::string::npos) << far.out;
    EXPECT_EQ(server_.request_count(), before);

    auto f = run(bus_ + " fault alarm --code 48 --fraction 0.5");
    ASSERT_EQ(f.status, 0) << f.out;
    auto m = run(base_ + " move 40");
    EXPECT_NE(m.status, 0);
    EXPECT_NE(m.out.find("alarm code 48"), std::string::npos) << m.out;
    auto st = run(base_ + " status");
    EXPECT_NE(st.out.find("alarm, position"), std::string::npos) << st.out;
    auto r = run(base_ + " reset");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("idle"), std::string::npos) << r.out;

    auto e = run(bus_ + " fault exception --code 2");
    ASSERT_EQ(e.status, 0) << e.out;
    auto bad = run(base_ + " status");
    EXPECT_NE(bad.status, 0);
    EXPECT_NE(bad.out.find("Modbus exception 2 (illegal data address)"), std::string::npos)
        << bad.out;
}

TEST_F(AxisCli, NoControllerIsAClearError) {
    auto r = run("axis --connect tcp://127.0.0.1:1 --unit 1 status");
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.out.find("tcp://127.0.0.1:1"), std::string::npos) << r.out;
    auto p = run("axis --connect " + server_.address() + " --profile no-such status");
    EXPECT_NE(p.status, 0);
    EXPECT_NE(p.out.find("no-such"), std::string::npos) << p.out;
}

/// Reads one line from `fd` within `timeout`.
std::string read_line(int fd, std::chrono::milliseconds timeout) {
    std::string line;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
        pollfd p{fd, POLLIN, 0};
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (::poll(&p, 1, static_cast<int>(std::max<long long>(1, left.count()))) <= 0) {
            continue;
        }
        char c = 0;
        if (::read(fd, &c, 1) != 1) {
            break;
        }
        if (c == '\n') {
            return line;
        }
        line += c;
    }
    return line;
}

TEST(AxisServe, ServesUntilInterrupted) {
    for (const char* transport : {"", " --rtu"}) {
        int out[2];
        ASSERT_EQ(::pipe(out), 0);
        const pid_t pid = ::fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            ::dup2(out[1], 1);
            ::close(out[0]);
            const std::string extra = transport;
            if (extra.empty()) {
                ::execl(GONIO_EXE,
                        GONIO_EXE,
                        "axis",
                        "--profile",
                        "generic",
                        "serve",
                        "--units",
                        "1,2",
                        "--time-scale",
                        "50",
                        static_cast<char*>(nullptr));
            } else {
                ::execl(GONIO_EXE,
                        GONIO_EXE,
                        "axis",
                        "--profile",
                        "generic",
                        "serve",
                        "--units",
                        "1,2",
                        "--time-scale",
                        "50",
                        "--rtu",
                        static_cast<char*>(nullptr));
            }
            ::_exit(127);
        }
        ::close(out[1]);
        const std::string line = read_line(out[0], std::chrono::milliseconds(20000));
        ASSERT_EQ(line.rfind("serving ", 0), 0u) << line;
        const std::string address = line.substr(8, line.find(' ', 8) - 8);
        for (int unit : {1, 2}) {
            auto m = run("axis --connect '" + address + "' --unit " + std::to_string(unit) +
                         " --profile generic move " + std::to_string(10 * unit));
            EXPECT_EQ(m.status, 0) << m.out;
            EXPECT_NE(m.out.find("position " + std::to_string(10 * unit) + ".0000 deg"),
                      std::string::npos)
                << m.out;
        }
        ASSERT_EQ(::kill(pid, SIGINT), 0);
        int st = 0;
        ASSERT_EQ(::waitpid(pid, &st, 0), pid);
        EXPECT_TRUE(WIFEXITED(st));
        EXPECT_EQ(WEXITSTATUS(st), 0);
        ::close(out[0]);
    }
}

}  // namespace
