// The RGL glue of the CLI, run through the gonio binary on files in a temporary folder (no devices,
// no network). A model becomes a file (`convert`), the file is a BRDF for `eval` and `check`, its
// nodes are samples for `convert ... .csv` and `fit`, and options that do not apply to an RGL
// output are refused with exit 2 naming them. An anisotropic model becomes an anisotropic file.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_json.h"

namespace gonio::testing {
namespace {

const char* kRglCliModel = R"({
  "diffuse": [0.2, 0.3, 0.4],
  "lobes": [
    {"distribution": "ggx", "alpha": 0.3, "shadowing": "smith-correlated",
     "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}
  ]
})";

class RglCli : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fresh_test_dir("rgl_cli");
        std::ofstream(path("model.json")) << kRglCliModel;
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    std::filesystem::path dir_;
};

TEST_F(RglCli, ModelToBsdfThenEvalCheckAndNodes) {
    CliRun r = run_gonio("convert " + path("model.json") + " " + path("m.bsdf"));
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("power iteration"), std::string::npos) << r.out;

    // eval at a few pairs agrees with the model.
    {
        std::ofstream dirs(path("dirs.csv"));
        dirs << "theta_i,phi_i,theta_o,phi_o\n0.3,0,0.3,3.14159\n0.7,0.5,0.2,-2\n1.0,0,0.9,3.0\n";
    }
    r = run_gonio("eval " + path("m.bsdf") + " -i " + path("dirs.csv") + " -o " + path("vals.csv"));
    ASSERT_EQ(r.status, 0) << r.out;
    auto m = brdf::parse_model_json(kRglCliModel, "model");
    ASSERT_TRUE(m);
    std::ifstream vals(path("vals.csv"));
    std::string line;
    std::getline(vals, line);
    const double pairs[3][4] = {{0.3, 0, 0.3, 3.14159}, {0.7, 0.5, 0.2, -2}, {1.0, 0, 0.9, 3.0}};
    int rows = 0;
    while (std::getline(vals, line)) {
        std::stringstream s(line);
        std::string cell;
        std::vector<double> v;
        while (std::getline(s, cell, ',')) {
            v.push_back(std::stod(cell));
        }
        ASSERT_GE(v.size(), 3u) << line;
        const double* p = pairs[rows];
        const brdf::Rgbd truth = brdf::eval_model(
            *m, brdf::spherical_to_cartesian(p[0], p[1]), brdf::spherical_to_cartesian(p[2], p[3]));
        for (int c = 0; c < 3; ++c) {
            const double got = v[v.size() - 3 + static_cast<std::size_t>(c)];
            // Within the representation error of a written file (docs/benchmarks.md: 95th
            // percentile 8 %, larger near the peak at grazing angles).
            EXPECT_NEAR(got, truth[c], 0.1 * truth[c]) << "row " << rows << " channel " << c;
        }
        ++rows;
    }
    EXPECT_EQ(rows, 3);

    r = run_gonio("check " + path("m.bsdf"));
    EXPECT_NE(r.out.find("RGL material file"), std::string::npos) << r.out;

    r = run_gonio("convert " + path("m.bsdf") + " " + path("nodes.csv"));
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("one per stored node"), std::string::npos) << r.out;
    auto data = brdf::read_dataset_csv(path("nodes.csv"));
    ASSERT_TRUE(data) << data.error().message;
    EXPECT_GT(data->samples.size(), 8000u);

    r = run_gonio("fit " + path("m.bsdf") + " --out " + path("fit.json"));
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(std::filesystem::exists(path("fit.json"))) << r.out;
}

TEST_F(RglCli, OptionsThatDoNotApplyToAnRglOutputAreRefused) {
    for (const char* opt : {"--grid 10x10x10", "--threads 1", "--radius 2"}) {
        CliRun r = run_gonio("convert " + path("model.json") + " " + path("m.bsdf") + " " + opt);
        EXPECT_EQ(r.status, 2) << opt << ": " << r.out;
        EXPECT_NE(r.out.find(std::string(opt).substr(0, std::string(opt).find(' '))),
                  std::string::npos)
            << r.out;
    }
    EXPECT_FALSE(std::filesystem::exists(path("m.bsdf")));
}

// A brushed lobe mounted at 30 degrees becomes an anisotropic file (phi_i nodes over the full
// turn); its nodes are samples with their own incident azimuths, and an anisotropic fit of them
// gives the lobe back. One azimuth cannot hold it, and --phi-i means nothing for other outputs.
TEST_F(RglCli, AnisotropicModelBecomesAnAnisotropicFileThatFitsBack) {
    std::ofstream(path("brushed.json")) << R"({
  "diffuse": [0.05, 0.05, 0.05],
  "lobes": [
    {"distribution": "ggx", "alpha_x": 0.1, "alpha_y": 0.25, "orientation_deg": 30,
     "shadowing": "smith-correlated", "fresnel": {"type": "schlick", "f0": [0.9, 0.8, 0.6]}}
  ]
})";
    CliRun r = run_gonio("convert " + path("brushed.json") + " " + path("one.bsdf") + " --phi-i 1");
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_NE(r.out.find("anisotropic"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(path("one.bsdf")));
    r = run_gonio("convert " + path("brushed.json") + " " + path("b.csv") + " --phi-i 8");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find("--phi-i"), std::string::npos) << r.out;

    r = run_gonio("convert " + path("brushed.json") + " " + path("b.bsdf") + " --phi-i 8");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("anisotropic, 8 incident azimuths"), std::string::npos) << r.out;
    r = run_gonio("check " + path("b.bsdf"));
    EXPECT_NE(r.out.find("anisotropic RGB, 9 phi_i"), std::string::npos) << r.out;

    r = run_gonio("convert " + path("b.bsdf") + " " + path("nodes.csv"));
    ASSERT_EQ(r.status, 0) << r.out;
    auto data = brdf::read_dataset_csv(path("nodes.csv"));
    ASSERT_TRUE(data) << data.error().message;
    std::set<long> azimuths;
    for (const brdf::Sample& smp : data->samples) {
        azimuths.insert(std::lround((smp.phi_i + brdf::kPi) / (brdf::kPi / 4)) % 8);
    }
    EXPECT_EQ(azimuths.size(), 8u);

    r = run_gonio("fit " + path("b.bsdf") + " --anisotropic --out " + path("fit.json"));
    ASSERT_EQ(r.status, 0) << r.out;
    auto fitted = brdf::load_model_json(path("fit.json"));
    ASSERT_TRUE(fitted) << fitted.error().message;
    ASSERT_EQ(fitted->lobes.size(), 1u);
    const auto& lobe = fitted->lobes[0];
    // The nodes hold the model's values to float rounding: the fit finds the lobe within 2 %,
    // the orientation within half a degree (the canonical form keeps alpha_x <= alpha_y).
    EXPECT_NEAR(lobe.alpha_x, 0.1, 0.002) << r.out;
    EXPECT_NEAR(lobe.alpha_y, 0.25, 0.005) << r.out;
    EXPECT_NEAR(lobe.orientation_deg, 30.0, 0.5) << r.out;
}

TEST_F(RglCli, BrokenFileIsAnInputErrorNamingTheFile) {
    std::ofstream(path("bad.bsdf")) << "tensor_fila";
    CliRun r = run_gonio("check " + path("bad.bsdf"));
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.out.find(path("bad.bsdf")), std::string::npos) << r.out;
}

TEST_F(RglCli, TabulatedFitIsWrittenAsBsdfAndRefusedByRendererExports) {
    // A table fitted by power iteration from the nodes of a file written from a GGX model: the
    // model file evaluates, the renderer exports refuse it naming the RGL file as the way out, and
    // `convert` writes it as one.
    CliRun r = run_gonio("convert " + path("model.json") + " " + path("m.bsdf"));
    ASSERT_EQ(r.status, 0) << r.out;
    r = run_gonio("fit " + path("m.bsdf") + " --model tabulated --out " + path("fit.json"));
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("power iteration"), std::string::npos) << r.out;
    auto fitted = brdf::load_model_json(path("fit.json"));
    ASSERT_TRUE(fitted) << fitted.error().message;
    ASSERT_EQ(fitted->lobes.size(), 1u);
    EXPECT_EQ(fitted->lobes[0].distribution, brdf::Distribution::kTabulated);
    for (const char* to : {"mitsuba", "pbrt"}) {
        r = run_gonio(std::string("export ") + path("fit.json") + " --to " + to);
        EXPECT_EQ(r.status, 1) << to << ": " << r.out;
        EXPECT_NE(r.out.find("tabulated NDF"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find(".bsdf"), std::string::npos) << r.out;
    }
    r = run_gonio("convert " + path("fit.json") + " " + path("t.bsdf"));
    ASSERT_EQ(r.status, 0) << r.out;
    r = run_gonio("check " + path("fit.json"));
    EXPECT_EQ(r.status, 0) << r.out;
}

}  // namespace
}  // namespace gonio::testing
