// `gonio acquire --plan fit` on the virtual rig (reference error budget): on a GGX truth with
// --until it reaches the target with fewer configurations than the uniform plan, its parameters
// within 3 sigma of the truth; on a measured RGL material served as the truth it runs and ends
// saying why; killed with SIGKILL in the middle of a batch and resumed, it measures exactly the
// batch it was measuring (every configuration once, every batch of its size).

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <thread>

#include "cli_run.h"

extern char** environ;

namespace plan_fit_test {
namespace {

using gonio::testing::read_text;
using gonio::testing::run_gonio;

const char* kTruth = R"({"diffuse": [0.1, 0.1, 0.1], "lobes": [{"distribution": "ggx",
    "alpha": 0.2, "shadowing": "smith-correlated",
    "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

double truth_of(const std::string& name) {
    if (name.rfind("diffuse", 0) == 0) {
        return 0.1;
    }
    if (name == "lobes[0].alpha_x") {
        return 0.2;
    }
    if (name == "lobes[0].fresnel.f0") {
        return 0.04;
    }
    if (name.rfind("lobes[0].scale", 0) == 0) {
        return 1.0;
    }
    ADD_FAILURE() << "unexpected parameter " << name;
    return std::nan("");
}

nlohmann::json metadata(const std::string& dir) {
    const std::string text = read_text(dir + "/metadata.json");
    return text.empty() ? nlohmann::json() : nlohmann::json::parse(text, nullptr, false);
}

std::string truth_file(const std::string& dir) {
    const std::string p = dir + "_truth.json";
    std::ofstream(p) << kTruth;
    return p;
}

/// Every parameter of the stop rule's check within 3 sigma of the truth.
void expect_within_3_sigma(const nlohmann::json& until) {
    const std::string params = until["parameters"].get<std::string>();
    const std::regex item(R"(([^;\s]+) ([-+0-9.eE]+) \+- ([-+0-9.eE]+))");
    int n = 0;
    for (auto it = std::sregex_iterator(params.begin(), params.end(), item);
         it != std::sregex_iterator();
         ++it, ++n) {
        const std::string name = (*it)[1];
        EXPECT_LE(std::abs(std::stod((*it)[2]) - truth_of(name)), 3 * std::stod((*it)[3]))
            << name << " in " << params;
    }
    EXPECT_EQ(n, 8) << params;
}

/// (pass, index) of every measurement in a campaign's journal.
std::vector<std::pair<int, int>> journal_measurements(const std::string& dir) {
    std::vector<std::pair<int, int>> out;
    std::istringstream in(read_text(dir + "/journal.log"));
    for (std::string line; std::getline(in, line);) {
        const auto j = nlohmann::json::parse(line.substr(0, line.find('\t')), nullptr, false);
        if (j.is_object() && j.value("type", "") == "measurement") {
            out.push_back({j["pass"].get<int>(), j["index"].get<int>()});
        }
    }
    return out;
}

TEST(AcquirePlanFit, ReachesTheTargetWithFewerConfigurationsThanTheUniformPlan) {
    const std::string fit_dir = gonio::testing::test_folder("test_tools_plan_fit", "fit", false);
    const std::string uni_dir =
        gonio::testing::test_folder("test_tools_plan_fit", "uniform", false);
    const std::string truth = truth_file(fit_dir);
    int st = 0;
    const std::string out = run_gonio("acquire --brdf " + truth + " --out " + fit_dir +
                                          " --plan fit --time-scale 500 --until sigma=0.01",
                                      &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("stopped: target reached"), std::string::npos) << out;
    EXPECT_NE(out.find("where the prediction is least certain"), std::string::npos) << out;
    const std::string uni = run_gonio("acquire --brdf " + truth + " --out " + uni_dir +
                                          " --n-theta 8 --n-dphi 6 --adaptive 0 --time-scale 500 "
                                          "--until sigma=0.01",
                                      &st);
    ASSERT_EQ(st, 0) << uni;
    const nlohmann::json fit = metadata(fit_dir);
    const nlohmann::json uniform = metadata(uni_dir);
    ASSERT_TRUE(fit["until"]["held"].get<bool>()) << fit["until"].dump();
    ASSERT_TRUE(uniform["until"]["held"].get<bool>()) << uniform["until"].dump();
    EXPECT_LT(fit["measured"].get<int>(), uniform["measured"].get<int>());
    EXPECT_LT(fit["rig_time_s"].get<double>(), uniform["rig_time_s"].get<double>());
    expect_within_3_sigma(fit["until"]);
    // Every batch after the first was chosen from a fit.
    const nlohmann::json& batches = fit["fit_plan"]["batches"];
    ASSERT_FALSE(batches.empty());
    for (const auto& b : batches.items()) {
        EXPECT_TRUE(b.value()["fitted"].get<bool>()) << b.value().dump();
        EXPECT_GT(b.value()["by_variance"].get<int>(), 0) << b.value().dump();
        EXPECT_GT(b.value()["by_space"].get<int>(), 0) << b.value().dump();
    }
}

TEST(AcquirePlanFit, MeasuredRglMaterialRunsAndEndsSayingWhy) {
    const std::string rgl =
        std::string(GONIO_SOURCE_DIR) + "/../shared/data/rgl/satin_rosaline_rgb.bsdf";
    if (!std::filesystem::exists(rgl)) {
        GTEST_SKIP() << rgl << " is not beside the source tree";
    }
    const std::string dir = gonio::testing::test_folder("test_tools_plan_fit", "rgl", false);
    int st = 0;
    const std::string out = run_gonio("acquire --brdf " + rgl + " --out " + dir +
                                          " --plan fit --time-scale 1000 --until sigma=0.01",
                                      &st);
    ASSERT_EQ(st, 0) << out;
    const bool reached = out.find("stopped: target reached") != std::string::npos;
    const bool said = out.find("target never reached, the plan ended") != std::string::npos;
    EXPECT_TRUE(reached || said) << out;
    const nlohmann::json meta = metadata(dir);
    ASSERT_TRUE(meta.is_object());
    EXPECT_GT(meta["measured"].get<int>(), 16);
    // The satin misfits the default model: some batch measured where it does.
    int misfit = 0;
    for (const auto& b : meta["fit_plan"]["batches"].items()) {
        misfit += b.value()["by_misfit"].get<int>();
    }
    EXPECT_GT(misfit, 0) << meta["fit_plan"].dump();
}

TEST(AcquirePlanFit, KilledInABatchAndResumedMeasuresThatBatchExactly) {
    const std::string dir = gonio::testing::test_folder("test_tools_plan_fit", "kill9", false);
    const std::string truth = truth_file(dir);
    std::vector<std::string> words = {GONIO_EXE,
                                      "acquire",
                                      "--brdf",
                                      truth,
                                      "--out",
                                      dir,
                                      "--plan",
                                      "fit",
                                      "--time-scale",
                                      "200"};
    const pid_t pid = gonio::testing::spawn_quietly(words);
    ASSERT_GT(pid, 0);
    // Killed once the third batch (pass 2) has its first measurements in the journal.
    bool inside = false;
    for (int k = 0; k < 60000 && !inside; ++k) {  // at most two minutes
        int in_pass_2 = 0;
        for (const auto& m : journal_measurements(dir)) {
            in_pass_2 += m.first == 2;
        }
        inside = in_pass_2 >= 2;
        if (!inside) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    }
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(inside) << "the third batch did not start within two minutes";
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    const auto before = journal_measurements(dir);
    int st = 0;
    const std::string out = run_gonio("acquire --resume " + dir, &st);
    ASSERT_EQ(st, 0) << out;
    const auto after = journal_measurements(dir);
    // Nothing measured before the kill is lost or measured again.
    ASSERT_GE(after.size(), before.size());
    for (std::size_t k = 0; k < before.size(); ++k) {
        EXPECT_EQ(after[k], before[k]);
    }
    std::set<std::pair<int, int>> unique(after.begin(), after.end());
    EXPECT_EQ(unique.size(), after.size()) << "a configuration measured twice";
    // The resumed run rebuilt the batch it was in: every pass holds exactly its batch (16 in the
    // first, 8 in every later one, the budget of 120 reached) and no pool configuration twice.
    std::map<int, int> per_pass;
    std::set<int> pool;
    for (const auto& m : after) {
        ++per_pass[m.first];
        EXPECT_TRUE(pool.insert(m.second).second) << "pool configuration " << m.second;
    }
    EXPECT_EQ(after.size(), 120u);
    for (const auto& [pass, n] : per_pass) {
        EXPECT_EQ(n, pass == 0 ? 16 : 8) << "pass " << pass;
    }
    const nlohmann::json meta = metadata(dir);
    ASSERT_EQ(meta["runs"].size(), 2u);
    EXPECT_EQ(meta["runs"][0]["state"], "killed");
    EXPECT_EQ(meta["runs"][1]["stopped"], "plan end");
}

}  // namespace
}  // namespace plan_fit_test
