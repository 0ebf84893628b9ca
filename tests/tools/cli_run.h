#pragma once

// Runs the gonio binary under test (GONIO_EXE) and gives each test a folder of its own: ctest runs
// the tests of one executable as parallel processes, so nothing may be shared between them.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace gonio::testing {

struct CliRun {
    int status = -1;  ///< exit status, -1 when the process did not exit normally
    std::string out;  ///< standard output (and standard error, see run_gonio)
};

/// Runs `gonio ARGS`. Without `stderr_path` standard error is merged into `out`; with it, standard
/// error goes to that file and is appended to `out` after a "--- stderr ---" line.
inline CliRun run_gonio(const std::string& args, const std::string& stderr_path = "") {
    const std::string redirect = stderr_path.empty() ? " 2>&1" : " 2>" + stderr_path;
    const std::string cmd = std::string(GONIO_EXE) + " " + args + redirect;
    CliRun r;
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) {
        return r;
    }
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) {
        r.out.append(buf, n);
    }
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    if (!stderr_path.empty()) {
        std::ifstream e(stderr_path);
        std::stringstream ss;
        ss << e.rdbuf();
        r.out += "\n--- stderr ---\n" + ss.str();
    }
    return r;
}

/// The same for tests that keep the status apart: the output (standard error merged), the exit
/// status in *status.
inline std::string run_gonio(const std::string& args, int* status) {
    CliRun r = run_gonio(args);
    *status = r.status;
    return std::move(r.out);
}

/// Starts `words` (words[0] the program, e.g. GONIO_EXE) as a child process with its standard output
/// sent to /dev/null, for a test that kills it midway; returns its pid, or -1 when it did not start.
inline pid_t spawn_quietly(std::vector<std::string> words) {
    std::vector<char*> argv;
    for (std::string& w : words) {
        argv.push_back(w.data());
    }
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    pid_t pid = -1;
    const int e = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    return e == 0 ? pid : -1;
}

/// A fresh folder for the running test: GONIO_BINARY_DIR/tests/<prefix>_<test name>.
/// GONIO_BINARY_DIR/<group>/<name>_<pid>, removed if it was there, with its parent created; the
/// folder itself is created when `create` (a campaign's --out must not exist before the campaign).
inline std::string test_folder(const std::string& group, const std::string& name, bool create) {
    const std::filesystem::path d =
        std::filesystem::path(GONIO_BINARY_DIR) / group / (name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(create ? d : d.parent_path());
    return d.string();
}

/// The whole content of a file ("" when it cannot be read).
inline std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

inline std::filesystem::path fresh_test_dir(const std::string& prefix) {
    const std::filesystem::path dir =
        std::filesystem::path(GONIO_BINARY_DIR) / "tests" /
        (prefix + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

}  // namespace gonio::testing
