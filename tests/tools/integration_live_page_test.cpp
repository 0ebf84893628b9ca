// The live campaign page: `gonio acquire --serve 127.0.0.1:0` on the embedded virtual rig prints
// its URL; headless Chromium shows the progress advancing and the latest camera frame decoded (a
// point campaign's and an image campaign's, whose coverage map fills too). A flood of clients
// whose requests reach the server's handlers (busy clients on every route, idle connections
// fewer than its HTTP threads, a client that never reads) leaves the campaign its pace: the
// measurements per second while flooded are compared with those of quiet windows between the
// floods, on the same campaign at the same time, so that a loaded machine slows both alike while a
// handler that holds the campaign up stops the flooded ones.

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
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

/// The routes of the live page (live_server.h), every one requested by the flood; /report.html
/// answers 404 until the campaign ends.
constexpr std::array<const char*, 6> kLiveRoutes = {"/",
                                                    "/status.json",
                                                    "/img/in_plane.png",
                                                    "/img/coverage.png",
                                                    "/img/frame.png",
                                                    "/report.html"};

/// An HTTP answer: its status code (-1 when none came) and its body.
struct HttpAnswer {
    int status = -1;
    std::string body;
};

/// One GET of `route` on a fresh connection, its whole answer read (at most `limit_ms` waiting for
/// each piece).
HttpAnswer http_get(int port, const std::string& route, int limit_ms) {
    HttpAnswer a;
    const int fd = connect_to(port);
    if (fd < 0) {
        return a;
    }
    const std::string get = "GET " + route + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
    std::string text;
    bool ok = ::send(fd, get.data(), get.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(get.size());
    char buf[16384];
    for (pollfd p{fd, POLLIN, 0}; ok && ::poll(&p, 1, limit_ms) == 1;) {
        const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
        if (n <= 0) {
            break;
        }
        text.append(buf, static_cast<std::size_t>(n));
    }
    ::close(fd);
    static const std::regex status_line("^HTTP/1\\.[01] ([0-9]{3})");
    std::smatch m;
    if (std::regex_search(text, m, status_line)) {
        a.status = std::stoi(m[1]);
    }
    if (const std::size_t body = text.find("\r\n\r\n"); body != std::string::npos) {
        a.body = text.substr(body + 4);
    }
    return a;
}

/// Polls the live page's /status.json (4 times a second, at most `limit_s`) until `ready` says
/// so of it; the last status read (null when none parsed). What a page shows once its script has
/// read the status is then there for Chromium whatever the machine's load: the server's render
/// thread runs at a lower priority and may lag the campaign by seconds.
nlohmann::json wait_for_status(int port,
                               const std::function<bool(const nlohmann::json&)>& ready,
                               double limit_s) {
    nlohmann::json s;
    const auto deadline = Clock::now() + std::chrono::duration<double>(limit_s);
    while (Clock::now() < deadline) {
        const HttpAnswer a = http_get(port, "/status.json", 5000);
        s = nlohmann::json::parse(a.body, nullptr, false);
        if (a.status == 200 && s.is_object() && ready(s)) {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
    return s;
}

/// Clients that flood the live page while the object lives: kBusy clients that request every
/// route in turn (20 ms apart: traffic, not a CPU load of its own), kIdle connections that
/// send nothing, fewer than the server's HTTP threads (8 at least), so that the busy clients'
/// requests reach the handlers instead of queueing behind them, and one client with a 4 KB
/// receive buffer that asks for a picture 100 times and never reads.
class Flood {
  public:
    static constexpr int kBusy = 3;
    static constexpr int kIdle = 3;

    explicit Flood(int port) {
        for (int i = 0; i < kIdle; ++i) {
            fds_.push_back(connect_to(port));
        }
        const int sink = connect_to(port, 4096);
        fds_.push_back(sink);
        if (sink >= 0) {
            ::fcntl(sink, F_SETFL, O_NONBLOCK);
            const std::string get = "GET /img/in_plane.png HTTP/1.1\r\nHost: x\r\n\r\n";
            for (int i = 0; i < 100; ++i) {
                if (::send(sink, get.data(), get.size(), MSG_NOSIGNAL) < 0) {
                    break;
                }
            }
        }
        for (int c = 0; c < kBusy; ++c) {
            busy_.emplace_back([this, port, c] {
                for (std::size_t k = static_cast<std::size_t>(c); !stop_; ++k) {
                    const std::size_t r = k % kLiveRoutes.size();
                    const int code = http_get(port, kLiveRoutes[r], 5000).status;
                    if (code == 200 || (code == 404 && r + 1 == kLiveRoutes.size())) {
                        ++answered_[r];
                    }
                    std::this_thread::sleep_for(std::chrono::milliseconds(20));
                }
            });
        }
    }
    ~Flood() { stop(); }
    Flood(const Flood&) = delete;
    Flood& operator=(const Flood&) = delete;

    /// Ends the flood: the busy clients finish their request, the connections close.
    void stop() {
        stop_ = true;
        for (std::thread& t : busy_) {
            t.join();
        }
        busy_.clear();
        for (int fd : fds_) {
            if (fd >= 0) {
                ::close(fd);
            }
        }
        fds_.clear();
    }
    /// Requests of route r answered as the server answers it (200; 404 for /report.html).
    std::size_t answered(std::size_t r) const { return answered_[r]; }
    std::size_t connections() const {
        return static_cast<std::size_t>(
            std::count_if(fds_.begin(), fds_.end(), [](int fd) { return fd >= 0; }));
    }

  private:
    std::atomic<bool> stop_{false};
    std::array<std::atomic<std::size_t>, kLiveRoutes.size()> answered_{};
    std::vector<std::thread> busy_;
    std::vector<int> fds_;
};

/// The campaign's measurements in alternating quiet and flooded windows.
struct FloodRates {
    std::size_t quiet_lines = 0;
    std::size_t flooded_lines = 0;
    double quiet_s = 0;
    double flooded_s = 0;
    std::array<std::size_t, kLiveRoutes.size()> answered{};
    std::size_t connections = 0;  ///< the flood's idle and non-reading connections, summed
    double quiet() const { return quiet_s > 0 ? static_cast<double>(quiet_lines) / quiet_s : 0; }
    double flooded() const {
        return flooded_s > 0 ? static_cast<double>(flooded_lines) / flooded_s : 0;
    }
};

/// `rounds` times a quiet window, then a flooded one, `window_s` each: the journal lines written
/// in each kind of window and the requests the flood had answered.
FloodRates flood_rates(const fs::path& out, int port, int rounds, double window_s) {
    FloodRates f;
    auto count = [&](std::size_t* lines, double* seconds) {
        const std::size_t a = journal_lines(out);
        const auto t0 = Clock::now();
        std::this_thread::sleep_for(std::chrono::duration<double>(window_s));
        *lines += journal_lines(out) - a;
        *seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    };
    for (int k = 0; k < rounds; ++k) {
        count(&f.quiet_lines, &f.quiet_s);
        Flood flood(port);
        f.connections += flood.connections();
        count(&f.flooded_lines, &f.flooded_s);
        flood.stop();
        for (std::size_t r = 0; r < kLiveRoutes.size(); ++r) {
            f.answered[r] += flood.answered(r);
        }
    }
    return f;
}

/// `data-done` of the progress line in a dumped DOM, -1 when absent.
long done_in(const std::string& dom) {
    std::smatch m;
    if (std::regex_search(dom, m, std::regex("data-done=\"([0-9]+)\""))) {
        return std::stol(m[1]);
    }
    return -1;
}

/// The attribute `name` of the element with this id in a dumped DOM ("" when absent).
std::string attribute_of(const std::string& dom, const std::string& id, const std::string& name) {
    std::smatch tag;
    if (!std::regex_search(dom, tag, std::regex("<[a-z]+[^>]* id=\"" + id + "\"[^>]*>"))) {
        return {};
    }
    const std::string t = tag.str();
    std::smatch m;
    if (std::regex_search(t, m, std::regex(" " + name + "=\"([^\"]*)\""))) {
        return m[1];
    }
    return {};
}

/// The text inside the element with this id (up to its first child or end tag), whatever
/// attributes the page's script added to it.
std::string inner_text(const std::string& dom, const std::string& id) {
    std::smatch m;
    if (std::regex_search(dom, m, std::regex("<[a-z]+[^>]* id=\"" + id + "\"[^>]*>([^<]*)<"))) {
        return m[1];
    }
    return {};
}

TEST(LivePage, ChromiumWatchesTheCampaignAndFloodingClientsDoNotStopIt) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_test_dir("live_page");
    const fs::path out = dir / "campaign";
    const fs::path log = dir / "acquire.log";
    const fs::path pid_file = dir / "acquire.pid";
    // A child process: the campaign runs while the test looks at it. It is long (657
    // configurations at a paced rig) so that it is still running when the flood starts on any
    // machine; the test stops it with Ctrl-C (SIGINT) once it has seen what it needs.
    const std::string cmd = "echo $$ > " + pid_file.string() + "; exec " + std::string(GONIO_EXE) +
                            " acquire --serve 127.0.0.1:0 --out " + out.string() +
                            " --n-theta 12 --n-dphi 10 --adaptive 0 --time-scale 20 > " +
                            log.string() + " 2>&1";
    int status = -1;
    std::thread campaign([&] { status = std::system(cmd.c_str()); });
    const auto child_pid = [&]() -> pid_t {
        std::ifstream in(pid_file);
        long pid = 0;
        in >> pid;
        return static_cast<pid_t>(pid);
    };
    // Whatever fails below, the child is ended and the thread joined.
    struct Reaper {
        std::thread& t;
        std::function<pid_t()> pid;
        ~Reaper() {
            if (t.joinable()) {
                if (const pid_t p = pid(); p > 0) {
                    ::kill(p, SIGKILL);
                }
                t.join();
            }
        }
    } reaper{campaign, child_pid};
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

    // Chromium twice: the progress it shows advances. The second look comes once the server has
    // more measurements and a drawn camera frame to give (its render thread may lag on a loaded
    // machine: the page can only show what the server has drawn).
    const std::string dom1 = chromium_dump_dom(url, dir / "profile1", 3000);
    const long d1 = done_in(dom1);
    wait_for_status(
        port,
        [d1](const nlohmann::json& s) {
            const nlohmann::json versions = s.value("versions", nlohmann::json::object());
            return s.value("done", -1L) > d1 && versions.is_object() &&
                   versions.value("frame", 0) > 0;
        },
        120);
    const std::string dom2 = chromium_dump_dom(url, dir / "profile2", 3000);
    const long d2 = done_in(dom2);
    std::printf("Chromium saw %ld then %ld measurements\n", d1, d2);
    EXPECT_GE(d1, 0) << dom1.substr(0, 2000);
    EXPECT_GT(d2, d1) << "the page's progress did not advance";
    EXPECT_NE(dom2.find("of "), std::string::npos);
    // The camera frame a measurement was exposed on is shown, decoded, with what it is.
    const std::string fw = attribute_of(dom2, "frame", "data-natural-width");
    EXPECT_GT(fw.empty() ? 0 : std::stol(fw), 0) << dom2.substr(0, 3000);
    EXPECT_NE(element_text(dom2, "frame-caption").find("detector camera"), std::string::npos)
        << element_text(dom2, "frame-caption");

    // Four rounds of a quiet window and a flooded one: the flood's requests reach every handler,
    // and the campaign keeps its pace among them. The comparison is with the quiet windows of the
    // same campaign, taken in turn with the flooded ones, so that the machine's load weighs on
    // both alike; a third of the quiet rate leaves room for that load's swings, and a handler
    // that held the campaign's lock for a while would leave the flooded windows nearly empty.
    const FloodRates rates = flood_rates(out, port, 4, 3.0);
    std::printf(
        "measurement rate (journal lines/s): quiet %.2f (%zu lines in %.1f s), flooded "
        "%.2f (%zu lines in %.1f s); requests answered while flooded:",
        rates.quiet(),
        rates.quiet_lines,
        rates.quiet_s,
        rates.flooded(),
        rates.flooded_lines,
        rates.flooded_s);
    for (std::size_t r = 0; r < kLiveRoutes.size(); ++r) {
        std::printf(" %s %zu", kLiveRoutes[r], rates.answered[r]);
    }
    std::printf("\n");
    ASSERT_GT(rates.quiet_lines, 0u) << "the campaign did not measure in the quiet windows";
    EXPECT_EQ(rates.connections, 4u * (Flood::kIdle + 1)) << "the flood's connections failed";
    for (std::size_t r = 0; r < kLiveRoutes.size(); ++r) {
        EXPECT_GE(rates.answered[r], 4u) << kLiveRoutes[r] << ": the flood did not reach it";
    }
    EXPECT_GE(rates.flooded(), rates.quiet() / 3)
        << "the flood slowed the campaign: " << rates.flooded_lines << " lines in "
        << rates.flooded_s << " s flooded, " << rates.quiet_lines << " in " << rates.quiet_s
        << " s quiet";
    // The campaign ends only when asked to, in the orderly way (a resumable stop), not by an
    // error.
    const pid_t pid = child_pid();
    ASSERT_GT(pid, 0);
    ::kill(pid, SIGINT);
    campaign.join();
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();
    ASSERT_TRUE(WIFEXITED(status)) << text;
    if (WEXITSTATUS(status) == 0) {
        // A machine fast enough to finish 657 paced configurations first.
        EXPECT_NE(text.find("completed:"), std::string::npos) << text;
    } else {
        EXPECT_EQ(WEXITSTATUS(status), 1) << text;
        EXPECT_NE(text.find("stopped on request; continue with: gonio acquire --resume"),
                  std::string::npos)
            << text;
    }
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
    // Image mode checks the address the same way, before the rig starts or a folder is made.
    const CliRun img =
        run_gonio("acquire --mode image --serve 70000 --out " + (dir / "y").string());
    EXPECT_EQ(img.status, 2) << img.out;
    EXPECT_NE(img.out.find("--serve"), std::string::npos);
    EXPECT_FALSE(fs::exists(dir / "y"));
}

TEST(LivePage, ChromiumWatchesAnImageCampaignFillItsTable) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_test_dir("live_page_image");
    const fs::path out = dir / "campaign";
    const fs::path log = dir / "acquire.log";
    const fs::path pid_file = dir / "acquire.pid";
    // An image campaign on the embedded virtual rig, its arms at half of real speed so that each
    // light position takes seconds: it ends at 45 % coverage (about fifteen positions).
    const std::string cmd = "echo $$ > " + pid_file.string() + "; exec " + std::string(GONIO_EXE) +
                            " acquire --mode image --serve 127.0.0.1:0 --out " + out.string() +
                            " --coverage-target 0.45 --max-frames 40 --time-scale 0.5 > " +
                            log.string() + " 2>&1";
    int status = -1;
    std::atomic<bool> finished{false};
    std::thread campaign([&] {
        status = std::system(cmd.c_str());
        finished = true;
    });
    struct Reaper {
        std::thread& t;
        fs::path pid_file;
        ~Reaper() {
            if (t.joinable()) {
                std::ifstream in(pid_file);
                long pid = 0;
                if (in >> pid && pid > 0) {
                    ::kill(static_cast<pid_t>(pid), SIGKILL);
                }
                t.join();
            }
        }
    } reaper{campaign, pid_file};
    auto log_text = [&] {
        std::ifstream in(log);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    };
    std::string url;
    for (int i = 0; i < 1200 && url.empty() && !finished; ++i) {
        std::smatch m;
        const std::string text = log_text();
        if (std::regex_search(text, m, std::regex("live page: (http://127\\.0\\.0\\.1:[0-9]+/)"))) {
            url = m[1];
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_FALSE(url.empty()) << "no live page URL printed\n" << log_text();

    // Chromium looks at the page until the campaign ends: the light positions it reports
    // advance, the coverage grows, the camera frame and the coverage map decode.
    std::vector<long> done;
    std::vector<double> coverage;
    long frame_width = 0;
    long coverage_width = 0;
    std::string frame_caption;
    std::string last_dom;
    // The last look at the running campaign (on a loaded machine the pictures may decode only
    // after its end, when the progress line says so instead).
    std::string running_dom;
    for (int k = 0; k < 30 && !finished; ++k) {
        const std::string dom = chromium_dump_dom(url, dir / ("profile" + std::to_string(k)), 3000);
        const long d = done_in(dom);
        if (d < 0) {
            continue;  // the campaign ended while Chromium loaded the page
        }
        last_dom = dom;
        if (attribute_of(dom, "progress", "data-state") == "running") {
            running_dom = dom;
        }
        done.push_back(d);
        const std::string c = attribute_of(dom, "progress", "data-coverage");
        coverage.push_back(c.empty() ? -1.0 : std::stod(c));
        const std::string fw = attribute_of(dom, "frame", "data-natural-width");
        const std::string cw = attribute_of(dom, "coverage", "data-natural-width");
        frame_width = std::max(frame_width, fw.empty() ? 0L : std::stol(fw));
        coverage_width = std::max(coverage_width, cw.empty() ? 0L : std::stol(cw));
        if (!fw.empty()) {
            frame_caption = inner_text(dom, "frame-caption");
        }
        if (done.size() >= 2 && done.back() > done.front() && frame_width > 0 &&
            coverage_width > 0) {
            break;
        }
    }
    for (std::size_t i = 0; i < done.size(); ++i) {
        std::printf("Chromium saw %ld light positions, coverage %.2f %%\n", done[i], coverage[i]);
    }
    ASSERT_GE(done.size(), 2u) << "Chromium saw the running campaign fewer than twice\n"
                               << last_dom.substr(0, 3000);
    EXPECT_GT(done.back(), done.front()) << "the light positions shown did not advance";
    EXPECT_GT(coverage.back(), coverage.front()) << "the coverage shown did not grow";
    EXPECT_GT(frame_width, 0) << "the camera frame did not decode\n" << last_dom.substr(0, 3000);
    EXPECT_LE(frame_width, 480);
    EXPECT_GT(coverage_width, 0) << "the coverage map did not decode";
    EXPECT_NE(frame_caption.find("light arm at"), std::string::npos) << frame_caption;
    const std::string progress = inner_text(running_dom, "progress");
    EXPECT_NE(progress.find("light positions; coverage"), std::string::npos) << progress;
    EXPECT_NE(progress.find("ETA"), std::string::npos) << progress;
    EXPECT_NE(progress.find("target 45.0 %"), std::string::npos) << progress;

    // The campaign ends by itself, at its target, with its table written; its page stays up
    // until Ctrl-C and shows the end.
    std::string ended_text;
    for (int i = 0; i < 3000 && ended_text.empty() && !finished; ++i) {
        const std::string t = log_text();
        if (t.find("campaign ended (") != std::string::npos) {
            ended_text = t;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_FALSE(ended_text.empty()) << log_text();
    EXPECT_FALSE(finished) << "the command ended with the campaign, its page with it";
    const std::string end_dom = chromium_dump_dom(url, dir / "profile_end", 3000);
    EXPECT_EQ(attribute_of(end_dom, "progress", "data-state"), "ended") << end_dom.substr(0, 3000);
    EXPECT_NE(inner_text(end_dom, "progress").find("campaign ended (completed)"), std::string::npos)
        << inner_text(end_dom, "progress");
    EXPECT_EQ(attribute_of(end_dom, "report-link", "href"), "/report.html");
    {
        std::ifstream in(pid_file);
        long pid = 0;
        in >> pid;
        ASSERT_GT(pid, 0);
        ::kill(static_cast<pid_t>(pid), SIGINT);
    }
    campaign.join();
    const std::string text = log_text();
    ASSERT_TRUE(WIFEXITED(status)) << text;
    EXPECT_EQ(WEXITSTATUS(status), 0) << text;
    EXPECT_NE(text.find("stopped: coverage target met"), std::string::npos) << text;
    EXPECT_TRUE(fs::exists(out / "dataset.csv"));
    EXPECT_TRUE(fs::exists(out / "report.html"));
    EXPECT_NE(text.find("next: gonio fit " + (out / "dataset.csv").string()), std::string::npos)
        << text;
}

TEST(LivePage, AnAddressThatCannotBeServedLeavesNoFolder) {
    const fs::path dir = fresh_test_dir("live_page_unbound");
    // An address of no interface of this machine, and a port another server holds.
    const int busy_fd = ::socket(AF_INET, SOCK_STREAM, 0);
    ASSERT_GE(busy_fd, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(busy_fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    ASSERT_EQ(::listen(busy_fd, 1), 0);
    socklen_t len = sizeof a;
    ::getsockname(busy_fd, reinterpret_cast<sockaddr*>(&a), &len);
    const std::string busy = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
    for (const std::string& serve : {std::string("1.2.3.4:80"), busy}) {
        for (const char* mode : {"", " --mode image"}) {
            const fs::path out = dir / "zz";
            const CliRun r = run_gonio("acquire" + std::string(mode) + " --serve " + serve +
                                       " --out " + out.string());
            EXPECT_EQ(r.status, 1) << serve << mode << "\n" << r.out;
            EXPECT_NE(r.out.find("cannot listen on"), std::string::npos) << r.out;
            EXPECT_EQ(r.out.find("campaign folder:"), std::string::npos) << r.out;
            EXPECT_FALSE(fs::exists(out)) << serve << mode << ": a failed start left its folder";
            // Without --out nothing appears among the automatically named folders either.
            const fs::path parent = dir / "campaigns";
            const CliRun q = run_gonio("acquire" + std::string(mode) + " --serve " + serve +
                                       " --campaigns-dir " + parent.string());
            EXPECT_EQ(q.status, 1) << q.out;
            std::error_code ec;
            EXPECT_TRUE(!fs::exists(parent) || fs::is_empty(parent, ec))
                << serve << mode << ": a failed start left a folder in " << parent;
        }
    }
    ::close(busy_fd);
}

TEST(LivePage, AfterTheCampaignThePageShowsTheEndUntilCtrlC) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_test_dir("live_page_end");
    const fs::path out = dir / "campaign";
    const fs::path log = dir / "acquire.log";
    const fs::path pid_file = dir / "acquire.pid";
    const std::string cmd = "echo $$ > " + pid_file.string() + "; exec " + std::string(GONIO_EXE) +
                            " acquire --serve 127.0.0.1:0 --out " + out.string() +
                            " --n-theta 4 --n-dphi 4 --adaptive 0 > " + log.string() + " 2>&1";
    int status = -1;
    std::atomic<bool> finished{false};
    std::thread campaign([&] {
        status = std::system(cmd.c_str());
        finished = true;
    });
    const auto child_pid = [&]() -> pid_t {
        std::ifstream in(pid_file);
        long pid = 0;
        in >> pid;
        return static_cast<pid_t>(pid);
    };
    struct Reaper {
        std::thread& t;
        std::function<pid_t()> pid;
        ~Reaper() {
            if (t.joinable()) {
                if (const pid_t p = pid(); p > 0) {
                    ::kill(p, SIGKILL);
                }
                t.join();
            }
        }
    } reaper{campaign, child_pid};
    auto log_text = [&] {
        std::ifstream in(log);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    };
    // The campaign ends; the command says its page stays up, and stays.
    std::string text;
    for (int i = 0; i < 3000 && !finished; ++i) {
        text = log_text();
        if (text.find("until Ctrl-C") != std::string::npos) {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_FALSE(finished) << "the command ended with its campaign\n" << log_text();
    EXPECT_NE(text.find("campaign ended (completed); the live page http://127.0.0.1:"),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("next: gonio fit " + (out / "dataset.csv").string() + " --out " +
                        (out / "fit.json").string()),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("gonio report " + out.string()), std::string::npos) << text;
    std::smatch m;
    ASSERT_TRUE(
        std::regex_search(text, m, std::regex("live page: (http://127\\.0\\.0\\.1:[0-9]+/)")));
    const std::string url = m[1];
    const int port = std::stoi(std::regex_replace(url, std::regex(".*:([0-9]+)/$"), "$1"));
    // The final fit is the server's render thread's work after the campaign's end, at a lower
    // priority than anything else: Chromium looks once the server has it to show.
    const auto ended_at = Clock::now();
    wait_for_status(
        port,
        [](const nlohmann::json& s) {
            return s.value("fit", std::string()).rfind("final fit on ", 0) == 0;
        },
        120);
    std::printf("waited %.1f s after the campaign's end for the final fit on the server\n",
                std::chrono::duration<double>(Clock::now() - ended_at).count());
    const std::string dom = chromium_dump_dom(url, dir / "profile", 4000);
    EXPECT_EQ(attribute_of(dom, "progress", "data-state"), "ended") << dom.substr(0, 3000);
    const std::string progress = inner_text(dom, "progress");
    EXPECT_EQ(progress.rfind("campaign ended (completed): ", 0), 0u) << progress;
    EXPECT_EQ(progress.find("running"), std::string::npos) << progress;
    EXPECT_EQ(attribute_of(dom, "report-link", "href"), "/report.html") << dom.substr(0, 3000);
    EXPECT_NE(inner_text(dom, "fit").find("final fit on "), std::string::npos)
        << inner_text(dom, "fit");
    // /status.json says so, and the report is served.
    const std::string status_dom = chromium_dump_dom(url + "status.json", dir / "profile2", 1000);
    EXPECT_NE(status_dom.find("\"ended\":true"), std::string::npos) << status_dom;
    const std::string report_dom = chromium_dump_dom(url + "report.html", dir / "profile3", 1000);
    EXPECT_NE(report_dom.find("id=\"verdict\""), std::string::npos) << report_dom.substr(0, 2000);
    EXPECT_TRUE(fs::exists(out / "report.html"));
    // Ctrl-C ends the command with the campaign's status.
    const pid_t pid = child_pid();
    ASSERT_GT(pid, 0);
    ::kill(pid, SIGINT);
    campaign.join();
    ASSERT_TRUE(WIFEXITED(status)) << log_text();
    EXPECT_EQ(WEXITSTATUS(status), 0) << log_text();
}

}  // namespace
}  // namespace gonio::testing
