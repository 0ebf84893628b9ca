// End to end through the gonio executable: plot, preview, export and report on files written here.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"

namespace {

namespace fs = std::filesystem;
using gonio::test_units::kDeg;

using gonio::testing::CliRun;

/// Runs the gonio binary with arguments; standard error is appended to out after a marker line.
CliRun gonio(const std::string& args, const fs::path& dir) {
    return gonio::testing::run_gonio(args, (dir / "stderr.txt").string());
}

gonio::brdf::ModelD glossy_model() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = gonio::brdf::Rgbd(0.1, 0.08, 0.05);
    gonio::brdf::Lobe<double> l;
    l.distribution = gonio::brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.1;
    l.shadowing = gonio::brdf::Shadowing::kSmithCorrelated;
    l.fresnel.type = gonio::brdf::FresnelType::kSchlick;
    l.fresnel.f0 = gonio::brdf::Rgbd::Constant(0.05);
    l.scale = gonio::brdf::Rgbd::Constant(0.5);
    m.lobes.push_back(l);
    return m;
}

class ReportCli : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = gonio::testing::fresh_test_dir("report_cli");
        const auto model = glossy_model();
        std::ofstream(dir_ / "fit.json") << gonio::brdf::model_to_json(model);
        const gonio::brdf::AnalyticBrdf truth(model);
        gonio::brdf::Dataset d;
        for (int ti : {20, 45}) {
            for (int to = 0; to <= 80; to += 4) {
                for (int p : {0, 60, 120, 180}) {
                    gonio::brdf::Sample s;
                    s.theta_i = ti * kDeg;
                    s.theta_o = to * kDeg;
                    s.phi_o = p * kDeg;
                    s.value = truth.eval(s.wi(), s.wo());
                    d.samples.push_back(s);
                }
            }
        }
        ASSERT_TRUE(gonio::brdf::write_dataset_csv((dir_ / "dataset.csv").string(), d));
        gonio::brdf::Dataset empty;
        ASSERT_TRUE(gonio::brdf::write_dataset_csv((dir_ / "empty.csv").string(), empty));
    }
    fs::path dir_;
};

TEST_F(ReportCli, PlotWritesThePicturesAndRefusesAnEmptyDataset) {
    const fs::path out = dir_ / "plots";
    CliRun r = gonio("plot " + (dir_ / "dataset.csv").string() + " --fit " +
                         (dir_ / "fit.json").string() + " --log --out " + out.string(),
                     dir_);
    ASSERT_EQ(r.status, 0) << r.out;
    for (const char* f : {"in_plane.png", "delta_phi.png", "residuals.png"}) {
        EXPECT_TRUE(fs::exists(out / f)) << f;
        EXPECT_NE(r.out.find(f), std::string::npos);
    }
    const fs::path none = dir_ / "empty_plots";
    r = gonio("plot " + (dir_ / "empty.csv").string() + " --out " + none.string(), dir_);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.out.find("empty dataset"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(none));
}

TEST_F(ReportCli, PreviewOfAModelAgainstItsMerlTable) {
    const fs::path table = dir_ / "fit.binary";
    CliRun r =
        gonio("export " + (dir_ / "fit.json").string() + " --to merl " + table.string(), dir_);
    ASSERT_EQ(r.status, 0) << r.out;
    auto t = gonio::brdf::read_merl(table.string());
    ASSERT_TRUE(t) << t.error().message;
    // The table holds the model at the bin centres (within the MERL quantisation of doubles: none).
    const gonio::brdf::AnalyticBrdf truth(glossy_model());
    const gonio::brdf::Vec3d wi = gonio::brdf::spherical_to_cartesian(0.5, 0.0);
    const gonio::brdf::Vec3d wo = gonio::brdf::spherical_to_cartesian(0.9, 2.0);
    EXPECT_NEAR(t->eval(wi, wo)[1], truth.eval(wi, wo)[1], 0.1 * truth.eval(wi, wo)[1]);

    const fs::path png = dir_ / "preview.png";
    r = gonio("preview " + (dir_ / "fit.json").string() + " --vs " + table.string() +
                  " --size 64 --samples 24 --out " + png.string(),
              dir_);
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string bytes = gonio::testing::read_text(png);
    ASSERT_GT(bytes.size(), 8u);
    EXPECT_EQ(bytes.substr(1, 3), "PNG");
    r = gonio("preview " + (dir_ / "missing.json").string(), dir_);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.out.find("missing.json"), std::string::npos) << r.out;
}

TEST_F(ReportCli, ExportsForMitsubaAndPbrt) {
    CliRun r = gonio("export " + (dir_ / "fit.json").string() + " --to mitsuba --name paint", dir_);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("<scene version=\"3.0.0\">"), std::string::npos);
    EXPECT_NE(r.out.find("id=\"paint\""), std::string::npos);
    EXPECT_NE(r.out.find("<float name=\"alpha\" value=\"0.1\"/>"), std::string::npos) << r.out;
    const fs::path pbrt = dir_ / "fit.pbrt";
    r = gonio("export " + (dir_ / "fit.json").string() + " --to pbrt --out " + pbrt.string(), dir_);
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string text = gonio::testing::read_text(pbrt);
    EXPECT_NE(text.find("MakeNamedMaterial \"gonio_fit\""), std::string::npos);
    EXPECT_NE(text.find("\"float roughness\" [ 0.1 ]"), std::string::npos) << text;
    r = gonio("export " + (dir_ / "fit.json").string() + " --to povray", dir_);
    EXPECT_NE(r.status, 0);
}

TEST_F(ReportCli, ReportPrintsThePathOfASelfContainedPage) {
    CliRun r = gonio("report " + dir_.string() + " --preview-size 48 --preview-samples 12", dir_);
    ASSERT_EQ(r.status, 0) << r.out;
    const fs::path html = dir_ / "report.html";
    EXPECT_EQ(r.out.substr(0, r.out.find('\n')), html.string());
    const std::string page = gonio::testing::read_text(html);
    EXPECT_NE(page.find("data:image/png;base64,"), std::string::npos);
    EXPECT_NE(page.find("Coverage of the angular domain"), std::string::npos);
    // A folder that does not exist is an input that cannot be read: exit 2, naming it.
    r = gonio("report " + (dir_ / "nowhere").string(), dir_);
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find((dir_ / "nowhere").string() + ": cannot open"), std::string::npos)
        << r.out;
}

}  // namespace
