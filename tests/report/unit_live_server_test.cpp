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
#include <cstdio>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "common/test_units.h"
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

using gonio::test_units::kDeg;

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

/// The status of the server once it shows the pictures named (the render thread draws them on
/// its own).
nlohmann::json status_with(httplib::Client& cli, const std::vector<std::string>& pictures) {
    nlohmann::json j;
    for (int i = 0; i < 400; ++i) {
        j = nlohmann::json::parse(cli.Get("/status.json")->body);
        bool all = true;
        for (const std::string& p : pictures) {
            all = all && j["versions"].contains(p);
        }
        if (all) {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    return j;
}

TEST(LiveServer, ImageCampaignShowsCoverageTargetEtaFrameAndMap) {
    LiveOptions o;
    o.render_interval_s = 0.05;
    o.frame_note = "no frame from this detector";
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    httplib::Client cli("127.0.0.1", s.port());
    // Until a frame is published the page says why there is none.
    auto page = cli.Get("/");
    ASSERT_TRUE(page);
    EXPECT_NE(page->body.find(">no frame from this detector<"), std::string::npos);
    // Five light positions gaining 5 % coverage each, target 50 %, at most 40 positions: six more
    // reach the target, sooner than the 36 the frame limit allows.
    for (int f = 0; f <= 4; ++f) {
        s.publish_image_progress(f, 40, 0.05 * f, 0.5, "running");
    }
    CoverageCells cells;
    cells.n_theta_h = 3;
    cells.n_theta_d = 2;
    cells.n_phi_d = 4;
    cells.fraction = {1, 0.5, 0, 0.25, -1, 0};
    cells.measured_bins = 7;
    cells.total_bins = 20;
    cells.total_is_valid_bins = true;
    s.publish_coverage(std::move(cells));
    Image frame;
    frame.width = 120;
    frame.height = 80;
    frame.rgb.assign(120 * 80 * 3, 77);
    s.publish_frame(std::move(frame), "sample sphere, light arm at 12.0 deg");
    nlohmann::json j = status_with(cli, {"frame", "coverage"});
    EXPECT_EQ(j["mode"], "image");
    EXPECT_EQ(j["done"].get<std::size_t>(), 4u);
    EXPECT_EQ(j["planned"].get<std::size_t>(), 40u);
    EXPECT_NEAR(j["coverage_percent"].get<double>(), 20.0, 1e-9);
    EXPECT_NEAR(j["target_percent"].get<double>(), 50.0, 1e-9);
    EXPECT_NEAR(j["bar_percent"].get<double>(), 40.0, 1e-9);  // 20 % of a 50 % target
    EXPECT_EQ(j["eta_basis"], "the coverage target at the recent gain per frame");
    const std::string progress = j["progress"];
    EXPECT_EQ(progress.find("4 of at most 40 light positions; coverage 20.0 % of the valid bins "
                            "(target 50.0 %); running"),
              0u)
        << progress;
    EXPECT_EQ(j["captions"]["frame"], "sample sphere, light arm at 12.0 deg");
    EXPECT_NE(j["captions"]["coverage"].get<std::string>().find("half/difference table"),
              std::string::npos);
    EXPECT_NE(j["fit"].get<std::string>().find("fitted when the campaign ends"), std::string::npos);
    // The pictures decode: the frame at the size it was published, the map at the plot width.
    const std::string dir = ::testing::TempDir();
    for (const char* name : {"frame", "coverage"}) {
        auto png = cli.Get(std::string("/img/") + name + ".png");
        ASSERT_TRUE(png);
        ASSERT_EQ(png->status, 200) << name;
        const std::string path = dir + "/live_" + name + ".png";
        FILE* f = std::fopen(path.c_str(), "wb");
        ASSERT_NE(f, nullptr);
        std::fwrite(png->body.data(), 1, png->body.size(), f);
        std::fclose(f);
        auto img = read_png(path);
        ASSERT_TRUE(img) << img.error().message;
        if (std::string(name) == "frame") {
            EXPECT_EQ(img->width, 120);
            EXPECT_EQ(img->height, 80);
            EXPECT_EQ(img->at(60, 40), (Color{77, 77, 77}));
        } else {
            EXPECT_EQ(img->width, o.plot_width);
        }
    }
    s.stop();
}

TEST(LiveServer, ImageCampaignEtaFallsBackToTheFrameLimit) {
    LiveOptions o;
    o.render_interval_s = 0.05;
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    httplib::Client cli("127.0.0.1", s.port());
    // 1 % per position from 10 %: 40 more to a 50 % target, but only 4 positions are left.
    for (int f = 0; f <= 4; ++f) {
        s.publish_image_progress(f, 8, 0.10 + 0.01 * f, 0.5, "running");
    }
    nlohmann::json j = status_with(cli, {});
    EXPECT_EQ(j["eta_basis"], "the frame limit");
    EXPECT_NEAR(j["bar_percent"].get<double>(), 50.0, 1e-9);  // 4 of 8 positions
    // Once the target is met nothing is left, and a finished campaign shows no ETA.
    s.publish_image_progress(5, 8, 0.55, 0.5, "completed");
    j = status_with(cli, {});
    EXPECT_EQ(j["state"], "completed");
    EXPECT_EQ(j["eta"], "-");
    EXPECT_GT(j["bar_percent"].get<double>(), 100.0);
    s.stop();
}

}  // namespace
}  // namespace gonio::report
