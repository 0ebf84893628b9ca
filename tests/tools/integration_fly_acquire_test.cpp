// `gonio acquire --fly` on the virtual rig (monochrome sim4, drives with touch probes): on a GGX
// alpha 0.05 truth `gonio fit` of the fly dataset (exposure-path columns, so the fit models each
// value as the mean over its path) recovers alpha within 3 sigma and 2 %; with --until the
// campaign stops on its rule; killed with SIGKILL in the middle of a sweep and resumed (on the
// monochrome rig and behind sim4's colour filter changer, a sweep per filter), no value is lost or
// measured twice and the interrupted sweep is run again; the options it cannot go with are refused
// with exit status 2, naming them.

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
#include <set>
#include <thread>

#include "cli_run.h"

extern char** environ;

namespace {

using gonio::testing::read_text;
using gonio::testing::run_gonio;

const char* kTruth = R"({"diffuse": [0.02, 0.02, 0.02], "lobes": [{"distribution": "ggx",
    "alpha": 0.05, "shadowing": "smith-correlated",
    "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

std::string mono_rig() {
    return std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4-mono.json";
}

/// sim4-mono whose error budget keeps the reference lamp's fluctuation (0.15 % per exposure) and
/// no systematic term (arm offsets and tilts, drift, stray light, non-linearity), written beside
/// `dir`: the fit's sigmas then cover its values; the drives' step (1e-3 deg) stays far below them.
std::string quiet_mono_rig(const std::string& dir) {
    nlohmann::json j = nlohmann::json::parse(read_text(mono_rig()));
    j["error_budget"] = {{"profile", "quiet"}, {"lamp", {{"fluctuation", 0.0015}}}};
    const std::string p = dir + "_rig.json";
    std::ofstream(p) << j.dump(2);
    return p;
}

std::string truth_file(const std::string& dir) {
    const std::string p = dir + "_truth.json";
    std::ofstream(p) << kTruth;
    return p;
}

nlohmann::json json_file(const std::string& path) {
    const std::string text = read_text(path);
    return text.empty() ? nlohmann::json() : nlohmann::json::parse(text, nullptr, false);
}

/// One journal line's type, (pass, index).
struct Line {
    std::string type;
    int pass = 0;
    int index = 0;
};

std::vector<Line> journal_lines(const std::string& dir) {
    std::vector<Line> out;
    std::istringstream in(read_text(dir + "/journal.log"));
    for (std::string line; std::getline(in, line);) {
        const auto j = nlohmann::json::parse(line.substr(0, line.find('\t')), nullptr, false);
        if (j.is_object()) {
            out.push_back({j.value("type", ""), j.value("pass", 0), j.value("index", 0)});
        }
    }
    return out;
}

std::vector<std::pair<int, int>> measurements(const std::vector<Line>& lines) {
    std::vector<std::pair<int, int>> out;
    for (const Line& l : lines) {
        if (l.type == "measurement") {
            out.push_back({l.pass, l.index});
        }
    }
    return out;
}

TEST(AcquireFly, FitOfTheFlyDatasetRecoversGgxAlpha) {
    const std::string dir = gonio::testing::test_folder("test_tools_fly", "fit", false);
    const std::string truth = truth_file(dir);
    int st = 0;
    const std::string out =
        run_gonio("acquire --fly --rig " + quiet_mono_rig(dir) + " --brdf " + truth + " --out " +
                      dir + " --n-theta 16 --n-dphi 2 --adaptive 0 --time-scale 5",
                  &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("sweeps through"), std::string::npos) << out;
    const nlohmann::json meta = json_file(dir + "/metadata.json");
    const nlohmann::json& fly = meta["runs"][0]["fly"];
    EXPECT_GT(fly["swept"].get<int>(), 2 * fly["standing"].get<int>()) << fly.dump();
    const std::string header = read_text(dir + "/dataset.csv").substr(0, 400);
    EXPECT_NE(header.find("theta_o_start"), std::string::npos) << header;
    const std::string fit =
        run_gonio("fit " + dir + "/dataset.csv --model ggx --out " + dir + "/fit.json", &st);
    ASSERT_EQ(st, 0) << fit;
    const nlohmann::json rep = json_file(dir + "/fit.report.json");
    double alpha = NAN, sigma = NAN;
    for (const auto& p : rep.at("parameters")) {
        if (p.at("name") == "lobes[0].alpha_x") {
            alpha = p.at("value").get<double>();
            sigma = p.at("sigma").get<double>();
        }
    }
    std::printf("fly fit: alpha %.6g +- %.3g (truth 0.05)\n", alpha, sigma);
    EXPECT_LE(std::abs(alpha - 0.05), 3 * sigma) << fit;
    EXPECT_LE(std::abs(alpha - 0.05), 0.02 * 0.05) << fit;
}

TEST(AcquireFly, StopsOnItsRule) {
    const std::string dir = gonio::testing::test_folder("test_tools_fly", "until", false);
    const std::string truth = truth_file(dir);
    int st = 0;
    const std::string out =
        run_gonio("acquire --fly --rig " + mono_rig() + " --brdf " + truth + " --out " + dir +
                      " --n-theta 16 --n-dphi 2 --adaptive 0 --time-scale 5 --until sigma=0.05",
                  &st);
    ASSERT_EQ(st, 0) << out;
    const nlohmann::json meta = json_file(dir + "/metadata.json");
    ASSERT_TRUE(meta["until"].is_object()) << meta.dump();
    EXPECT_TRUE(meta["until"]["held"].get<bool>()) << meta["until"].dump();
    EXPECT_EQ(meta["runs"][0]["stopped"], "target reached");
    EXPECT_LT(meta["measured"].get<int>(), meta["planned"].get<int>());
    EXPECT_GT(meta["runs"][0]["fly"]["swept"].get<int>(), 0);
}

/// `gonio acquire --fly` on `rig` killed with SIGKILL while a sweep runs (after the values of
/// `sweeps_before` earlier sweeps) and resumed: no value lost or measured twice, the interrupted
/// sweep's configurations measured after the resume. Returns the resumed run's metadata.
nlohmann::json kill_mid_sweep_and_resume(const std::string& dir,
                                         const std::string& rig,
                                         int sweeps_before) {
    const std::string truth = truth_file(dir);
    std::vector<std::string> words = {GONIO_EXE,
                                      "acquire",
                                      "--fly",
                                      "--rig",
                                      rig,
                                      "--brdf",
                                      truth,
                                      "--out",
                                      dir,
                                      "--n-theta",
                                      "10",
                                      "--n-dphi",
                                      "2",
                                      "--adaptive",
                                      "0",
                                      "--time-scale",
                                      "5"};
    const pid_t pid = gonio::testing::spawn_quietly(words);
    EXPECT_GT(pid, 0);
    if (pid <= 0) {
        return {};
    }
    // Killed while a sweep runs: its start is the journal's last line, after values of an
    // earlier sweep (its own values are written once it ends).
    bool inside = false;
    for (int k = 0; k < 60000 && !inside; ++k) {  // at most two minutes
        const std::vector<Line> lines = journal_lines(dir);
        int sweeps = 0;
        for (const Line& l : lines) {
            sweeps += l.type == "sweep";
        }
        inside = sweeps >= sweeps_before + 1 && lines.back().type == "sweep";
        if (!inside) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    }
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    EXPECT_TRUE(inside) << "no sweep after " << sweeps_before << " within two minutes";
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    if (!inside) {
        return {};
    }
    const std::vector<Line> killed = journal_lines(dir);
    const auto before = measurements(killed);
    int st = 0;
    const std::string out = run_gonio("acquire --resume " + dir, &st);
    EXPECT_EQ(st, 0) << out;
    const std::vector<Line> resumed = journal_lines(dir);
    const auto after = measurements(resumed);
    EXPECT_GE(after.size(), before.size());
    for (std::size_t k = 0; k < std::min(before.size(), after.size()); ++k) {
        EXPECT_EQ(after[k], before[k]);
    }
    std::set<std::pair<int, int>> unique(after.begin(), after.end());
    EXPECT_EQ(unique.size(), after.size()) << "a configuration measured twice";
    const nlohmann::json meta = json_file(dir + "/metadata.json");
    EXPECT_EQ(static_cast<int>(after.size()), meta["planned"].get<int>());
    EXPECT_EQ(meta["runs"].size(), 2u);
    EXPECT_EQ(meta["runs"][0]["state"], "killed");
    EXPECT_EQ(meta["runs"][meta["runs"].size() - 1]["stopped"], "plan end");
    // The interrupted sweep's configurations (listed in its journal line) were measured after the
    // resume, none before.
    std::string last_sweep;
    std::istringstream in(read_text(dir + "/journal.log"));
    std::size_t line_no = 0;
    for (std::string line; std::getline(in, line) && line_no < killed.size(); ++line_no) {
        const auto j = nlohmann::json::parse(line.substr(0, line.find('\t')), nullptr, false);
        if (j.is_object() && j.value("type", "") == "sweep") {
            last_sweep = j.value("text", "");
        }
    }
    std::istringstream members(last_sweep.substr(last_sweep.find(':') + 1));
    const std::set<std::pair<int, int>> done_before(before.begin(), before.end());
    int n = 0;
    for (int index = 0; members >> index; ++n) {
        EXPECT_EQ(done_before.count({killed.back().pass, index}), 0u) << index;
        EXPECT_EQ(unique.count({killed.back().pass, index}), 1u) << index;
    }
    EXPECT_GE(n, 2) << last_sweep;
    return meta;
}

TEST(AcquireFly, KilledMidSweepAndResumedLosesAndRepeatsNothing) {
    kill_mid_sweep_and_resume(
        gonio::testing::test_folder("test_tools_fly", "kill9", false), mono_rig(), 2);
}

// Behind the colour filter changer (sim4: red, green and blue on one wheel) each sweep runs once
// per filter; killed during the second sweep's filters and resumed, nothing is lost or repeated.
TEST(AcquireFly, ColourFilterSweepsKilledAndResumedLoseAndRepeatNothing) {
    const std::string rig = std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json";
    const nlohmann::json meta = kill_mid_sweep_and_resume(
        gonio::testing::test_folder("test_tools_fly", "kill9_colour", false), rig, 1);
    ASSERT_TRUE(meta.is_object());
    EXPECT_EQ(meta["calibration"]["colour"], "filter_wheel") << meta["calibration"].dump();
    EXPECT_GT(meta["runs"][1]["fly"]["swept"].get<int>(), 0) << meta["runs"][1].dump();
}

TEST(AcquireFly, RefusesWhatItCannotHonourWithExitStatus2) {
    const std::string dir = gonio::testing::test_folder("test_tools_fly", "refuse", false);
    int st = 0;
    std::string out = run_gonio("acquire --fly --mode image --out " + dir, &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--fly"), std::string::npos) << out;
    // A colour filter changer on a rig whose arms trigger by polling.
    nlohmann::json polled =
        nlohmann::json::parse(read_text(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json"));
    polled["axes"][1]["position_compare"] = false;
    const std::string polled_rig = dir + "_polled.json";
    std::ofstream(polled_rig) << polled.dump(2);
    out = run_gonio("acquire --fly --rig " + polled_rig + " --out " + dir, &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("filter_wheel"), std::string::npos) << out;
    EXPECT_NE(out.find("position_compare"), std::string::npos) << out;
    // An arm that claims a position compare its drive's register map lacks.
    nlohmann::json claims = nlohmann::json::parse(read_text(mono_rig()));
    claims["axes"][0]["profile"] = "oriental-az";
    const std::string claims_rig = dir + "_claims.json";
    std::ofstream(claims_rig) << claims.dump(2);
    out = run_gonio("acquire --fly --rig " + claims_rig + " --out " + dir, &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("position_compare"), std::string::npos) << out;
    out = run_gonio("acquire --fly --plan-only --rig " + mono_rig(), &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--plan-only"), std::string::npos) << out;
    out = run_gonio("acquire --fly-smear 2 --rig " + mono_rig() + " --out " + dir, &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--fly-smear"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(dir)) << "a refused campaign left its folder";
}

}  // namespace
