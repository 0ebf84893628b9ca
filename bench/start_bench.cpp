// Process start of the gonio executable: wall time of `gonio --help`, `gonio eval` of one line and
// `gonio-full --help` (the executable of the device, camera and image commands), each run as a
// child process with its output discarded. The counter shared_libraries is the number of shared
// objects the dynamic loader maps for the executable (LD_TRACE_LOADED_OBJECTS, as ldd reports).
//
//   cmake -S . -B build -DGONIO_BUILD_BENCH=ON && cmake --build build --target gonio
//   gonio_start_bench build/bench/gonio_start_bench --benchmark_min_time=2

#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

extern char** environ;

namespace {

/// Runs argv with stdin from `input` (or /dev/null) and stdout/stderr to /dev/null; exit status.
int run(const std::vector<std::string>& args, const std::string& input = "/dev/null") {
    std::vector<char*> argv;
    for (const std::string& a : args) {
        argv.push_back(const_cast<char*>(a.c_str()));
    }
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 0, input.c_str(), O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
        return -1;
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Shared objects the loader maps for `exe` (the lines of LD_TRACE_LOADED_OBJECTS=1 with "=>" or
/// a path).
double shared_libraries(const std::string& exe) {
    const std::string cmd = "LD_TRACE_LOADED_OBJECTS=1 " + exe + " 2>/dev/null";
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) {
        return -1;
    }
    int count = 0;
    char line[4096];
    while (std::fgets(line, sizeof line, p) != nullptr) {
        ++count;
    }
    pclose(p);
    return count;
}

void run_bench(benchmark::State& state,
               const std::vector<std::string>& args,
               const std::string& input = "/dev/null") {
    int failures = 0;
    for (auto _ : state) {
        failures += run(args, input) != 0;
    }
    state.counters["failed_runs"] = failures;
    state.counters["shared_libraries"] = shared_libraries(args[0]);
}

void BM_StartHelp(benchmark::State& state) {
    run_bench(state, {GONIO_EXE, "--help"});
}
BENCHMARK(BM_StartHelp)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StartEvalOneLine(benchmark::State& state) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path();
    const std::string input = (dir / "gonio_start_bench_dirs.csv").string();
    std::ofstream(input) << "theta_i,phi_i,theta_o,phi_o\n0.3,0,0.5,3.0\n";
    const std::string model = std::string(GONIO_SOURCE_DIR) + "/data/models/plastic-ggx.json";
    run_bench(state, {GONIO_EXE, "eval", model}, input);
}
BENCHMARK(BM_StartEvalOneLine)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StartFullHelp(benchmark::State& state) {
    run_bench(state, {GONIO_FULL_EXE, "--help"});
}
BENCHMARK(BM_StartFullHelp)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
