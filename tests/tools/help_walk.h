#pragma once

// The help walk: every option a command's `--help` lists does something or is refused. A table of
// proofs gives, for each option, either two runs whose outcome differs only by that option, or a
// run in a mode that cannot honour it, refused with exit status 2 and a message naming it; prove()
// runs the table and turns red for a listed option without a proof, for an option that stops
// changing anything and for one that stops being refused.
//
// Commands that serve until interrupted (gonio sim, axis serve, camera serve) run as child
// processes: once they print their ready line a probe runs against them (another gonio command on
// the addresses they printed), then they get SIGINT; the outcome is what they printed, their exit
// status and the probe's result.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"

extern char** environ;

namespace gonio::testing {

/// The options and positionals a command's --help lists (without --help itself).
inline std::set<std::string> listed_options(const std::string& command) {
    CliRun r = run_gonio(command + " --help");
    EXPECT_EQ(r.status, 0) << r.out;
    std::set<std::string> out;
    std::istringstream lines(r.out);
    std::string section;
    for (std::string line; std::getline(lines, line);) {
        if (!line.empty() && line[0] != ' ') {
            section = line;
            continue;
        }
        // An entry starts at an indent of two; deeper lines continue a description.
        if (line.size() < 3 || line.compare(0, 2, "  ") != 0 || line[2] == ' ') {
            continue;
        }
        std::istringstream words(line);
        std::string first;
        if (!(words >> first)) {
            continue;
        }
        if (section.rfind("Positionals", 0) == 0) {
            out.insert(first);
        } else if (section.rfind("Options", 0) == 0 && first[0] == '-') {
            std::stringstream names(first);
            for (std::string n; std::getline(names, n, ',');) {
                if (n.rfind("--", 0) == 0 && n != "--help") {
                    out.insert(n);
                }
            }
        }
    }
    return out;
}

/// How one option is shown to matter.
struct Proof {
    std::string option;
    /// Refused: `a` exits 2 with a message naming the option ("gonio CMD" in it).
    /// Changes: `a` and `b` differ only by the option, and their outcomes differ.
    std::string a;
    std::string b;           ///< empty: a refusal
    std::string named = "";  ///< for a refusal: the text naming the option (default: option)
    /// For a change: a file or folder both runs write, compared instead of the printed output
    /// (for options that change a picture or a table, not what is printed).
    std::string written = "";
    /// gonio commands run after each of `a` and `b` (what a fault or a setting does to the next
    /// request); their outputs join the outcome.
    std::vector<std::string> then = {};
    /// For a command that serves until interrupted: the text of its ready line. `a` and `b` run
    /// as servers; `probe` gets what the server printed up to its ready line and returns its own
    /// findings (it may be empty: the printed lines are the outcome).
    std::string ready = "";
    std::function<std::string(const std::string& printed)> probe = nullptr;
    /// For an option documented to leave the result as it is (a thread count): `a` and `b` must
    /// end the same, written files included.
    bool same = false;
    /// For a change with `written`: the exit status `b` must end with (1 for an option that makes
    /// the command fail on purpose: a fit stopped before it converged, --strict on a misfit).
    int b_status = 0;
    /// For a served command: the outcome is the exit status and the probe's findings only, not
    /// the printed lines (a ready line that echoes the option's value would differ whatever the
    /// server did with it).
    bool probe_only = false;
};

/// The bytes of a file, or of every file under a folder (names and contents, in name order);
/// removes it afterwards so that the next run writes it anew.
inline std::string take_written(const std::string& path) {
    namespace fs = std::filesystem;
    std::string out;
    std::vector<fs::path> files;
    if (fs::is_directory(path)) {
        for (const auto& e : fs::recursive_directory_iterator(path)) {
            if (e.is_regular_file()) {
                files.push_back(e.path());
            }
        }
        std::sort(files.begin(), files.end());
    } else if (fs::exists(path)) {
        files.push_back(path);
    }
    for (const fs::path& f : files) {
        std::ifstream in(f, std::ios::binary);
        std::stringstream ss;
        ss << in.rdbuf();
        out += f.filename().string() + "\n" + ss.str();
    }
    fs::remove_all(path);
    return out;
}

/// The words of a command line (split at spaces; no quoting).
inline std::vector<std::string> split_args(const std::string& args) {
    std::vector<std::string> out;
    std::istringstream in(args);
    for (std::string w; in >> w;) {
        out.push_back(w);
    }
    return out;
}

/// Runs `gonio ARGS` as a server: waits (at most 60 s) for a printed line containing `ready`,
/// runs `probe` on what it printed so far, then sends SIGINT and waits for its exit. A server that
/// exits before its ready line (a refusal, a failure) is run to its end and not probed. The result
/// holds the exit status and everything printed, then the probe's findings.
inline CliRun run_served(const std::string& args,
                         const std::string& ready,
                         const std::function<std::string(const std::string&)>& probe) {
    CliRun r;
    int fds[2];
    if (::pipe(fds) != 0) {
        return r;
    }
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 2);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    std::vector<std::string> words = split_args(args);
    words.insert(words.begin(), GONIO_EXE);
    std::vector<char*> argv;
    for (std::string& w : words) {
        argv.push_back(w.data());
    }
    argv.push_back(nullptr);
    pid_t pid = -1;
    const bool spawned = posix_spawn(&pid, GONIO_EXE, &fa, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    if (!spawned) {
        ::close(fds[0]);
        return r;
    }
    // Reads until `stop` says so, the pipe closes, or the deadline passes.
    auto read_until = [&](const std::function<bool()>& stop, std::chrono::seconds limit) {
        const auto deadline = std::chrono::steady_clock::now() + limit;
        while (!stop() && std::chrono::steady_clock::now() < deadline) {
            pollfd p{fds[0], POLLIN, 0};
            if (::poll(&p, 1, 100) <= 0) {
                continue;
            }
            char buf[512];
            const ssize_t n = ::read(fds[0], buf, sizeof buf);
            if (n <= 0) {
                return false;
            }
            r.out.append(buf, static_cast<std::size_t>(n));
        }
        return stop();
    };
    const bool is_ready = read_until(
        [&] {
            const std::size_t at = r.out.find(ready);
            return at != std::string::npos && r.out.find('\n', at) != std::string::npos;
        },
        std::chrono::seconds(60));
    std::string found;
    if (is_ready) {
        found = probe ? probe(r.out) : std::string();
        ::kill(pid, SIGINT);
    }
    read_until([] { return false; }, std::chrono::seconds(60));
    ::close(fds[0]);
    int st = 0;
    if (::waitpid(pid, &st, WNOHANG) == 0) {
        ::kill(pid, SIGKILL);  // it neither stopped on SIGINT nor exited: the run fails below
        ::waitpid(pid, &st, 0);
    }
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    r.out += "\n--- probe ---\n" + found;
    return r;
}

/// The word after `key` in `text` ("serving tcp://127.0.0.1:4711 units ..." -> the address).
inline std::string word_after(const std::string& text, const std::string& key) {
    const std::size_t at = text.find(key);
    if (at == std::string::npos) {
        return "";
    }
    std::istringstream in(text.substr(at + key.size()));
    std::string w;
    in >> w;
    return w;
}

/// `text` with what changes from run to run whatever the options replaced by placeholders: a
/// loopback address (127.x.y.z, which `auto` picks afresh) and the port after it, a
/// pseudo-terminal's path, a file's or folder's path (every absolute path, which names the test's
/// folder, and the time-stamped name of a campaign folder made without --out), and times. Two
/// outcomes are compared in this form, so that a proof that an option changes the result fails
/// when only an address, a port, a path or a time differs: an option that names where to write
/// is proved by what it wrote there (Proof::written), not by the echo of its name.
inline std::string normalised(const std::string& text) {
    static const std::regex address(R"(127\.\d+\.\d+\.\d+(:\d+)?)");
    static const std::regex port_word(R"(\bport \d+)");
    // An absolute path: after a space, a quote, '=', '(' or '[' or at a line's start, up to the
    // next space, quote, comma or bracket, a trailing ':' or '.' left out (a message's colon).
    static const std::regex path(R"((^|[\s'"=(\[])/[^\s'",;()<>\[\]]*[^\s'",;()<>\[\].:])");
    // ISO dates and times (2026-12-07T01:02:03Z, and the folder-name form 2026-12-07T01-02-03).
    static const std::regex when(R"(\d{4}-\d{2}-\d{2}[T ]\d{2}[:-]\d{2}[:-]\d{2}(\.\d+)?Z?)");
    // Times in a fit report ("time_s": 0.0123), which no two runs share.
    static const std::regex seconds(R"(("\w*time_s"): [-+.0-9eE]+)");
    std::string out = std::regex_replace(text, address, "127.N.N.N:P");
    out = std::regex_replace(out, path, "$1PATH");
    out = std::regex_replace(out, when, "TIME");
    out = std::regex_replace(out, seconds, "$1: T");
    return std::regex_replace(out, port_word, "port P");
}

/// Runs the proofs of `command` (as `gonio COMMAND --help` names it). `prepare`, when given, turns
/// each command line into the one to run, just before it runs (to put in the address of a server
/// started afresh for each run, so that no run sees what an earlier one did to it).
inline void prove(const std::string& command,
                  const std::vector<Proof>& table,
                  const std::function<std::string(const std::string&)>& prepare = nullptr) {
    namespace fs = std::filesystem;
    const std::set<std::string> listed = listed_options(command);
    ASSERT_FALSE(listed.empty()) << command;
    // Each run starts in an empty working folder, the same for every run: a folder a command
    // names itself (an image campaign's without --out, image-MATERIAL-N) is named alike in two
    // runs, and nothing is left among the build's files.
    const fs::path home = fs::current_path();
    auto outcome = [&](const Proof& p, const std::string& line) {
        const std::string args = prepare ? prepare(line) : line;
        fs::current_path(test_folder("help_walk_cwd", "run", true));
        CliRun r = p.ready.empty() ? run_gonio(args) : run_served(args, p.ready, p.probe);
        for (const std::string& t : p.then) {
            const CliRun next = run_gonio(prepare ? prepare(t) : t);
            r.out += "\n--- " + t + " (" + std::to_string(next.status) + ") ---\n" + next.out;
        }
        fs::current_path(home);
        return r;
    };
    std::map<std::string, int> proofs;
    for (const Proof& p : table) {
        ++proofs[p.option];
        SCOPED_TRACE(command + " " + p.option + ": " + p.a);
        if (!p.written.empty()) {
            fs::remove_all(p.written);
        }
        CliRun a = outcome(p, p.a);
        if (!p.written.empty()) {
            const std::string wa = take_written(p.written);
            CliRun b = outcome(p, p.b);
            const std::string wb = take_written(p.written);
            EXPECT_EQ(a.status, 0) << p.a << "\n" << a.out;
            EXPECT_EQ(b.status, p.b_status) << p.b << "\n" << b.out;
            EXPECT_FALSE(wa.empty()) << p.a << " wrote nothing at " << p.written;
            const std::string ea = std::to_string(a.status) + "\n" + normalised(wa);
            const std::string eb = std::to_string(b.status) + "\n" + normalised(wb);
            if (p.same) {
                EXPECT_EQ(ea, eb) << p.a << "\n  and\n" << p.b << "\nwrite different " << p.written;
            } else {
                EXPECT_NE(ea, eb) << p.a << "\n  and\n" << p.b << "\nwrite the same " << p.written;
            }
        } else if (p.b.empty()) {
            EXPECT_EQ(a.status, 2) << p.a << "\n" << a.out;
            EXPECT_NE(a.out.find("gonio " + command.substr(0, command.find(' '))),
                      std::string::npos)
                << a.out;
            EXPECT_NE(a.out.find(p.named.empty() ? p.option : p.named), std::string::npos)
                << p.a << "\n"
                << a.out;
        } else {
            CliRun b = outcome(p, p.b);
            if (p.probe_only) {
                // What the probe found (after the marker run_served puts before it).
                for (CliRun* r : {&a, &b}) {
                    const std::size_t at = r->out.rfind("\n--- probe ---\n");
                    r->out = at == std::string::npos ? std::string() : r->out.substr(at);
                }
            }
            if (command == "fit") {
                // A fit prints its times ("0.012 s"), which no two runs share.
                static const std::regex seconds(R"(\b\d+\.\d{3} s\b)");
                a.out = std::regex_replace(a.out, seconds, "T s");
                b.out = std::regex_replace(b.out, seconds, "T s");
            }
            EXPECT_NE(normalised(a.out) + std::to_string(a.status),
                      normalised(b.out) + std::to_string(b.status))
                << p.a << "\n  and\n"
                << p.b << "\nend the same (addresses, ports, paths and times aside):\n"
                << a.out;
        }
    }
    for (const std::string& o : listed) {
        EXPECT_GT(proofs[o], 0) << "gonio " << command << " " << o
                                << ": listed in --help, but nothing shows that it is honoured or "
                                   "refused";
    }
}

/// A command whose --help lists no option: the walk shows that it lists none and that an option
/// or an argument it does not know is refused with exit status 2 naming it.
inline void prove_no_options(const std::string& command) {
    EXPECT_TRUE(listed_options(command).empty()) << "gonio " << command << " lists options now";
    for (const char* extra : {"--verbose", "stray-argument"}) {
        const CliRun r = run_gonio(command + " " + extra);
        EXPECT_EQ(r.status, 2) << command << " " << extra << "\n" << r.out;
        EXPECT_NE(r.out.find(extra), std::string::npos) << r.out;
    }
}

/// A TCP port on 127.0.0.1 held by a listening socket for the object's lifetime.
class BusyPort {
  public:
    BusyPort() {
        fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t len = sizeof a;
        if (fd_ >= 0 && ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
            ::listen(fd_, 1) == 0 &&
            ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
            port_ = ntohs(a.sin_port);
        }
    }
    ~BusyPort() {
        if (fd_ >= 0) {
            ::close(fd_);
        }
    }
    BusyPort(const BusyPort&) = delete;
    BusyPort& operator=(const BusyPort&) = delete;
    int port() const { return port_; }

  private:
    int fd_ = -1;
    int port_ = 0;
};

}  // namespace gonio::testing
