#include "live_page.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "gonio/report/html_report.h"

namespace gonio::tools {

namespace {

std::atomic<bool> g_end_serving{false};

extern "C" void on_end_serving(int) {
    g_end_serving.store(true);
}

/// The campaign's report for the page's link; "" (with a note) when it cannot be written.
std::string write_campaign_report(const std::string& dir) {
    std::error_code ec;
    if (dir.empty() || !std::filesystem::is_directory(dir, ec)) {
        return {};
    }
    auto rep = report::build_report(dir);
    if (!rep) {
        std::fprintf(stderr,
                     "gonio acquire: note: the live page has no report: %s\n",
                     rep.error().message.c_str());
        return {};
    }
    return rep->html_path;
}

}  // namespace

Expected<std::unique_ptr<report::LiveServer>> start_live_page(const std::string& host,
                                                              int port,
                                                              const std::string& kind,
                                                              const std::string& frame_note) {
    report::LiveOptions lo;
    lo.title = "gonio " + kind;
    if (!frame_note.empty()) {
        lo.frame_note = frame_note;
    }
    auto srv = report::LiveServer::start(host, port, lo);
    if (!srv) {
        return srv;
    }
    std::printf("live page: %s\n", (*srv)->url().c_str());
    std::fflush(stdout);
    return srv;
}

void keep_live_page(report::LiveServer* live, const std::string& dir, const std::string& state) {
    if (live == nullptr) {
        return;
    }
    const std::string report_path = write_campaign_report(dir);
    live->finish(state, report_path);
    std::printf(
        "campaign ended (%s); the live page %s keeps showing its final state, the final fit%s "
        "until Ctrl-C\n",
        state.c_str(),
        live->url().c_str(),
        report_path.empty() ? "" : " and the report");
    std::fflush(stdout);
    g_end_serving.store(false);
    std::signal(SIGINT, on_end_serving);
    std::signal(SIGTERM, on_end_serving);
    while (!g_end_serving.load()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    live->stop();
}

}  // namespace gonio::tools
