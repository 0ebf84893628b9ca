// gonio acquire and gonio sim end to end through the binary: a campaign on the embedded virtual
// rig, its resume, the plan listing, errors; a campaign run against a separate `gonio sim` process
// (its camera a GigE Vision device).

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "gonio/brdf/dataset.h"

namespace {

namespace fs = std::filesystem;

using gonio::testing::run_gonio;

std::string acquire_dir(const std::string& name) {
    return gonio::testing::test_folder("test_tools_acquire", name, false);
}

TEST(AcquireCli, EmbeddedCampaignThenResumeMeasuresNothingTwice) {
    const std::string dir = acquire_dir("embedded");
    int st = 0;
    const std::string out = run_gonio(
        "acquire --out " + dir + " --n-theta 4 --n-dphi 3 --adaptive 0 --time-scale 500", &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("completed"), std::string::npos) << out;
    EXPECT_NE(out.find("raster order"), std::string::npos) << out;
    auto ds = gonio::brdf::read_dataset_csv(dir + "/dataset.csv");
    ASSERT_TRUE(ds) << ds.error().message;
    EXPECT_TRUE(ds->rejected.empty());
    // 4 x 3 grid: 4 at theta_i = 0, (3 + 2 + 1) x 3 = 18 more, less 4 retro-reflections.
    std::size_t brdf_samples = 0;
    for (const auto& s : ds->samples) {
        brdf_samples += (s.flags & gonio::brdf::kFlagReference) ? 0 : 1;
    }
    EXPECT_EQ(brdf_samples, 18u);
    const std::string again = run_gonio("acquire --resume " + dir, &st);
    ASSERT_EQ(st, 0) << again;
    auto ds2 = gonio::brdf::read_dataset_csv(dir + "/dataset.csv");
    ASSERT_TRUE(ds2);
    std::size_t brdf_samples2 = 0;
    for (const auto& s : ds2->samples) {
        brdf_samples2 += (s.flags & gonio::brdf::kFlagReference) ? 0 : 1;
    }
    EXPECT_EQ(brdf_samples2, 18u);
    std::ifstream meta(dir + "/metadata.json");
    std::stringstream ss;
    ss << meta.rdbuf();
    EXPECT_NE(ss.str().find("\"software\""), std::string::npos);
    EXPECT_NE(ss.str().find("\"unreachable\""), std::string::npos);
}

double param(const std::string& out, const std::string& name) {
    const auto at = out.find(name);
    if (at == std::string::npos) {
        return -1;
    }
    return std::stod(out.substr(at + name.size()));
}

TEST(AcquireCli, AcquireThenFitRecoversTheGroundTruth) {
    // GGX + Lambert ground truth, acquired on the virtual rig, fitted with the same model family.
    const std::string dir = acquire_dir("fit");
    const std::string model = dir + "_model.json";
    std::ofstream(model) << R"({"diffuse": [0.3, 0.3, 0.3], "lobes": [{"distribution": "ggx",
        "alpha": 0.25, "shadowing": "smith-correlated",
        "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";
    int st = 0;
    const std::string acq = run_gonio("acquire --brdf " + model + " --out " + dir +
                                          " --n-theta 6 --n-dphi 5 --adaptive 0 --time-scale 500",
                                      &st);
    ASSERT_EQ(st, 0) << acq;
    const std::string fit = run_gonio("fit " + dir + "/dataset.csv --model ggx", &st);
    ASSERT_EQ(st, 0) << fit;
    // The measurement noise is about 1e-5 relative (the fit reports ~2e-6 standard errors); 1e-3
    // leaves room for the stages' step quantisation.
    EXPECT_NEAR(param(fit, "diffuse[0]"), 0.3, 1e-3) << fit;
    EXPECT_NEAR(param(fit, "lobes[0].alpha_x"), 0.25, 1e-3) << fit;
    // The default model has one f0 for the three channels (the colour is in the scale).
    EXPECT_NEAR(param(fit, "lobes[0].fresnel.f0 "), 0.04, 1e-3) << fit;
}

TEST(AcquireCli, PlanOnlyListsUnreachableTargetsWithReasons) {
    int st = 0;
    const std::string out = run_gonio("acquire --plan-only --n-theta 4 --n-dphi 3", &st);
    ASSERT_EQ(st, 0) << out;
    EXPECT_NE(out.find("18 configurations, 4 unreachable"), std::string::npos) << out;
    EXPECT_NE(out.find("blind zone"), std::string::npos) << out;
}

TEST(AcquireCli, ErrorsNameTheProblem) {
    int st = 0;
    // Inputs named on the command line that do not exist: usage errors (exit 2), before any work.
    const std::string out = run_gonio("acquire --rig /nonexistent/rig.json --out x", &st);
    EXPECT_EQ(st, 2);
    EXPECT_NE(out.find("/nonexistent/rig.json"), std::string::npos) << out;
    const std::string out2 = run_gonio("acquire --resume /nonexistent/campaign", &st);
    EXPECT_EQ(st, 2);
    EXPECT_NE(out2.find("/nonexistent/campaign"), std::string::npos) << out2;
}

// The separate `gonio sim` serves its camera as a GigE Vision device on port 3956 of a loopback
// address of its own (--camera-ip auto), opened by gonio's Aravis camera: the whole point-mode
// campaign goes through GVCP/GVSP.
TEST(AcquireCli, CampaignAgainstASeparateSimProcess) {
    const std::string dir = acquire_dir("separate");
    fs::create_directories(dir);
    const std::string live = dir + "/live-rig.json";
    int pipefd[2];
    ASSERT_EQ(pipe(pipefd), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        dup2(pipefd[1], 1);
        close(pipefd[0]);
        execl(GONIO_EXE,
              GONIO_EXE,
              "sim",
              "--rig-out",
              live.c_str(),
              "--time-scale",
              "500",
              "--camera-ip",
              "auto",
              static_cast<char*>(nullptr));
        _exit(127);
    }
    close(pipefd[1]);
    // Read the sim's output until it says where its rig description is (written before that line).
    FILE* in = fdopen(pipefd[0], "r");
    char line[1024];
    bool ready = false;
    while (std::fgets(line, sizeof line, in)) {
        if (std::string(line).find("rig description with these addresses") != std::string::npos) {
            ready = true;
            break;
        }
    }
    ASSERT_TRUE(ready);
    {
        std::ofstream c(dir + "/campaign.json");
        c << R"({"sample": "separate", "rig": "live-rig.json",
                 "plan": {"kind": "uniform", "n_theta": 3, "n_dphi": 3, "theta_max_deg": 60},
                 "drift": {"every": 0}})";
    }
    int st = 0;
    const std::string out =
        run_gonio("acquire " + dir + "/campaign.json --out " + dir + "/run", &st);
    EXPECT_EQ(st, 0) << out;
    kill(pid, SIGINT);
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    std::fclose(in);
    auto ds = gonio::brdf::read_dataset_csv(dir + "/run/dataset.csv");
    ASSERT_TRUE(ds) << ds.error().message;
    EXPECT_GT(ds->samples.size(), 5u);
    // The rig description the sim wrote names the GigE Vision camera.
    std::ifstream rig(live);
    const std::string rig_text((std::istreambuf_iterator<char>(rig)),
                               std::istreambuf_iterator<char>());
    EXPECT_NE(rig_text.find("\"gige://127."), std::string::npos) << rig_text;
}

}  // namespace
