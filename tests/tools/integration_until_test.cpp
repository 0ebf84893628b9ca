// `gonio acquire --until`: a point campaign on the virtual rig (reference error budget) that fits
// between batches and stops when its fit is known; killed with SIGKILL and resumed, it keeps its
// rule; a target out of reach ends at the plan's end and says so; modes that cannot honour the
// rule refuse it with exit status 2.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <thread>

#include "cli_run.h"

extern char** environ;

namespace {

using gonio::testing::read_text;
using gonio::testing::run_gonio;

const char* kTruth = R"({"diffuse": [0.1, 0.1, 0.1], "lobes": [{"distribution": "ggx",
    "alpha": 0.2, "shadowing": "smith-correlated",
    "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

/// The truth of each parameter the default fit frees.
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

struct UntilCampaign {
    std::string dir;
    std::string truth;
    std::string args;
};

UntilCampaign make(const std::string& name, const std::string& until) {
    UntilCampaign c;
    c.dir = gonio::testing::test_folder("test_tools_until", name, false);
    c.truth = c.dir + "_truth.json";
    std::ofstream(c.truth) << kTruth;
    c.args = "acquire --brdf " + c.truth + " --out " + c.dir +
             " --n-theta 8 --n-dphi 6 --adaptive 0 --time-scale 500 --until " + until;
    return c;
}

nlohmann::json metadata(const std::string& dir) {
    const std::string text = read_text(dir + "/metadata.json");
    return text.empty() ? nlohmann::json() : nlohmann::json::parse(text, nullptr, false);
}

/// Every parameter of the check within the target and within 3 sigma of the truth.
void expect_known(const nlohmann::json& until, double target) {
    const std::string params = until["parameters"].get<std::string>();
    const std::regex item(R"(([^;\s]+) ([-+0-9.eE]+) \+- ([-+0-9.eE]+))");
    int n = 0;
    for (auto it = std::sregex_iterator(params.begin(), params.end(), item);
         it != std::sregex_iterator();
         ++it, ++n) {
        const std::string name = (*it)[1];
        const double value = std::stod((*it)[2]);
        const double sigma = std::stod((*it)[3]);
        EXPECT_LE(sigma / std::abs(value), target) << name << " in " << params;
        EXPECT_LE(std::abs(value - truth_of(name)), 3 * sigma) << name << " in " << params;
    }
    EXPECT_EQ(n, 8) << params;  // diffuse x3, alpha, f0, scale x3
}

TEST(AcquireUntil, StopsWhenTheFitIsKnownBeforeThePlansEnd) {
    const UntilCampaign c = make("known", "sigma=0.01");
    int st = 0;
    const std::string out = run_gonio(c.args, &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("target reached: target held at"), std::string::npos) << out;
    EXPECT_NE(out.find("stopped: target reached"), std::string::npos) << out;
    const nlohmann::json meta = metadata(c.dir);
    ASSERT_TRUE(meta.is_object());
    EXPECT_EQ(meta["runs"].back()["stopped"], "target reached");
    const nlohmann::json& until = meta["until"];
    EXPECT_TRUE(until["held"].get<bool>());
    EXPECT_EQ(until["rule"], "sigma=0.01,holdout=2");
    EXPECT_LT(until["measurements"].get<int>(), until["planned"].get<int>());
    EXPECT_LT(meta["measured"].get<int>(), meta["planned"].get<int>());
    EXPECT_LE(until["holdout_rms_z"].get<double>(), 2);
    EXPECT_GT(until["rig_time_s"].get<double>(), 0);
    expect_known(until, 0.01);
}

TEST(AcquireUntil, KilledAndResumedKeepsTheStopRule) {
    const UntilCampaign c = make("kill9", "sigma=0.01");
    // The campaign in a child process, killed with SIGKILL once its first check (not yet held) is
    // in metadata.json.
    std::vector<std::string> words = {GONIO_EXE};
    {
        std::istringstream ss(c.args);
        for (std::string w; ss >> w;) {
            words.push_back(w);
        }
    }
    const pid_t pid = gonio::testing::spawn_quietly(words);
    ASSERT_GT(pid, 0);
    bool checked = false;
    for (int k = 0; k < 12000 && !checked; ++k) {  // polls the folder, at most two minutes
        const nlohmann::json m = metadata(c.dir);
        checked = m.is_object() && m.contains("until");
        if (!checked) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
    }
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(checked) << "no check within two minutes";
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    const nlohmann::json killed = metadata(c.dir);
    ASSERT_FALSE(killed["until"]["held"].get<bool>()) << killed["until"].dump();
    // The resume reads the rule from the folder and stops by it.
    int st = 0;
    const std::string out = run_gonio("acquire --resume " + c.dir, &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("until sigma=0.01,holdout=2"), std::string::npos) << out;
    EXPECT_NE(out.find("stopped: target reached"), std::string::npos) << out;
    const nlohmann::json meta = metadata(c.dir);
    ASSERT_EQ(meta["runs"].size(), 2u) << meta["runs"].dump();
    EXPECT_EQ(meta["runs"][0]["state"], "killed");
    EXPECT_EQ(meta["runs"][1]["stopped"], "target reached");
    EXPECT_TRUE(meta["until"]["held"].get<bool>());
    EXPECT_LT(meta["measured"].get<int>(), meta["planned"].get<int>());
    // Rig time counts the killed run as of its last record.
    EXPECT_GT(meta["rig_time_s"].get<double>(), meta["runs"][1]["rig_time_s"].get<double>());
    expect_known(meta["until"], 0.01);
}

TEST(AcquireUntil, TargetOutOfReachEndsAtThePlansEndSayingSo) {
    UntilCampaign c = make("never", "sigma=1e-6,every=20");
    c.args = "acquire --brdf " + c.truth + " --out " + c.dir +
             " --n-theta 4 --n-dphi 3 --adaptive 0 --time-scale 500 --until sigma=1e-6,every=20";
    int st = 0;
    const std::string out = run_gonio(c.args, &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("target never reached, the plan ended"), std::string::npos) << out;
    EXPECT_NE(out.find("stopped: plan end"), std::string::npos) << out;
    const nlohmann::json meta = metadata(c.dir);
    EXPECT_EQ(meta["runs"].back()["stopped"], "plan end");
    EXPECT_FALSE(meta["until"]["held"].get<bool>());
    EXPECT_EQ(meta["until"]["message"].get<std::string>().rfind("target never reached", 0), 0u)
        << meta["until"].dump();
    EXPECT_EQ(meta["measured"], meta["planned"]);
}

TEST(AcquireUntil, BadRulesAndModesThatCannotHonourItAreRefused) {
    for (const char* args : {"acquire --until sigma=0",
                             "acquire --until sigma=0.01,holdot=2",
                             "acquire --until holdout=2",
                             "acquire --mode image --until sigma=0.01",
                             "acquire --plan vndf --until sigma=0.01"}) {
        int st = 0;
        const std::string out = run_gonio(args, &st);
        EXPECT_EQ(st, 2) << args << "\n" << out;
        EXPECT_NE(out.find("until"), std::string::npos) << args << "\n" << out;
    }
}

}  // namespace
