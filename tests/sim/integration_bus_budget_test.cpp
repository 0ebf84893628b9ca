// The bus scheduler on a shared RS-485 line: four drives on one RTU bus (one libmodbus context,
// one owner) move at once while their status polls share the line's budget, derived from the
// baud rate and the frame sizes. The number of polls never exceeds what the budget allows over
// the elapsed time, and every move completes at its target.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/motor_controller_server.h"

namespace {

using namespace std::chrono_literals;

TEST(BusBudget, FourDrivesOnOneRtuLineStayWithinTheLineShare) {
    auto p = gonio::devices::load_axis_profile("leadshine");
    ASSERT_TRUE(p) << p.error().message;
    gonio::sim::MotorControllerServer server;
    gonio::sim::MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.time_scale = 4;
    for (int unit = 1; unit <= 4; ++unit) {
        ASSERT_TRUE(server.add_unit(unit, *p, cfg));
    }
    gonio::sim::ServerOptions so;
    so.transport = gonio::sim::Transport::kRtu;
    so.log = nullptr;
    ASSERT_TRUE(server.start(so));
    // 19200 baud 8N1: 12.5 ms per 2-register read; half the line = 40 polls/s.
    auto bus = gonio::devices::ModbusBus::shared("rtu:" + server.device_path() +
                                                 "?baud=19200&line_share=0.5");
    ASSERT_TRUE(bus) << bus.error().message;
    EXPECT_NEAR((*bus)->poll_budget_per_s(), 40, 1e-9);
    std::vector<std::unique_ptr<gonio::devices::ModbusAxis>> axes;
    for (int unit = 1; unit <= 4; ++unit) {
        axes.push_back(
            std::make_unique<gonio::devices::ModbusAxis>(*bus,
                                                         unit,
                                                         *p,
                                                         "axis" + std::to_string(unit),
                                                         gonio::devices::SoftLimits{-170, 170},
                                                         gonio::devices::Motion{30, 60, 0}));
    }
    const auto before = (*bus)->stats();
    const auto t0 = std::chrono::steady_clock::now();
    const double targets[4] = {40, -25, 60, 10};
    for (int k = 0; k < 4; ++k) {
        ASSERT_TRUE(axes[static_cast<size_t>(k)]->start_move(targets[k]));
    }
    for (int k = 0; k < 4; ++k) {
        auto r = axes[static_cast<size_t>(k)]->wait_done(30s);
        ASSERT_TRUE(r) << r.error().message;
        EXPECT_NEAR(server.position_deg(k + 1), targets[k], 1e-9);
    }
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto after = (*bus)->stats();
    const double polls = static_cast<double>(after.polls - before.polls);
    std::printf(
        "4 drives, 19200 baud, line share 0.5: %.0f polls in %.3f s = %.1f polls/s "
        "(budget 40/s), %.0f requests in all\n",
        polls,
        elapsed,
        polls / elapsed,
        static_cast<double>(after.requests - before.requests));
    // Slots are 25 ms apart: at most elapsed / 25 ms + 1 polls, whatever the machine's load.
    EXPECT_LE(polls, elapsed * 40 + 1);
    EXPECT_GT(polls, 0);
}

}  // namespace

namespace {

TEST(BusBudget, OneOwnerPerLineWhateverTheQueryKeys) {
    auto p = gonio::devices::load_axis_profile("generic");
    ASSERT_TRUE(p);
    gonio::sim::MotorControllerServer server;
    ASSERT_TRUE(server.add_unit(1, *p));
    gonio::sim::ServerOptions so;
    so.log = nullptr;
    ASSERT_TRUE(server.start(so));
    auto a = gonio::devices::ModbusBus::shared(server.address() + "?poll_rate=25");
    ASSERT_TRUE(a) << a.error().message;
    auto b = gonio::devices::ModbusBus::shared(server.address() + "?poll_rate=25");
    ASSERT_TRUE(b) << b.error().message;
    EXPECT_EQ(a->get(), b->get());
    // The same line with another budget would be a second owner: refused, naming both.
    auto c = gonio::devices::ModbusBus::shared(server.address() + "?poll_rate=100");
    ASSERT_FALSE(c);
    EXPECT_NE(c.error().message.find("already open as"), std::string::npos) << c.error().message;
    EXPECT_NE(c.error().message.find("poll_rate=25"), std::string::npos) << c.error().message;
}

}  // namespace
