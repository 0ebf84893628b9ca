// `gonio acquire --plan fit --fly` on the virtual rig (monochrome sim4, reference error budget):
// on a GGX alpha 0.05 truth with --until sigma=0.01 each batch is chosen as sweeps, the campaign
// stops on its rule before the plan's budget with alpha within 3 sigma of the truth, in less rig
// time (metadata.json rig_time_s, simulated rig seconds) than `--plan fit` stop-and-go on the same
// truth; killed with SIGKILL while a sweep of a fit-chosen batch runs and resumed, no value is
// lost or measured twice and that sweep's configurations are measured after the resume.

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "plan_fit_support.h"

extern char** environ;

namespace plan_fit_fly_test {
namespace {

using gonio::testing::run_gonio;
using namespace gonio::testing::plan_fit;

const char* kGgx005 = R"({"diffuse": [0.02, 0.02, 0.02], "lobes": [{"distribution": "ggx",
    "alpha": 0.05, "shadowing": "smith-correlated",
    "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

std::string ggx_truth(const std::string& dir) {
    return write_truth(dir, kGgx005);
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
    const auto [alpha, sigma] = estimate_of(fly["until"], "lobes[0].alpha_x");
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
    const std::vector<std::string> words = {GONIO_EXE,
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
    // Killed while a sweep of a batch chosen from the fit (pass 2 or later) runs.
    ASSERT_TRUE(kill_inside_sweep(words, dir, 2))
        << "no sweep of the third batch within three minutes";
    const std::vector<JournalLine> killed = lines_of(dir);
    const auto before = measured_of(killed);
    std::vector<std::pair<int, int>> after;
    ASSERT_NO_FATAL_FAILURE(resume_keeping(dir, before, &after));
    const std::set<std::pair<int, int>> unique(after.begin(), after.end());
    EXPECT_EQ(unique.size(), after.size()) << "a configuration measured twice";
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
