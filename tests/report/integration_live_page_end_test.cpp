// The live page at the end of a campaign, in headless Chromium: once finish() is called the page
// says the campaign ended, with the final fit and the link to the report; a page whose server has
// gone says "campaign ended" (its last state was the end) or "connection lost" (it was not), with
// the last state it saw, and never "running".
//
// The server's going is made deterministic by a relay on 127.0.0.1 (cpp-httplib) that serves the
// live server's page and answers /status.json from it for the first few requests only, then
// refuses (503) as a server that is gone would.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "browser_support.h"
#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/report/live_server.h"
#include "test_models.h"

// clang-format off
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#include <httplib.h>
#pragma GCC diagnostic pop
// clang-format on

namespace gonio::report {
namespace {

namespace fs = std::filesystem;
using gonio::testing::chromium_dump_dom;

using gonio::test_units::kDeg;

fs::path work_dir(const std::string& name) {
    const fs::path d = fs::path(GONIO_BINARY_DIR) / "tests" / ("live_page_end_" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

/// 34 samples of a GGX + Lambert model in two incidence planes, published as a campaign would.
void publish_campaign(LiveServer& s, std::size_t planned) {
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    std::size_t n = 0;
    for (double ti : {20.0, 40.0}) {
        for (int to = -80; to <= 80; to += 10) {
            brdf::Sample x;
            x.theta_i = ti * kDeg;
            x.theta_o = std::abs(to) * kDeg;
            x.phi_o = (to >= 0 ? 180 : 0) * kDeg;
            x.value = truth.eval(x.wi(), x.wo());
            x.sigma = 0.02 * x.value;
            s.publish_sample(x);
            s.publish_progress(++n, planned, "running");
        }
    }
}

/// Waits (at most 120 s: the final fit is the render thread's, at a lower priority than anything
/// else on a loaded machine) until /status.json satisfies `ok`; returns the last status read.
template <class Pred>
nlohmann::json wait_for_status(int port, Pred ok) {
    httplib::Client cli("127.0.0.1", port);
    nlohmann::json j;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (std::chrono::steady_clock::now() < deadline) {
        auto r = cli.Get("/status.json");
        if (r && r->status == 200) {
            j = nlohmann::json::parse(r->body);
            if (ok(j)) {
                break;
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    return j;
}

/// A relay in front of the live server: the page as it serves it, /status.json from it for the
/// first `answers` requests, then 503.
class Relay {
  public:
    Relay(int live_port, int answers) : live_(live_port), answers_(answers) {
        server_.Get("/", [this](const httplib::Request&, httplib::Response& res) {
            httplib::Client c("127.0.0.1", live_);
            auto r = c.Get("/");
            res.set_content(r ? r->body : std::string(), "text/html; charset=utf-8");
        });
        server_.Get("/status.json", [this](const httplib::Request&, httplib::Response& res) {
            if (served_.fetch_add(1) >= answers_) {
                res.status = 503;
                res.set_content("gone\n", "text/plain");
                return;
            }
            httplib::Client c("127.0.0.1", live_);
            auto r = c.Get("/status.json");
            res.set_content(r ? r->body : std::string(), "application/json");
            res.set_header("Cache-Control", "no-store");
        });
        port_ = server_.bind_to_any_port("127.0.0.1");
        thread_ = std::thread([this] { server_.listen_after_bind(); });
    }
    ~Relay() {
        server_.stop();
        thread_.join();
    }
    std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/"; }
    int status_requests() const { return served_.load(); }

  private:
    httplib::Server server_;
    int live_;
    int answers_;
    int port_ = 0;
    std::atomic<int> served_{0};
    std::thread thread_;
};

/// The text of the element with this id, up to its first child or end tag, whatever attributes
/// the page's script gave it.
std::string element_text(const std::string& dom, const std::string& id) {
    const auto at = dom.find("id=\"" + id + "\"");
    if (at == std::string::npos) {
        return {};
    }
    const auto start = dom.find('>', at) + 1;
    std::string t = dom.substr(start, dom.find('<', start) - start);
    for (std::size_t p = t.find("&amp;"); p != std::string::npos; p = t.find("&amp;", p + 1)) {
        t.replace(p, 5, "&");
    }
    return t;
}

std::string attribute(const std::string& dom, const std::string& id, const std::string& name) {
    const auto at = dom.find("id=\"" + id + "\"");
    if (at == std::string::npos) {
        return {};
    }
    const auto open = dom.rfind('<', at);
    const auto close = dom.find('>', at);
    const std::string tag = dom.substr(open, close - open);
    const auto a = tag.find(" " + name + "=\"");
    if (a == std::string::npos) {
        return {};
    }
    const auto start = a + name.size() + 3;
    return tag.substr(start, tag.find('"', start) - start);
}

TEST(LivePageEnd, ChromiumShowsTheEndTheFinalFitAndTheReportLink) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = work_dir("ended");
    const fs::path report = dir / "report.html";
    std::ofstream(report) << "<!DOCTYPE html><html><body><h1 id=\"r\">the campaign report</h1>"
                             "</body></html>\n";
    LiveOptions o;
    o.render_interval_s = 0.05;
    o.fit_interval_s = 3600;  // only the final fit runs
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    publish_campaign(s, 34);
    s.finish("completed", report.string());
    const nlohmann::json j = wait_for_status(s.port(), [](const nlohmann::json& x) {
        return x["fit"].get<std::string>().rfind("final fit on 34 samples", 0) == 0;
    });
    EXPECT_TRUE(j["ended"].get<bool>());
    EXPECT_EQ(j["state"], "completed");
    EXPECT_EQ(j["eta"], "-");
    EXPECT_EQ(j["report"], "/report.html");
    EXPECT_EQ(j["fit"].get<std::string>().rfind("final fit on 34 samples", 0), 0u) << j["fit"];
    httplib::Client cli("127.0.0.1", s.port());
    auto rep = cli.Get("/report.html");
    ASSERT_TRUE(rep);
    EXPECT_EQ(rep->status, 200);
    EXPECT_NE(rep->body.find("the campaign report"), std::string::npos);

    const std::string dom = chromium_dump_dom(s.url(), dir / "profile", 4000);
    const std::string progress = element_text(dom, "progress");
    EXPECT_EQ(attribute(dom, "progress", "data-state"), "ended") << dom.substr(0, 3000);
    EXPECT_EQ(progress.rfind("campaign ended (completed): 34 of 34 measured", 0), 0u) << progress;
    EXPECT_EQ(progress.find("running"), std::string::npos) << progress;
    EXPECT_EQ(progress.find("ETA"), std::string::npos) << progress;
    EXPECT_NE(element_text(dom, "ended").find("Campaign ended: completed"), std::string::npos);
    EXPECT_EQ(attribute(dom, "report-link", "href"), "/report.html") << dom.substr(0, 3000);
    EXPECT_EQ(element_text(dom, "fit-heading"), "Final fit");
    EXPECT_EQ(element_text(dom, "fit").rfind("final fit on 34 samples", 0), 0u)
        << element_text(dom, "fit");
    s.stop();
}

TEST(LivePageEnd, APageWhoseServerWentDuringTheCampaignSaysConnectionLost) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = work_dir("lost");
    LiveOptions o;
    o.render_interval_s = 0.05;
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    publish_campaign(s, 135);
    wait_for_status(s.port(), [](const nlohmann::json& x) { return x["done"] == 34; });
    // Two answers ("34 of 135 measured, running"), then the server is gone.
    Relay relay(s.port(), 2);
    const std::string dom = chromium_dump_dom(relay.url(), dir / "profile", 6000);
    EXPECT_GT(relay.status_requests(), 2) << "the page stopped asking";
    const std::string progress = element_text(dom, "progress");
    EXPECT_EQ(attribute(dom, "progress", "data-state"), "connection lost") << dom.substr(0, 3000);
    EXPECT_EQ(progress.rfind("connection lost", 0), 0u) << progress;
    EXPECT_NE(progress.find("last state seen: 34 of 135 measured"), std::string::npos) << progress;
    EXPECT_EQ(progress.find("running"), std::string::npos) << progress;
    EXPECT_EQ(progress.find("ETA"), std::string::npos) << progress;
}

TEST(LivePageEnd, APageWhoseServerWentAfterTheEndSaysCampaignEnded) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = work_dir("ended_gone");
    LiveOptions o;
    o.render_interval_s = 0.05;
    auto srv = LiveServer::start("127.0.0.1", 0, o);
    ASSERT_TRUE(srv) << srv.error().message;
    LiveServer& s = **srv;
    publish_campaign(s, 34);
    s.finish("paused");
    wait_for_status(s.port(), [](const nlohmann::json& x) { return x["ended"] == true; });
    Relay relay(s.port(), 2);
    const std::string dom = chromium_dump_dom(relay.url(), dir / "profile", 6000);
    EXPECT_GT(relay.status_requests(), 2);
    const std::string progress = element_text(dom, "progress");
    EXPECT_EQ(attribute(dom, "progress", "data-state"), "ended") << dom.substr(0, 3000);
    EXPECT_EQ(progress.rfind("campaign ended (paused)", 0), 0u) << progress;
    EXPECT_NE(progress.find("last state: 34 of 34 measured"), std::string::npos) << progress;
    EXPECT_NE(element_text(dom, "ended").find("Campaign ended: paused"), std::string::npos);
    EXPECT_EQ(dom.find("id=\"report-link\""), std::string::npos);  // no report was handed over
}

}  // namespace
}  // namespace gonio::report
