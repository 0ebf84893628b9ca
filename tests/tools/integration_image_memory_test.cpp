// The memory budget of image mode (--max-memory, 2 GiB by default): an image plan or campaign
// whose memory estimate (acquisition/image/image_memory.h) is above the budget is refused with
// exit 2 before any work, naming the estimate and the budget, and leaves no campaign folder; the
// same work within the default budget plans and runs.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli_run.h"

namespace gonio::tools {
namespace {

namespace fs = std::filesystem;
using gonio::testing::run_gonio;

std::string temp_dir(const std::string& name) {
    return gonio::testing::test_folder("test_tools_image_memory", name, true);
}

bool has(const std::string& out, const std::string& what) {
    return out.find(what) != std::string::npos;
}

/// A small campaign on the default virtual rig: 48 px camera, 15 x 15 x 30 table.
const char* const kSmall = "acquire --mode image --camera-px 48 --grid 15x15x30 --max-frames 3 ";

TEST(ImageMemory, OverBudgetIsRefusedBeforeTheFolderExists) {
    const std::string dir = temp_dir("refused");
    // 1 MiB: below what the program alone needs.
    int st = 0;
    std::string out = run_gonio(
        std::string("--max-memory 1M ") + kSmall + "--time-scale 1000 --out " + dir + "/run", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_TRUE(has(out, "the image campaign (program ")) << out;
    EXPECT_TRUE(has(out, "candidates")) << out;
    EXPECT_TRUE(has(out, "above the limit of 1 MiB")) << out;
    EXPECT_TRUE(has(out, "--max-memory")) << out;
    EXPECT_FALSE(fs::exists(dir + "/run")) << out;
    // The plan alone is refused the same way (after the command: gonio's options may follow it).
    out = run_gonio(std::string(kSmall) + "--plan-only --max-memory 1M", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_TRUE(has(out, "the image plan (program ")) << out;
    EXPECT_TRUE(has(out, "above the limit of 1 MiB")) << out;
    EXPECT_FALSE(has(out, "predicted from the nominal sphere")) << out;
    fs::remove_all(dir);
}

TEST(ImageMemory, WithinTheDefaultBudgetThePlanAndTheCampaignRun) {
    const std::string dir = temp_dir("runs");
    int st = 0;
    std::string out = run_gonio(std::string(kSmall) + "--plan-only", &st);
    EXPECT_EQ(st, 0) << out;
    EXPECT_TRUE(has(out, "predicted from the nominal sphere")) << out;
    out = run_gonio(
        std::string(kSmall) + "--time-scale 1000 --coverage-target 0.01 --out " + dir + "/run",
        &st);
    EXPECT_EQ(st, 0) << out;
    EXPECT_TRUE(fs::exists(dir + "/run/dataset.csv")) << out;
    fs::remove_all(dir);
}

}  // namespace
}  // namespace gonio::tools
