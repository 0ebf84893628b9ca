#pragma once

// Shared pieces of the fit plan's fly tests: the monochrome virtual rig, a truth file, the
// campaign's metadata and journal, the stop rule's estimates, and a fly campaign killed with
// SIGKILL while a sweep of a fit-chosen batch runs.

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cli_run.h"

namespace gonio::testing::plan_fit {

inline std::string mono_rig_path() {
    return std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4-mono.json";
}

/// Writes the model `json` beside the campaign folder `dir`; its path.
inline std::string write_truth(const std::string& dir, const char* json) {
    const std::string p = dir + "_truth.json";
    std::ofstream(p) << json;
    return p;
}

/// The file's JSON; null when the file is missing or empty.
inline nlohmann::json read_json(const std::string& path) {
    const std::string text = read_text(path);
    return text.empty() ? nlohmann::json() : nlohmann::json::parse(text, nullptr, false);
}

struct Estimate {
    double value = NAN;
    double sigma = NAN;
};

/// The stop rule's last check of `name` ("lobes[0].alpha_y"): value and sigma.
inline Estimate estimate_of(const nlohmann::json& until, const std::string& name) {
    const std::string params = until["parameters"].get<std::string>();
    std::smatch m;
    const std::regex item(std::regex_replace(name, std::regex(R"([\[\].])"), R"(\$&)") +
                          R"( ([-+0-9.eE]+) \+- ([-+0-9.eE]+))");
    if (!std::regex_search(params, m, item)) {
        ADD_FAILURE() << "no " << name << " in " << params;
        return {};
    }
    return {std::stod(m[1]), std::stod(m[2])};
}

struct JournalLine {
    std::string type;
    int pass = 0;
    int index = 0;
    std::string text;
    double spin_deg = 0;  ///< the pose's fourth axis, 0 without a four-axis pose
};

inline std::vector<JournalLine> lines_of(const std::string& dir) {
    std::vector<JournalLine> out;
    std::istringstream in(read_text(dir + "/journal.log"));
    for (std::string line; std::getline(in, line);) {
        const auto j = nlohmann::json::parse(line.substr(0, line.find('\t')), nullptr, false);
        if (j.is_object()) {
            const bool posed = j.contains("pose_deg") && j["pose_deg"].size() == 4;
            out.push_back({j.value("type", ""),
                           j.value("pass", 0),
                           j.value("index", 0),
                           j.value("text", ""),
                           posed ? j["pose_deg"][3].get<double>() : 0.0});
        }
    }
    return out;
}

/// The journal's measurements: (pass, pool index) in their order.
inline std::vector<std::pair<int, int>> measured_of(const std::vector<JournalLine>& lines) {
    std::vector<std::pair<int, int>> out;
    for (const JournalLine& l : lines) {
        if (l.type == "measurement") {
            out.push_back({l.pass, l.index});
        }
    }
    return out;
}

/// Spawns the campaign `words` writing into `dir` and kills it with SIGKILL while a sweep of a
/// batch of pass `min_pass` or later runs (its start the journal's last line); false when none
/// came within three minutes.
inline bool kill_inside_sweep(const std::vector<std::string>& words,
                              const std::string& dir,
                              int min_pass) {
    const pid_t pid = spawn_quietly(words);
    EXPECT_GT(pid, 0);
    if (pid <= 0) {
        return false;
    }
    bool inside = false;
    for (int k = 0; k < 90000 && !inside; ++k) {
        const std::vector<JournalLine> lines = lines_of(dir);
        inside = !lines.empty() && lines.back().type == "sweep" && lines.back().pass >= min_pass;
        if (!inside) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    }
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    return inside;
}

/// Resumes the campaign in `dir` killed after the measurements `before`; `after` its
/// measurements then, which begin with `before` and measure each pool configuration once.
inline void resume_keeping(const std::string& dir,
                           const std::vector<std::pair<int, int>>& before,
                           std::vector<std::pair<int, int>>* after) {
    int st = 0;
    const std::string out = run_gonio("acquire --resume " + dir, &st);
    ASSERT_EQ(st, 0) << out;
    *after = measured_of(lines_of(dir));
    ASSERT_GE(after->size(), before.size());
    for (std::size_t k = 0; k < before.size(); ++k) {
        EXPECT_EQ((*after)[k], before[k]);
    }
    std::set<int> pool_once;
    for (const auto& m : *after) {
        EXPECT_TRUE(pool_once.insert(m.second).second) << "pool configuration " << m.second;
    }
}

}  // namespace gonio::testing::plan_fit
