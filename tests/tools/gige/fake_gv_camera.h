#pragma once

// Aravis's simulated GigE Vision camera (arv-fake-gv-camera-0.8) on 127.0.0.1, started by the test
// and killed by its PID. GigE Vision control uses the fixed UDP port 3956, so the fixture holds the
// machine-wide lock file /tmp/gonio-gige.lock (the same one `flock` takes) while the camera runs,
// unless the test runs in a network namespace of its own (GONIO_TEST_NETNS=1, tests/netns-run.sh),
// where its 127.0.0.1:3956 is its own.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

extern char** environ;

namespace gonio::testing {

/// Runs a shell command, returns its exit status and standard output + error.
inline int run_command(const std::string& cmd, std::string* out) {
    out->clear();
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    if (p == nullptr) {
        return -1;
    }
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) {
        out->append(buf, n);
    }
    const int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/// `arv-tool-0.8 -a 127.0.0.1 ARGS`: Aravis's own tool, the reference the tests trust.
inline int arv_tool(const std::string& args, std::string* out) {
    return run_command("arv-tool-0.8 -a 127.0.0.1 " + args, out);
}

/// Parses "Feature = VALUE ..." from arv-tool's `control` output; false when absent.
inline bool arv_value(const std::string& out, const std::string& feature, std::string* value) {
    const std::string key = feature + " = ";
    std::size_t at = 0;
    while ((at = out.find(key, at)) != std::string::npos) {
        if (at == 0 || out[at - 1] == '\n') {
            const std::size_t start = at + key.size();
            const std::size_t end = out.find_first_of(" \n", start);
            *value = out.substr(start, end == std::string::npos ? end : end - start);
            return true;
        }
        at += key.size();
    }
    return false;
}

/// Parses "min:A max:B" of a feature from arv-tool's `control` output.
inline bool arv_bounds(const std::string& out, const std::string& feature, double* lo, double* hi) {
    const std::size_t at = out.find(feature + " = ");
    if (at == std::string::npos) {
        return false;
    }
    const std::size_t line_end = out.find('\n', at);
    const std::string line =
        out.substr(at, line_end == std::string::npos ? line_end : line_end - at);
    const std::size_t mn = line.find("min:");
    const std::size_t mx = line.find("max:");
    if (mn == std::string::npos || mx == std::string::npos) {
        return false;
    }
    *lo = std::strtod(line.c_str() + mn + 4, nullptr);
    *hi = std::strtod(line.c_str() + mx + 4, nullptr);
    return true;
}

class FakeGvCamera {
  public:
    /// Takes the GigE lock, starts the camera with `extra` arguments and waits until Aravis's own
    /// tool reads it (a bounded number of attempts, each bounded by arv-tool's timeouts).
    explicit FakeGvCamera(const std::vector<std::string>& extra = {})
        : FakeGvCamera(with_program({"arv-fake-gv-camera-0.8", "-i", "127.0.0.1"}, extra)) {}

    /// Any other GigE Vision camera served on 127.0.0.1 by the command `argv` (e.g. gonio's own
    /// simulated camera, `gonio camera serve`), under the same lock.
    struct Command {
        std::vector<std::string> argv;
    };
    explicit FakeGvCamera(const Command& command) {
        if (!alone_on_loopback()) {
            lock_fd_ = ::open("/tmp/gonio-gige.lock", O_RDWR | O_CREAT | O_CLOEXEC, 0666);
            if (lock_fd_ < 0 || ::flock(lock_fd_, LOCK_EX) != 0) {
                error_ = "cannot lock /tmp/gonio-gige.lock";
                return;
            }
        }
        std::vector<std::string> args = command.argv;
        std::vector<char*> argv;
        for (auto& a : args) {
            argv.push_back(a.data());
        }
        argv.push_back(nullptr);
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
        posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
        if (posix_spawnp(&pid_, args[0].c_str(), &fa, nullptr, argv.data(), environ) != 0) {
            pid_ = -1;
            error_ = "cannot start " + args[0];
        }
        posix_spawn_file_actions_destroy(&fa);
        if (pid_ <= 0) {
            return;
        }
        std::string out;
        for (int attempt = 0; attempt < 20; ++attempt) {
            if (arv_tool("control DeviceID", &out) == 0 &&
                out.find("DeviceID = ") != std::string::npos) {
                ready_ = true;
                return;
            }
            int st = 0;
            if (::waitpid(pid_, &st, WNOHANG) == pid_) {
                pid_ = -1;
                error_ = args[0] + " exited: " + out;
                return;
            }
        }
        error_ = args[0] + " did not answer arv-tool-0.8: " + out;
    }
    ~FakeGvCamera() {
        kill_now();
        if (lock_fd_ >= 0) {
            ::close(lock_fd_);  // releases the lock
        }
    }
    FakeGvCamera(const FakeGvCamera&) = delete;
    FakeGvCamera& operator=(const FakeGvCamera&) = delete;

    /// SIGKILL, as a camera losing power: no goodbye on the wire.
    void kill_now() {
        if (pid_ > 0) {
            ::kill(pid_, SIGKILL);
            int st = 0;
            ::waitpid(pid_, &st, 0);
            pid_ = -1;
        }
    }
    bool ready() const { return ready_; }
    const std::string& error() const { return error_; }

  private:
    static bool alone_on_loopback() {
        const char* netns = std::getenv("GONIO_TEST_NETNS");
        return netns != nullptr && std::string(netns) == "1";
    }

    static Command with_program(std::vector<std::string> argv,
                                const std::vector<std::string>& extra) {
        argv.insert(argv.end(), extra.begin(), extra.end());
        return Command{argv};
    }

    int lock_fd_ = -1;
    pid_t pid_ = -1;
    bool ready_ = false;
    std::string error_;
};

}  // namespace gonio::testing
