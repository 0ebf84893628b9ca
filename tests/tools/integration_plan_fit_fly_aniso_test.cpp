// `gonio acquire --plan fit --fly --anisotropic` on the virtual rig (monochrome sim4, reference
// error budget): on the brushed GGX truth (alpha_x 0.1, alpha_y 0.3, turned 30 deg; the rig-time
// benchmark's "brushed") with --until sigma=0.02 each batch is chosen as sweeps at the spins of
// the anisotropic pool, and the campaign stops on its rule with alpha_x, alpha_y and the
// orientation within 3 sigma of the truth and within a capped tolerance, in less rig time
// (metadata.json rig_time_s) than `--plan fit --anisotropic` stop-and-go on the same truth; killed
// with SIGKILL while a sweep of a fit-chosen batch runs and resumed, the campaign keeps its stop
// rule and stops on it, no value is lost or measured twice and that sweep's configurations are
// measured after the resume (unless the rule holds inside that batch, which then is the last).

#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "plan_fit_support.h"

namespace plan_fit_fly_aniso_test {
namespace {

using gonio::testing::run_gonio;
using namespace gonio::testing::plan_fit;

const char* kBrushed = R"({"diffuse": [0.05, 0.05, 0.05], "lobes": [{"distribution": "ggx",
    "alpha_x": 0.1, "alpha_y": 0.3, "orientation_deg": 30, "shadowing": "smith-correlated",
    "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

/// The largest error allowed of a recovered slope (relative) and of the orientation (degrees),
/// whatever the sigma: the fit's sigma leaves out the rig's shared offsets.
constexpr double kSlopeCap = 0.02;
constexpr double kOrientationCapDeg = 1.0;

std::string brushed_truth(const std::string& dir) {
    return write_truth(dir, kBrushed);
}

/// The recovered slopes and orientation against the truth: within 3 sigma and within the caps.
void expect_brushed_truth(const nlohmann::json& until) {
    const std::map<std::string, double> truth = {
        {"lobes[0].alpha_x", 0.1}, {"lobes[0].alpha_y", 0.3}, {"lobes[0].orientation_deg", 30.0}};
    for (const auto& [name, t] : truth) {
        const Estimate e = estimate_of(until, name);
        const double cap =
            name.find("orientation") != std::string::npos ? kOrientationCapDeg : kSlopeCap * t;
        std::printf("  %s %.6g +- %.2g (truth %g)\n", name.c_str(), e.value, e.sigma, t);
        EXPECT_LE(std::abs(e.value - t), 3 * e.sigma) << name;
        EXPECT_LE(std::abs(e.value - t), cap) << name;
    }
}

/// The spins (degrees, rounded, folded into [0, 360)) the sweeps of the batches after the first
/// stood at.
std::set<long> fit_sweep_spins(const std::vector<JournalLine>& lines) {
    std::set<long> out;
    for (const JournalLine& l : lines) {
        if (l.type == "sweep" && l.pass >= 1) {
            out.insert((std::lround(l.spin_deg) % 360 + 360) % 360);
        }
    }
    return out;
}

// The fly run's triggers are polled in real time: at a time scale of 2 a loaded machine still
// sees the arm pass each trigger position, so few frames fall back to standing.
TEST(AcquirePlanFitFlyAniso, RecoversTheBrushedTruthInLessRigTimeThanStopAndGo) {
    const std::string fly_dir =
        gonio::testing::test_folder("test_tools_plan_fit_fly_aniso", "fly", false);
    const std::string still_dir =
        gonio::testing::test_folder("test_tools_plan_fit_fly_aniso", "still", false);
    const std::string truth = brushed_truth(fly_dir);
    int st = 0;
    const std::string out =
        run_gonio("acquire --plan fit --fly --anisotropic --rig " + mono_rig_path() + " --brdf " +
                      truth + " --out " + fly_dir + " --time-scale 2 --until sigma=0.02",
                  &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("stopped: target reached"), std::string::npos) << out;
    const nlohmann::json fly = read_json(fly_dir + "/metadata.json");
    ASSERT_TRUE(fly["until"]["held"].get<bool>()) << fly["until"].dump();
    EXPECT_LT(fly["measured"].get<int>(), 120) << "the plan's budget";
    EXPECT_GT(fly["runs"][0]["fly"]["swept"].get<int>(),
              3 * fly["runs"][0]["fly"]["standing"].get<int>())
        << fly["runs"][0]["fly"].dump();
    for (const auto& b : fly["fit_plan"]["batches"].items()) {
        EXPECT_TRUE(b.value()["fitted"].get<bool>()) << b.value().dump();
        EXPECT_GT(b.value()["sweeps"].get<int>(), 0) << b.value().dump();
    }
    // The sample was turned between the fit's sweeps: its azimuth is measured, not assumed.
    EXPECT_GE(fit_sweep_spins(lines_of(fly_dir)).size(), 2u);
    std::printf("fit plan, fly, anisotropic: %d values, rig time %.1f s\n",
                fly["measured"].get<int>(),
                fly["rig_time_s"].get<double>());
    expect_brushed_truth(fly["until"]);

    const std::string still =
        run_gonio("acquire --plan fit --anisotropic --rig " + mono_rig_path() + " --brdf " + truth +
                      " --out " + still_dir + " --time-scale 500 --until sigma=0.02",
                  &st);
    ASSERT_EQ(st, 0) << still;
    const nlohmann::json stop_go = read_json(still_dir + "/metadata.json");
    ASSERT_TRUE(stop_go["until"]["held"].get<bool>()) << stop_go["until"].dump();
    std::printf("fit plan, stop-and-go, anisotropic: %d values, rig time %.1f s\n",
                stop_go["measured"].get<int>(),
                stop_go["rig_time_s"].get<double>());
    expect_brushed_truth(stop_go["until"]);
    EXPECT_LT(fly["rig_time_s"].get<double>(), stop_go["rig_time_s"].get<double>());
}

/// Spawns the fly campaign and kills it with SIGKILL while a sweep of a batch chosen from the fit
/// runs (its start the journal's last line); false when none came within three minutes.
bool kill_inside_fit_sweep(const std::string& dir, const std::string& truth) {
    const std::vector<std::string> words = {GONIO_EXE,
                                            "acquire",
                                            "--plan",
                                            "fit",
                                            "--fly",
                                            "--anisotropic",
                                            "--rig",
                                            mono_rig_path(),
                                            "--brdf",
                                            truth,
                                            "--out",
                                            dir,
                                            "--time-scale",
                                            "5",
                                            "--until",
                                            "sigma=0.02"};
    return kill_inside_sweep(words, dir, 1);
}

TEST(AcquirePlanFitFlyAniso, KilledMidSweepResumesToItsStopRuleLosingAndRepeatingNothing) {
    const std::string dir =
        gonio::testing::test_folder("test_tools_plan_fit_fly_aniso", "kill9", false);
    const std::string truth = brushed_truth(dir);
    ASSERT_TRUE(kill_inside_fit_sweep(dir, truth)) << "no sweep of a fit-chosen batch";
    const std::vector<JournalLine> killed = lines_of(dir);
    const auto before = measured_of(killed);
    std::vector<std::pair<int, int>> after;
    ASSERT_NO_FATAL_FAILURE(resume_keeping(dir, before, &after));
    // The interrupted sweep's configurations: none measured before the kill; after it each
    // measured once, unless the rule held inside that batch (no later batch was chosen).
    const nlohmann::json meta = read_json(dir + "/metadata.json");
    const JournalLine& sweep = killed.back();
    std::istringstream members(sweep.text.substr(sweep.text.find(':') + 1));
    const std::set<std::pair<int, int>> done_before(before.begin(), before.end());
    const std::set<std::pair<int, int>> done_after(after.begin(), after.end());
    std::size_t n = 0, measured = 0;
    for (int index = 0; members >> index; ++n) {
        EXPECT_EQ(done_before.count({sweep.pass, index}), 0u) << index;
        measured += done_after.count({sweep.pass, index});
    }
    EXPECT_GE(n, 2u) << sweep.text;
    const bool later_batch = meta["fit_plan"]["batches"].contains(std::to_string(sweep.pass + 1));
    if (measured < n) {
        EXPECT_FALSE(later_batch) << "the interrupted sweep was dropped: " << sweep.text;
    }
    std::printf(
        "killed at %zu values in batch %d; resumed to %zu values, %zu of the sweep's %zu%s\n",
        before.size(),
        sweep.pass,
        after.size(),
        measured,
        n,
        later_batch ? "" : " (the rule held inside that batch)");
    // The resumed run kept the rule and stopped on it, before the budget, on the truth.
    ASSERT_EQ(meta["runs"].size(), 2u);
    EXPECT_EQ(meta["runs"][0]["state"], "killed");
    EXPECT_EQ(meta["runs"][1]["stopped"], "target reached") << meta["runs"].dump();
    EXPECT_NE(meta["until"]["rule"].get<std::string>().find("sigma=0.02"), std::string::npos);
    ASSERT_TRUE(meta["until"]["held"].get<bool>()) << meta["until"].dump();
    EXPECT_EQ(meta["until"]["measurements"].get<std::size_t>(), after.size());
    EXPECT_LT(after.size(), 120u) << "the budget";
    expect_brushed_truth(meta["until"]);
}

}  // namespace
}  // namespace plan_fit_fly_aniso_test
