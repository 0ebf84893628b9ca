// Misbehaving clients against the simulated motor controller: a client that sends requests and
// never reads the replies, one that floods, one that trickles a byte at a time, one that holds a
// half frame, and over a thousand simultaneous connections. A well-behaved libmodbus client keeps
// getting correct answers while they run; its latencies are measured and printed.

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>
#include <vector>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/motor_controller_server.h"
#include "raw_modbus_client.h"

namespace {

using gonio::test::Bytes;
using gonio::test::hex_bytes;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

struct Server {
    gonio::devices::AxisProfile p;
    gonio::sim::MotorControllerServer server;
    std::FILE* log = std::tmpfile();

    explicit Server(int frame_timeout_ms = 1000, int max_connections = 64) {
        auto prof = gonio::devices::load_axis_profile("oriental-az");
        EXPECT_TRUE(prof) << prof.error().message;
        p = *prof;
        gonio::sim::MotorSimConfig cfg;
        cfg.start_homed = true;
        cfg.initial_deg = 12.34;
        EXPECT_TRUE(server.add_unit(1, p, cfg));
        gonio::sim::ServerOptions so;
        so.frame_timeout_ms = frame_timeout_ms;
        so.max_connections = max_connections;
        so.log = log;
        auto st = server.start(so);
        EXPECT_TRUE(st) << st.error().message;
    }
    ~Server() {
        server.stop();
        std::fclose(log);
    }
    std::string log_text() {
        std::fflush(log);
        std::rewind(log);
        std::string s;
        char buf[512];
        while (std::fgets(buf, sizeof buf, log) != nullptr) {
            s += buf;
        }
        return s;
    }
};

Bytes read_request(std::uint16_t tid, int qty) {
    Bytes r = hex_bytes("0000 0000 0006 01 03 00CC 0000");
    r[0] = static_cast<std::uint8_t>(tid >> 8);
    r[1] = static_cast<std::uint8_t>(tid & 0xFF);
    r[11] = static_cast<std::uint8_t>(qty);
    return r;
}

struct Latency {
    std::vector<double> ms;
    int wrong = 0;
    int failed = 0;
    double quantile(double q) const {
        std::vector<double> s = ms;
        std::sort(s.begin(), s.end());
        return s.empty() ? 0 : s[std::min(s.size() - 1, static_cast<size_t>(q * s.size()))];
    }
};

/// The well-behaved client: libmodbus through ModbusBus, no retries, reading the position until
/// `done` is set (at most `max_reads`).
Latency good_client(Server& s, const std::atomic<bool>& done, int max_reads) {
    Latency lat;
    auto bus =
        gonio::devices::ModbusBus::open(*gonio::devices::parse_bus_address(s.server.address()));
    EXPECT_TRUE(bus) << bus.error().message;
    if (!bus) {
        return lat;
    }
    gonio::devices::RequestPolicy pol;
    pol.response_timeout = 3000ms;
    pol.retries = 0;
    const int wire = *gonio::devices::wire_address(s.p, s.p.position.address);
    for (int i = 0; i < max_reads && (i < 200 || !done); ++i) {
        const auto t0 = Clock::now();
        auto w = (*bus)->read_registers(1, wire, 2, pol, "good client");
        const auto t1 = Clock::now();
        if (!w) {
            ++lat.failed;
            continue;
        }
        lat.ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        if (gonio::devices::decode_value(w->data(), 32, true, s.p.word_order) != 1234) {
            ++lat.wrong;
        }
    }
    return lat;
}

TEST(MisbehavingClients, WellBehavedClientIsServedWhileStalledFloodingAndTricklingClientsRun) {
    Server s(/*frame_timeout_ms=*/1000);
    std::atomic<bool> stalled_dropped{false};
    std::atomic<bool> trickle_closed{false};
    std::atomic<bool> half_closed{false};
    std::atomic<bool> stop_flood{false};
    std::atomic<long> flood_replies{0};
    std::atomic<int> finished{0};

    // Sends 125-register reads and never reads a reply, until the server drops it.
    std::thread stalled([&] {
        const int fd = gonio::test::tcp_connect(s.server.port(), 4096);
        Bytes batch;
        for (int k = 0; k < 64; ++k) {
            const Bytes r = read_request(static_cast<std::uint16_t>(k), 125);
            batch.insert(batch.end(), r.begin(), r.end());
        }
        for (int i = 0; i < 20000 && fd >= 0; ++i) {
            if (!gonio::test::send_all(fd, batch)) {
                stalled_dropped = true;
                break;
            }
        }
        if (fd >= 0) {
            ::close(fd);
        }
        ++finished;
    });
    // Floods: bursts of 50 requests, then reads the 50 replies.
    std::thread flood([&] {
        const int fd = gonio::test::tcp_connect(s.server.port());
        Bytes burst;
        for (int k = 0; k < 50; ++k) {
            const Bytes r = read_request(static_cast<std::uint16_t>(k), 2);
            burst.insert(burst.end(), r.begin(), r.end());
        }
        while (!stop_flood && fd >= 0) {
            if (!gonio::test::send_all(fd, burst)) {
                break;
            }
            const Bytes got = gonio::test::read_bytes(fd, 50 * 13, 3000ms);
            flood_replies += static_cast<long>(got.size() / 13);
            if (got.size() != 50 * 13) {
                break;
            }
        }
        if (fd >= 0) {
            ::close(fd);
        }
    });
    // Trickles one valid request a byte every 150 ms: 12 bytes need 1.65 s, beyond the frame
    // timeout, so the server closes it.
    std::thread trickle([&] {
        const int fd = gonio::test::tcp_connect(s.server.port());
        const Bytes r = read_request(1, 2);
        for (size_t k = 0; k < r.size() && fd >= 0; ++k) {
            if (!gonio::test::send_all(fd, Bytes{r[k]})) {
                trickle_closed = true;
                break;
            }
            bool closed = false;
            gonio::test::read_bytes(fd, 1, 150ms, &closed);
            if (closed) {
                trickle_closed = true;
                break;
            }
        }
        if (fd >= 0) {
            ::close(fd);
        }
        ++finished;
    });
    // Holds half a frame open.
    std::thread half([&] {
        const int fd = gonio::test::tcp_connect(s.server.port());
        const Bytes r = read_request(1, 2);
        gonio::test::send_all(fd, Bytes(r.begin(), r.begin() + 5));
        bool closed = false;
        gonio::test::read_bytes(fd, 1, 5000ms, &closed);
        half_closed = closed;
        ::close(fd);
        ++finished;
    });
    std::atomic<bool> bad_done{false};
    std::thread watcher([&] {
        stalled.join();
        trickle.join();
        half.join();
        bad_done = true;
    });
    const Latency lat = good_client(s, bad_done, 200000);
    watcher.join();
    stop_flood = true;
    flood.join();

    std::printf(
        "well-behaved client: %zu reads, median %.3f ms, p99 %.3f ms, max %.3f ms; flood served "
        "%ld replies\n",
        lat.ms.size(),
        lat.quantile(0.5),
        lat.quantile(0.99),
        lat.quantile(1.0),
        flood_replies.load());
    ::testing::Test::RecordProperty("good_reads", static_cast<int>(lat.ms.size()));
    ::testing::Test::RecordProperty("good_max_us", static_cast<int>(lat.quantile(1.0) * 1000));
    EXPECT_EQ(lat.failed, 0);
    EXPECT_EQ(lat.wrong, 0);
    EXPECT_GE(lat.ms.size(), 200u);
    EXPECT_TRUE(stalled_dropped) << "the client that never reads was not dropped";
    EXPECT_TRUE(trickle_closed) << "the trickling client was not timed out";
    EXPECT_TRUE(half_closed) << "the half frame was not timed out";
    EXPECT_GT(flood_replies.load(), 0);
    // No well-behaved request waited for another client's frame timeout (1000 ms): the old
    // single-connection loop held every client for as long as one of them was mid-frame.
    EXPECT_LT(lat.quantile(1.0), 500.0);
    const std::string log = s.log_text();
    EXPECT_NE(log.find("does not read its replies"), std::string::npos) << log;
    EXPECT_NE(log.find("incomplete frame"), std::string::npos) << log;
}

TEST(MisbehavingClients, OverAThousandConnectionsAreRefusedBeyondTheLimitWithALogLine) {
    rlimit rl{};
    ::getrlimit(RLIMIT_NOFILE, &rl);
    if (rl.rlim_cur < 2400 && rl.rlim_max >= 2400) {
        rl.rlim_cur = 2400;
        ::setrlimit(RLIMIT_NOFILE, &rl);
    }
    ::getrlimit(RLIMIT_NOFILE, &rl);
    if (rl.rlim_cur < 1200) {
        GTEST_SKIP() << "descriptor limit " << rl.rlim_cur << " too low for 1100 connections";
    }
    Server s(1000, /*max_connections=*/64);
    std::vector<int> fds;
    for (int i = 0; i < 1100; ++i) {
        const int fd = gonio::test::tcp_connect(s.server.port());
        ASSERT_GE(fd, 0) << "connect " << i;
        fds.push_back(fd);
    }
    // Descriptors above FD_SETSIZE (1024) are in use now, on both sides of the loopback.
    EXPECT_GT(fds.back(), 1024);
    int closed_by_server = 0;
    for (int fd : fds) {
        bool closed = false;
        gonio::test::read_bytes(fd, 1, 5ms, &closed);
        closed_by_server += closed ? 1 : 0;
    }
    // A connection the server kept still gets answers; the last ones were refused.
    const Bytes want = hex_bytes("0007 0000 0007 01 03 04 0000 04D2");
    ASSERT_TRUE(gonio::test::send_all(fds.front(), read_request(7, 2)));
    EXPECT_EQ(gonio::test::read_bytes(fds.front(), want.size(), 2000ms), want);
    EXPECT_GE(closed_by_server, 1100 - 64 - 5);
    for (int fd : fds) {
        ::close(fd);
    }
    const std::string log = s.log_text();
    EXPECT_NE(log.find("connection limit 64 reached"), std::string::npos) << log;
    // After they are gone, a new client is served.
    const int fd = gonio::test::tcp_connect(s.server.port());
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(gonio::test::send_all(fd, read_request(7, 2)));
    EXPECT_EQ(gonio::test::read_bytes(fd, want.size(), 2000ms), want);
    ::close(fd);
}

TEST(MisbehavingClients, FunctionSixteenWithWrongByteCountLosesNoLaterRequest) {
    Server s;
    const int fd = gonio::test::tcp_connect(s.server.port());
    ASSERT_GE(fd, 0);
    // Byte count 2 for 3 registers, then a read right behind it in the same segment.
    Bytes both = hex_bytes("0001 0000 0009 01 10 0058 0003 02 0000");
    const Bytes rd = read_request(2, 2);
    both.insert(both.end(), rd.begin(), rd.end());
    ASSERT_TRUE(gonio::test::send_all(fd, both));
    const Bytes want = hex_bytes("0001 0000 0003 01 90 03  0002 0000 0007 01 03 04 0000 04D2");
    EXPECT_EQ(gonio::test::read_bytes(fd, want.size(), 2000ms), want);
    ::close(fd);
}

}  // namespace
