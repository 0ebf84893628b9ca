// The live campaign page: `gonio acquire --serve 127.0.0.1:0` on the embedded virtual rig prints
// its URL; headless Chromium shows the progress advancing; 200 idle connections and a client that
// never reads leave the campaign running to the end. The measurement rate with and without those
// clients is printed (the figures in docs/benchmarks.md), not asserted: timing is no test's
// business.

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../report/browser_support.h"
#include "cli_run.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

/// Lines in the campaign journal (one per finished measurement or event).
std::size_t journal_lines(const fs::path& dir) {
    std::ifstream in(dir / "journal.log");
    std::size_t n = 0;
    std::string line;
    while (std::getline(in, line)) {
        ++n;
    }
    return n;
}

/// Journal lines per second over `seconds` of wall time.
double journal_rate(const fs::path& dir, double seconds) {
    const std::size_t a = journal_lines(dir);
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const std::size_t b = journal_lines(dir);
    return static_cast<double>(b - a) / std::chrono::duration<double>(Clock::now() - t0).count();
}

int connect_to(int port, int rcvbuf = 0) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) {
        return -1;
    }
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

/// `data-done` of the progress line in a dumped DOM, -1 when absent.
long done_in(const std::string& dom) {
    std::smatch m;
    if (std::regex_search(dom, m, std::regex("data-done=\"([0-9]+)\""))) {
        return std::stol(m[1]);
    }
    return -1;
}

TEST(LivePage, ChromiumWatchesTheCampaignAndFloodingClientsDoNotStopIt) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_test_dir("live_page");
    const fs::path out = dir / "campaign";
    const fs::path log = dir / "acquire.log";
    // A child process: the campaign runs while the test looks at it.
    const std::string cmd =
        std::string(GONIO_EXE) + " acquire --serve 127.0.0.1:0 --out " + out.string() +
        " --n-theta 6 --n-dphi 4 --adaptive 0 --time-scale 200 > " + log.string() + " 2>&1";
    std::thread campaign([&] { EXPECT_EQ(std::system(cmd.c_str()), 0) << "gonio acquire failed"; });
    // The URL is printed before the first measurement.
    std::string url;
    for (int i = 0; i < 1200 && url.empty(); ++i) {
        std::ifstream in(log);
        std::stringstream ss;
        ss << in.rdbuf();
        std::smatch m;
        const std::string text = ss.str();
        if (std::regex_search(
                text, m, std::regex("live page: (http://127\\.0\\.0\\.1:([0-9]+)/)"))) {
            url = m[1];
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_FALSE(url.empty()) << "no live page URL printed";
    const int port = std::stoi(std::regex_replace(url, std::regex(".*:([0-9]+)/$"), "$1"));
    ASSERT_GT(port, 0);

    // Chromium twice, a few seconds apart: the progress it shows advances.
    const std::string dom1 = chromium_dump_dom(url, dir / "profile1", 3000);
    const long d1 = done_in(dom1);
    std::this_thread::sleep_for(std::chrono::seconds(3));
    const std::string dom2 = chromium_dump_dom(url, dir / "profile2", 3000);
    const long d2 = done_in(dom2);
    std::printf("Chromium saw %ld then %ld measurements\n", d1, d2);
    EXPECT_GE(d1, 0) << dom1.substr(0, 2000);
    EXPECT_GT(d2, d1) << "the page's progress did not advance";
    EXPECT_NE(dom2.find("of "), std::string::npos);

    // Rates: quiet, then 200 idle connections and a client that requests pictures and never
    // reads, then quiet again.
    const double quiet = journal_rate(out, 4);
    std::vector<int> fds;
    for (int i = 0; i < 200; ++i) {
        const int fd = connect_to(port);
        if (fd >= 0) {
            fds.push_back(fd);
        }
    }
    const int sink = connect_to(port, 4096);
    ASSERT_GE(sink, 0);
    ::fcntl(sink, F_SETFL, O_NONBLOCK);
    const std::string get = "GET /img/coverage.png HTTP/1.1\r\nHost: x\r\n\r\n";
    for (int i = 0; i < 200; ++i) {
        if (::send(sink, get.data(), get.size(), MSG_NOSIGNAL) < 0) {
            break;
        }
    }
    const double flooded = journal_rate(out, 4);
    for (int fd : fds) {
        ::close(fd);
    }
    ::close(sink);
    const double after = journal_rate(out, 4);
    std::printf(
        "measurement rate (journal lines/s): quiet %.2f, with 200 idle connections and a "
        "non-reading client %.2f, after %.2f\n",
        quiet,
        flooded,
        after);
    EXPECT_EQ(fds.size(), 200u);
    campaign.join();
    // The campaign ran to its end, every planned configuration in the journal.
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    EXPECT_NE(ss.str().find("completed:"), std::string::npos) << ss.str();
}

TEST(LivePage, ServeOptionIsCheckedBeforeAnyWork) {
    const fs::path dir = fresh_test_dir("live_page_usage");
    for (const char* bad : {"--serve 70000", "--serve host:", "--serve :80x", "--serve abc"}) {
        const CliRun r =
            run_gonio(std::string("acquire --out ") + (dir / "x").string() + " " + bad);
        EXPECT_EQ(r.status, 2) << bad << "\n" << r.out;
        EXPECT_NE(r.out.find("--serve"), std::string::npos) << r.out;
        EXPECT_FALSE(fs::exists(dir / "x")) << bad;
    }
    const CliRun img = run_gonio("acquire --mode image --serve 0 --out " + (dir / "y").string());
    EXPECT_EQ(img.status, 2) << img.out;
    EXPECT_NE(img.out.find("--serve"), std::string::npos);
}

}  // namespace
}  // namespace gonio::testing
