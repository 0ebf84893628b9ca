// Symbolic links planted at every output name of fit, report, convert, export, plot, preview and
// acquire - the final names and the predictable temporary names ("NAME.tmp") the writers once used
// - must never be followed: each link's target keeps its content, the outputs end up as regular
// files, and no temporary file is left behind.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"

namespace {

namespace fs = std::filesystem;
using gonio::testing::CliRun;
using gonio::testing::run_gonio;

const char* kLinksModel = R"({"diffuse": [0.2, 0.15, 0.1], "lobes": [{"distribution": "ggx",
    "alpha": 0.3, "shadowing": "smith-correlated", "fresnel": {"type": "schlick", "f0": 0.04}}]})";

class OutputLinks : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = gonio::testing::fresh_test_dir("links");
        fs::create_directories(dir_ / "victims");
    }

    fs::path p(const std::string& name) const { return dir_ / name; }
    std::string q(const std::string& name) const { return "'" + p(name).string() + "'"; }

    /// Plants links at `output` and (unless final_only) `output.tmp`, each to a victim of its own.
    void plant(const fs::path& output, bool final_only = false) {
        std::vector<fs::path> names = {output};
        if (!final_only) {
            names.emplace_back(output.string() + ".tmp");
        }
        for (const fs::path& at : names) {
            const fs::path victim = dir_ / "victims" / ("victim" + std::to_string(planted_.size()));
            std::ofstream(victim) << "precious " << planted_.size();
            fs::create_directories(at.parent_path());
            fs::create_symlink(victim, at);
            planted_.push_back({at, victim});
        }
    }

    /// Every victim untouched; every final output a regular file (or absent when the command
    /// refused); no hidden temporary file anywhere.
    void check(const std::string& what) {
        for (std::size_t k = 0; k < planted_.size(); ++k) {
            EXPECT_EQ(gonio::testing::read_text(planted_[k].second),
                      "precious " + std::to_string(k))
                << what << ": the link at " << planted_[k].first << " was followed";
        }
        for (const auto& e : fs::recursive_directory_iterator(dir_)) {
            const std::string n = e.path().filename().string();
            EXPECT_FALSE(n[0] == '.' && n.size() > 4 && n.compare(n.size() - 4, 4, ".tmp") == 0)
                << what << ": temporary file left: " << e.path();
        }
    }

    void expect_regular(const fs::path& output, const std::string& what) {
        EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(output)))
            << what << ": " << output << " is not a regular file";
    }

    fs::path dir_;
    std::vector<std::pair<fs::path, fs::path>> planted_;
};

TEST_F(OutputLinks, ConvertAndExport) {
    std::ofstream(p("m.json")) << kLinksModel;
    plant(p("o.gtab"));
    plant(p("o.csv"));
    plant(p("o.pbrt"));
    plant(p("o.xml"));
    plant(p("o.binary"));
    CliRun r = run_gonio("convert " + q("m.json") + " " + q("o.gtab") + " --grid 8x8x16");
    EXPECT_EQ(r.status, 0) << r.out;
    r = run_gonio("convert " + q("m.json") + " " + q("o.csv") + " --grid 8x8x16");
    EXPECT_EQ(r.status, 0) << r.out;
    r = run_gonio("export " + q("m.json") + " --to pbrt --out " + q("o.pbrt"));
    EXPECT_EQ(r.status, 0) << r.out;
    r = run_gonio("export " + q("m.json") + " --to mitsuba --out " + q("o.xml"));
    EXPECT_EQ(r.status, 0) << r.out;
    r = run_gonio("export " + q("m.json") + " --to merl " + q("o.binary"));
    EXPECT_EQ(r.status, 0) << r.out;
    for (const char* o : {"o.gtab", "o.csv", "o.pbrt", "o.xml", "o.binary"}) {
        expect_regular(p(o), o);
    }
    EXPECT_NE(gonio::testing::read_text(p("o.pbrt")).find("MakeNamedMaterial"), std::string::npos);
    check("convert/export");
}

TEST_F(OutputLinks, FitPlotAndPreview) {
    std::ofstream(p("m.json")) << kLinksModel;
    ASSERT_EQ(run_gonio("convert " + q("m.json") + " " + q("d.csv") + " --grid 8x8x16").status, 0);
    plant(p("fit.json"));
    plant(p("fit.report.json"));
    CliRun r =
        run_gonio("fit " + q("d.csv") + " --model ggx --max-samples 300 --out " + q("fit.json"));
    EXPECT_EQ(r.status, 0) << r.out;
    expect_regular(p("fit.json"), "fit");
    expect_regular(p("fit.report.json"), "fit");

    plant(p("preview.png"));
    r = run_gonio("preview " + q("m.json") + " --size 32 --samples 16 --out " + q("preview.png"));
    EXPECT_EQ(r.status, 0) << r.out;
    expect_regular(p("preview.png"), "preview");

    // The picture names of plot, from a first run elsewhere; then links at each of them.
    r = run_gonio("plot " + q("d.csv") + " --out " + q("names"));
    ASSERT_EQ(r.status, 0) << r.out;
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(p("names"))) {
        names.push_back(e.path().filename().string());
    }
    ASSERT_FALSE(names.empty());
    for (const std::string& n : names) {
        plant(p("plots/" + n));
    }
    r = run_gonio("plot " + q("d.csv") + " --out " + q("plots"));
    EXPECT_EQ(r.status, 0) << r.out;
    for (const std::string& n : names) {
        expect_regular(p("plots/" + n), "plot");
    }
    check("fit/plot/preview");
}

TEST_F(OutputLinks, Report) {
    fs::create_directories(p("D"));
    std::ofstream(p("D/fit.json")) << kLinksModel;
    ASSERT_EQ(run_gonio("convert " + q("D/fit.json") + " " + q("D/dataset.csv") + " --grid 8x8x16")
                  .status,
              0);
    plant(p("D/report.html"));
    const CliRun r = run_gonio("report " + q("D") + " --preview-size 32 --preview-samples 16");
    EXPECT_EQ(r.status, 0) << r.out;
    expect_regular(p("D/report.html"), "report");
    EXPECT_NE(gonio::testing::read_text(p("D/report.html")).find("<html"), std::string::npos);
    check("report");
}

TEST_F(OutputLinks, AcquireNewCampaignAndResume) {
    const std::string args = " --n-theta 3 --n-dphi 2 --adaptive 0 --time-scale 500";
    // A link at the journal: opened with O_NOFOLLOW, so the campaign refuses to run on it.
    plant(p("A/journal.log"));
    CliRun r = run_gonio("acquire --out " + q("A") + args);
    EXPECT_EQ(r.status, 1) << r.out;
    check("acquire with a linked journal");

    plant(p("C/metadata.json"));
    plant(p("C/dataset.csv"));
    plant(p("C/rig.json"));
    r = run_gonio("acquire --out " + q("C") + args);
    ASSERT_EQ(r.status, 0) << r.out;
    for (const char* o : {"C/metadata.json", "C/dataset.csv", "C/rig.json", "C/campaign.json"}) {
        expect_regular(p(o), o);
    }
    // Resume: dataset.csv and metadata.json are written again.
    fs::remove(p("C/dataset.csv"));
    fs::remove(p("C/metadata.json"));
    plant(p("C/dataset.csv"), true);
    plant(p("C/metadata.json"), true);
    r = run_gonio("acquire --resume " + q("C"));
    ASSERT_EQ(r.status, 0) << r.out;
    expect_regular(p("C/dataset.csv"), "resume");
    expect_regular(p("C/metadata.json"), "resume");
    check("acquire");
}

}  // namespace
