// The live campaign page's server on 127.0.0.1 with an ephemeral port: the address syntax, the
// routes (page, status, pictures, 404, read-only), the status figures against what was published,
// and publishing that goes on while every HTTP thread is held by clients that never read.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/report/live_server.h"
#include "test_models.h"

// After Eigen (through the gonio headers): the resolver header httplib pulls in defines `_res`.
// clang-format off
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#include <httplib.h>
#pragma GCC diagnostic pop
// clang-format on

namespace gonio::report {
namespace {

constexpr double kDeg = brdf::kPi / 180.0;

TEST(LiveAddress, ParsesAddressAndPort) {
    auto a = parse_listen_address("0");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->first, "127.0.0.1");
    EXPECT_EQ(a->second, 0);
    a = parse_listen_address("0.0.0.0:8080");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->first, "0.0.0.0");
    EXPECT_EQ(a->second, 8080);
    a = parse_listen_address("[::1]:65535");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->first, "::1");
    EXPECT_EQ(a->second, 65535);
    for (const char* bad : {"", "65536", "x", ":80", "host:", "1:2:x", "123456"}) {
        auto b = parse_listen_address(bad);
        ASSERT_FALSE(b) << bad;
        EXPECT_NE(b.error().message.find("--serve"), std::string::npos) << b.error().message;
    }
}

brdf::Sample sample_of(const brdf::Brdf& b, double ti, double to, double dphi) {
    brdf::Sample s;
    s.theta_i = ti * kDeg;
    s.theta_o = to * kDeg;
    s.phi_o = dphi * kDeg;
    s.value = b.eval(s.wi(), s.wo());
    s.sigma = 0.02 * s.value;
    return s;
}

TEST(LiveServer, ServesWhatWasPublished) {
    LiveOptions o;
    o.render_interval_s = 0.05;
    o.fit_interval_s = 0.05;
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    ASSERT_GT(s.port(), 0);
    EXPECT_EQ(s.url(), "http://127.0.0.1:" + std::to_string(s.port()) + "/");
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    std::size_t n = 0;
    for (double ti : {20.0, 40.0}) {
        for (int to = -80; to <= 80; to += 10) {
            s.publish_sample(sample_of(truth, ti, std::abs(to), to >= 0 ? 180 : 0));
            ++n;
        }
    }
    s.publish_progress(n, 50, "running");
    // Wait for a render that saw every sample (the render thread runs on its own).
    for (int i = 0; i < 400 && s.renders() < 2; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    ASSERT_GE(s.renders(), 1u);
    httplib::Client cli("127.0.0.1", s.port());
    auto page = cli.Get("/");
    ASSERT_TRUE(page);
    EXPECT_EQ(page->status, 200);
    EXPECT_NE(page->body.find("/status.json"), std::string::npos);
    auto st = cli.Get("/status.json");
    ASSERT_TRUE(st);
    const nlohmann::json j = nlohmann::json::parse(st->body);
    EXPECT_EQ(j["done"].get<std::size_t>(), n);
    EXPECT_EQ(j["planned"].get<std::size_t>(), 50u);
    EXPECT_NEAR(j["percent"].get<double>(), 100.0 * n / 50, 1e-9);
    EXPECT_EQ(j["state"], "running");
    EXPECT_GT(j["versions"]["in_plane"].get<std::uint64_t>(), 0u);
    auto png = cli.Get("/img/in_plane.png");
    ASSERT_TRUE(png);
    EXPECT_EQ(png->status, 200);
    ASSERT_GT(png->body.size(), 8u);
    EXPECT_EQ(png->body.substr(1, 3), "PNG");
    EXPECT_EQ(cli.Get("/img/frame.png")->status, 404);  // no frame published
    EXPECT_EQ(cli.Get("/../etc/passwd")->status, 404);
    auto post = cli.Post("/status.json", "x", "text/plain");
    ASSERT_TRUE(post);
    EXPECT_NE(post->status, 200);  // read-only
    // The live fit of 34 samples of a GGX + Lambert model ran and is reported.
    for (int i = 0; i < 400; ++i) {
        auto again = cli.Get("/status.json");
        if (again &&
            nlohmann::json::parse(again->body)["fit"].get<std::string>().find("on 34 ") == 0) {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    const nlohmann::json k = nlohmann::json::parse(cli.Get("/status.json")->body);
    EXPECT_EQ(k["fit"].get<std::string>().find("on 34 samples"), 0u) << k["fit"];
    s.stop();
}

int connect_to(int port, int rcvbuf) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (rcvbuf > 0) {
        ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
        ::close(fd);
        return -1;
    }
    return fd;
}

TEST(LiveServer, PublishingGoesOnWhileClientsHoldEveryConnection) {
    LiveOptions o;
    o.render_interval_s = 0.05;
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    s.publish_sample(sample_of(truth, 30, 30, 180));
    for (int i = 0; i < 400 && s.renders() < 1; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    // 200 connections that send nothing, and one that asks for pictures and never reads.
    std::vector<int> fds;
    for (int i = 0; i < 200; ++i) {
        const int fd = connect_to(s.port(), 0);
        ASSERT_GE(fd, 0);
        fds.push_back(fd);
    }
    const int sink = connect_to(s.port(), 4096);
    ASSERT_GE(sink, 0);
    const std::string get = "GET /img/coverage.png HTTP/1.1\r\nHost: x\r\n\r\n";
    for (int i = 0; i < 50; ++i) {
        (void)::send(sink, get.data(), get.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    // The publishing thread never waits for them: 20000 publications return, and the render
    // thread keeps drawing the new data.
    const std::uint64_t renders_before = s.renders();
    for (int i = 0; i < 20000; ++i) {
        s.publish_sample(sample_of(truth, 10 + i % 60, 5 + i % 70, (i * 7) % 180));
        s.publish_progress(static_cast<std::size_t>(i + 2), 20001, "running");
    }
    for (int i = 0; i < 400 && s.renders() <= renders_before; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    EXPECT_GT(s.renders(), renders_before);
    for (int fd : fds) {
        ::close(fd);
    }
    ::close(sink);
    // Once they are gone the page answers again.
    httplib::Client cli("127.0.0.1", s.port());
    cli.set_connection_timeout(30);
    cli.set_read_timeout(30);
    auto st = cli.Get("/status.json");
    ASSERT_TRUE(st);
    EXPECT_EQ(nlohmann::json::parse(st->body)["done"].get<std::size_t>(), 20001u);
    s.stop();
}

}  // namespace
}  // namespace gonio::report
