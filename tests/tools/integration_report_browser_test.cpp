// The demo's pages in a real browser: a point campaign and an image campaign measured on the
// embedded virtual rig, each fitted and reported by the gonio binary exactly as scripts/demo.sh
// does, then loaded in headless Chromium at 1280 x 900: every image decodes, nothing is wider than
// the window, the first screen holds the verdict and the parameters.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "../report/browser_support.h"
#include "cli_run.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

TEST(DemoPages, PointCampaignReportInChromium) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_test_dir("demo_pages");
    const fs::path c = dir / "campaign";
    CliRun r = run_gonio("acquire --material red-plastic --out " + c.string() +
                         " --n-theta 5 --n-dphi 3 --adaptive 0 --time-scale 500");
    ASSERT_EQ(r.status, 0) << r.out;
    r = run_gonio("fit " + (c / "dataset.csv").string() + " --out " + (c / "fit.json").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run_gonio("plot " + (c / "dataset.csv").string() + " --fit " + (c / "fit.json").string() +
                  " --out " + (c / "plots").string());
    ASSERT_EQ(r.status, 0) << r.out;
    fs::create_directories(c / "previews");
    r = run_gonio("preview material:red-plastic --vs " + (c / "fit.json").string() +
                  " --size 128 --samples 24 --out " +
                  (c / "previews" / "truth-vs-fit.png").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run_gonio("report " + c.string());
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string html = read_all(c / "report.html");
    // The run history and the folded raw descriptions are there; no nested JSON tables.
    EXPECT_NE(html.find("id=\"history\""), std::string::npos);
    EXPECT_NE(html.find("<details><summary><code>metadata.json</code>"), std::string::npos);
    EXPECT_EQ(html.find("<table class=\"kv\"><tr><th>name</th><td><table"), std::string::npos);
    const nlohmann::json f = page_layout_facts(c / "report.html", dir / "browser_point");
    // in-plane, delta_phi, residuals, truth-vs-fit preview, coverage.
    expect_report_layout(f, 5);
}

TEST(DemoPages, ImageCampaignReportInChromium) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_test_dir("demo_pages_image");
    const fs::path c = dir / "image";
    CliRun r = run_gonio("acquire --mode image --material red-plastic --out " + c.string() +
                         " --coverage-target 0.5 --time-scale 200");
    ASSERT_EQ(r.status, 0) << r.out;
    ASSERT_TRUE(fs::exists(c / "dataset.json"));
    r = run_gonio("fit " + (c / "dataset.csv").string() + " --out " + (c / "fit.json").string());
    ASSERT_EQ(r.status, 0) << r.out;
    r = run_gonio("report " + c.string() + " --preview-size 128 --preview-samples 24");
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string html = read_all(c / "report.html");
    EXPECT_NE(html.find("image-mode campaign"), std::string::npos);
    EXPECT_NE(html.find("Light positions in the order measured"), std::string::npos);
    EXPECT_EQ(html.find("No campaign.json"), std::string::npos);
    EXPECT_EQ(html.find("No calibration"), std::string::npos);
    EXPECT_TRUE(fs::exists(c / "plots" / "coverage-map.png"));
    const nlohmann::json f = page_layout_facts(c / "report.html", dir / "browser_image");
    // in-plane (or half angle), residuals, table-vs-fit preview, coverage map.
    expect_report_layout(f, 4);
    // The measured table's checks: within its resolution and stated noise (dataset.csv's sigma).
    std::string table = fs::exists(c / "table.binary") ? "table.binary" : "table.gtab";
    r = run_gonio("check " + (c / table).string());
    EXPECT_NE(r.out.find("noise: per-bin sigma"), std::string::npos) << r.out;
    std::printf("%s\n", r.out.c_str());
}

}  // namespace
}  // namespace gonio::testing
