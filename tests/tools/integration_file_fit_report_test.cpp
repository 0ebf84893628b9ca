// The report of a fit of a file (gonio fit FILE.bsdf --out DIR/fit.json; gonio report DIR) is that
// fit's page: titled as a fit of the file, its plots drawn from the file fit.report.json names, and
// no campaign sections (no calibration, no run history, no "point-mode campaign").

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli_run.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

TEST(FileFitReport, ABsdfFitIsReportedAsAFitOfThatFile) {
    const fs::path dir = fresh_test_dir("file_fit_report");
    const fs::path bsdf = dir / "plastic.bsdf";
    const CliRun c = run_gonio("convert " + std::string(GONIO_SOURCE_DIR) +
                               "/data/models/plastic-ggx.json " + bsdf.string());
    ASSERT_EQ(c.status, 0) << c.out;
    const fs::path out = dir / "fit";
    fs::create_directories(out);  // gonio fit writes into an existing folder
    const CliRun f = run_gonio("fit " + bsdf.string() + " --out " + (out / "fit.json").string());
    ASSERT_EQ(f.status, 0) << f.out;
    const CliRun r = run_gonio("report " + out.string());
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string page = read_text((out / "report.html").string());
    EXPECT_NE(page.find("<h1>gonio fit report: plastic.bsdf</h1>"), std::string::npos)
        << page.substr(0, 3000);
    EXPECT_NE(page.find("fit of the file " + bsdf.string()), std::string::npos);
    EXPECT_EQ(page.find("campaign report"), std::string::npos);
    EXPECT_EQ(page.find("point-mode campaign"), std::string::npos);
    // The plots are drawn from the file the fit report names.
    EXPECT_NE(page.find("id=\"plot-in_plane\""), std::string::npos);
    EXPECT_NE(page.find("id=\"coverage\""), std::string::npos);
    EXPECT_TRUE(fs::exists(out / "plots" / "in_plane.png"));
    // No campaign sections, no notes of what a campaign would have.
    EXPECT_EQ(page.find("No calibration"), std::string::npos);
    EXPECT_EQ(page.find("No run history"), std::string::npos);
    EXPECT_EQ(page.find("id=\"calibration\""), std::string::npos);
    EXPECT_EQ(page.find("id=\"history\""), std::string::npos);
    EXPECT_EQ(page.find("dataset.csv: missing"), std::string::npos);
    // Moved away from where it was fitted, the file is found beside the fit; gone, a note says so.
    fs::rename(bsdf, out / "plastic.bsdf");
    ASSERT_EQ(run_gonio("report " + out.string() + " --regenerate").status, 0);
    EXPECT_NE(read_text((out / "report.html").string()).find("id=\"plot-in_plane\""),
              std::string::npos);
    fs::remove(out / "plastic.bsdf");
    fs::remove_all(out / "plots");
    ASSERT_EQ(run_gonio("report " + out.string()).status, 0);
    const std::string gone = read_text((out / "report.html").string());
    EXPECT_NE(gone.find("not found (as named, nor in this folder); no plots"), std::string::npos);
    EXPECT_EQ(gone.find("id=\"plot-in_plane\""), std::string::npos);
}

}  // namespace
}  // namespace gonio::testing
