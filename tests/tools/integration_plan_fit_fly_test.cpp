// `gonio acquire --plan fit --fly` on the virtual rig (monochrome sim4, reference error budget):
// on a GGX alpha 0.05 truth with --until sigma=0.01 each batch is chosen as sweeps, the campaign
// stops on its rule before the plan's budget with alpha within 3 sigma of the truth, in less rig
// time (metadata.json rig_time_s, simulated rig seconds) than `--plan fit` stop-and-go on the same
// truth; killed with SIGKILL while a sweep of a fit-chosen batch runs and resumed, no value is
// lost or measured twice and that sweep's configurations are measured after the resume.

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <thread>

#include "cli_run.h"

extern char** environ;

namespace plan_fit_fly_test {
namespace {

using gonio::testing::read_text;
using gonio::testing::run_gonio;

const char* kGgx005 = R"({"diffuse": [0.02, 0.02, 0.02], "lobes": [{"distribution": "ggx",
    "alpha": 0.05, "shadowing": "smith-correlated",
    "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

std::string mono_rig_path() {
    return std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4-mono.json";
}

std::string ggx_truth(const std::string& dir) {
    const std::string p = dir + "_truth.json";
    std::ofstream(p) << kGgx005;
    return p;
}

nlohmann::json read_json(const std::string& path) {
    const std::string text = read_text(path);
    return text.empty() ? nlohmann::json() : nlohmann::json::parse(text, nullptr, false);
}

/// The stop rule's check of alpha: value and sigma.
std::pair<double, double> alpha_of(const nlohmann::json& until) {
    const std::string params = until["parameters"].get<std::string>();
    std::smatch m;
    const std::regex item(R"(lobes\[0\]\.alpha_x ([-+0-9.eE]+) \+- ([-+0-9.eE]+))");
    if (!std::regex_search(params, m, item)) {
        ADD_FAILURE() << "no alpha in " << params;
        return {NAN, NAN};
    }
    return {std::stod(m[1]), std::stod(m[2])};
}

struct JournalLine {
    std::string type;
    int pass = 0;
    int index = 0;
    std::string text;
};

std::vector<JournalLine> lines_of(const std::string& dir) {
    std::vector<JournalLine> out;
    std::istringstream in(read_text(dir + "/journal.log"));
    for (std::string line; std::getline(in, line);) {
        const auto j = nlohmann::json::parse(line.substr(0, line.find('\t')), nullptr, false);
        if (j.is_object()) {
            out.push_back({j.value("type", ""),
                           j.value("pass", 0),
                           j.value("index", 0),
                           j.value("text", "")});
        }
    }
    return out;
}

std::vector<std::pair<int, int>> measured_of(const std::vector<JournalLine>& lines) {
    std::vector<std::pair<int, int>> out;
    for (const JournalLine& l : lines) {
        if (l.type == "measurement") {
            out.push_back({l.pass, l.index});
        }
    }
    return out;
}

// The fly run's frames are triggered by the drives' position compare (the rig's default time
// scale): a loaded machine delays their arrival, never their positions.
TEST(AcquirePlanFitFly, ReachesTheTargetInLessRigTimeThanStopAndGo) {
    const std::string fly_dir =
        gonio::testing::test_folder("test_tools_plan_fit_fly", "fly", false);
    const std::string still_dir =
        gonio::testing::test_folder("test_tools_plan_fit_fly", "still", false);
    const std::string truth = ggx_truth(fly_dir);
    int st = 0;
    const std::string out =
        run_gonio("acquire --plan fit --fly --rig " + mono_rig_path() + " --brdf " + truth +
                      " --out " + fly_dir + " --until sigma=0.01",
                  &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("stopped: target reached"), std::string::npos) << out;
    EXPECT_NE(out.find("sweeps through"), std::string::npos) << out;
    const nlohmann::json fly = read_json(fly_dir + "/metadata.json");
    ASSERT_TRUE(fly["until"]["held"].get<bool>()) << fly["until"].dump();
    EXPECT_EQ(fly["runs"][0]["stopped"], "target reached");
    EXPECT_LT(fly["measured"].get<int>(), 120) << "the plan's budget";
    EXPECT_GT(fly["runs"][0]["fly"]["swept"].get<int>(),
              fly["runs"][0]["fly"]["standing"].get<int>())
        << fly["runs"][0]["fly"].dump();
    // Every batch after the first (if the rule did not hold within it) was chosen as sweeps
    // from a fit.
    for (const auto& b : fly["fit_plan"]["batches"].items()) {
        EXPECT_TRUE(b.value()["fitted"].get<bool>()) << b.value().dump();
        EXPECT_GT(b.value()["sweeps"].get<int>(), 0) << b.value().dump();
    }
    const auto [alpha, sigma] = alpha_of(fly["until"]);
    std::printf("fit plan, fly: alpha %.6g +- %.3g (truth 0.05), %d values, rig time %.1f s\n",
                alpha,
                sigma,
                fly["measured"].get<int>(),
                fly["rig_time_s"].get<double>());
    EXPECT_LE(std::abs(alpha - 0.05), 3 * sigma);

    const std::string still =
        run_gonio("acquire --plan fit --rig " + mono_rig_path() + " --brdf " + truth + " --out " +
                      still_dir + " --time-scale 500 --until sigma=0.01",
                  &st);
    ASSERT_EQ(st, 0) << still;
    const nlohmann::json stop_go = read_json(still_dir + "/metadata.json");
    ASSERT_TRUE(stop_go["until"]["held"].get<bool>()) << stop_go["until"].dump();
    std::printf("fit plan, stop-and-go: %d values, rig time %.1f s\n",
                stop_go["measured"].get<int>(),
                stop_go["rig_time_s"].get<double>());
    EXPECT_LT(fly["rig_time_s"].get<double>(), stop_go["rig_time_s"].get<double>());
}

TEST(AcquirePlanFitFly, KilledMidSweepAndResumedLosesAndRepeatsNothing) {
    const std::string dir = gonio::testing::test_folder("test_tools_plan_fit_fly", "kill9", false);
    const std::string truth = ggx_truth(dir);
    std::vector<std::string> words = {GONIO_EXE,
                                      "acquire",
                                      "--plan",
                                      "fit",
                                      "--fly",
                                      "--rig",
                                      mono_rig_path(),
                                      "--brdf",
                                      truth,
                                      "--out",
                                      dir,
                                      "--time-scale",
                                      "5"};
    const pid_t pid = gonio::testing::spawn_quietly(words);
    ASSERT_GT(pid, 0);
    // Killed while a sweep of a batch chosen from the fit (pass 2 or later) runs: its start is
    // the journal's last line.
    bool inside = false;
    for (int k = 0; k < 90000 && !inside; ++k) {  // at most three minutes
        const std::vector<JournalLine> lines = lines_of(dir);
        inside = !lines.empty() && lines.back().type == "sweep" && lines.back().pass >= 2;
        if (!inside) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    }
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(inside) << "no sweep of the third batch within three minutes";
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    const std::vector<JournalLine> killed = lines_of(dir);
    const auto before = measured_of(killed);
    int st = 0;
    const std::string out = run_gonio("acquire --resume " + dir, &st);
    ASSERT_EQ(st, 0) << out;
    const auto after = measured_of(lines_of(dir));
    ASSERT_GE(after.size(), before.size());
    for (std::size_t k = 0; k < before.size(); ++k) {
        EXPECT_EQ(after[k], before[k]);
    }
    const std::set<std::pair<int, int>> unique(after.begin(), after.end());
    EXPECT_EQ(unique.size(), after.size()) << "a configuration measured twice";
    std::set<int> pool_once;
    for (const auto& m : after) {
        EXPECT_TRUE(pool_once.insert(m.second).second) << "pool configuration " << m.second;
    }
    EXPECT_EQ(after.size(), 120u) << "the budget";
    // The interrupted sweep's configurations, none measured before the kill, all after it, in
    // the batch it belonged to (the resume rebuilt that batch).
    const JournalLine& sweep = killed.back();
    std::istringstream members(sweep.text.substr(sweep.text.find(':') + 1));
    const std::set<std::pair<int, int>> done_before(before.begin(), before.end());
    int n = 0;
    for (int index = 0; members >> index; ++n) {
        EXPECT_EQ(done_before.count({sweep.pass, index}), 0u) << index;
        EXPECT_EQ(unique.count({sweep.pass, index}), 1u) << index;
    }
    EXPECT_GE(n, 2) << sweep.text;
    const nlohmann::json meta = read_json(dir + "/metadata.json");
    // The batches after the first were chosen from the fit, as sweeps where the prediction is
    // least certain and sweeps that fill space.
    ASSERT_GE(meta["fit_plan"]["batches"].size(), 2u) << meta["fit_plan"].dump();
    for (const auto& b : meta["fit_plan"]["batches"].items()) {
        EXPECT_TRUE(b.value()["fitted"].get<bool>()) << b.value().dump();
        EXPECT_GT(b.value()["sweeps"].get<int>(), 0) << b.value().dump();
        EXPECT_GT(b.value()["by_variance"].get<int>(), 0) << b.value().dump();
        EXPECT_GT(b.value()["by_space"].get<int>(), 0) << b.value().dump();
    }
    ASSERT_EQ(meta["runs"].size(), 2u);
    EXPECT_EQ(meta["runs"][0]["state"], "killed");
    EXPECT_EQ(meta["runs"][1]["stopped"], "plan end");
}

}  // namespace
}  // namespace plan_fit_fly_test
