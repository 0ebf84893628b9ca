// `gonio fit` end to end: a dataset CSV on disk, the command, the model and report files.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../fitting/fit_test_util.h"
#include "cli_run.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/material_library.h"
#include "gonio/brdf/model_json.h"

namespace {

using gonio::brdf::Rgbd;

using gonio::testing::CliRun;
using gonio::testing::run_gonio;

/// The running test's own folder (created fresh on first use).
std::string fit_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("integration_fit").string();
    return d;
}

gonio::brdf::ModelD ggx_truth() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = Rgbd(0.4, 0.3, 0.2);
    gonio::brdf::Lobe<double> l;
    l.distribution = gonio::brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.15;
    l.fresnel.type = gonio::brdf::FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd::Constant(0.05);
    l.scale = Rgbd(1.0, 0.9, 0.8);
    m.lobes.push_back(l);
    return m;
}

/// Writes the synthetic dataset of the default model's structure, with `extra` appended.
std::string write_data(const std::string& name = "ggx.csv", const std::string& extra = "") {
    const std::string path = fit_dir() + "/" + name;
    gonio::brdf::Dataset d = gonio::fitting::testing::synthesize(
        ggx_truth(), gonio::fitting::testing::measurement_grid());
    EXPECT_TRUE(gonio::brdf::write_dataset_csv(path, d));
    std::ofstream out(path, std::ios::app);
    out << extra;
    return path;
}

TEST(GonioFit, FitsACsvAndWritesModelAndReport) {
    const std::string data = write_data();
    const std::string out = fit_dir() + "/fit.json";
    std::remove(out.c_str());
    CliRun r = run_gonio("fit " + data + " --model ggx --out " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("CONVERGENCE"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("lobes[0].alpha_x"), std::string::npos) << r.out;
    // The model file is a model: the loader of `gonio eval` reads it.
    auto model = gonio::brdf::load_model_json(out);
    ASSERT_TRUE(model) << model.error().message;
    EXPECT_NEAR(model->lobes[0].alpha_x, 0.15, 1e-6);
    EXPECT_NEAR(model->diffuse[1], 0.3, 1e-6);
    auto brdf = gonio::brdf::load_brdf(out);
    ASSERT_TRUE(brdf) << brdf.error().message;
    // The report: keys other tools read.
    std::ifstream in(fit_dir() + "/fit.report.json");
    std::stringstream ss;
    ss << in.rdbuf();
    const nlohmann::json j = nlohmann::json::parse(ss.str());
    for (const char* key : {"model",
                            "parameters",
                            "not_identifiable",
                            "metrics",
                            "samples",
                            "residual",
                            "loss",
                            "solver",
                            "data"}) {
        EXPECT_TRUE(j.contains(key)) << key;
    }
    EXPECT_EQ(j["samples"]["rejected"].get<int>(), 0);
    const std::size_t n = gonio::fitting::testing::measurement_grid().size();
    EXPECT_EQ(j["samples"]["valid"].get<std::size_t>(), n);
    // Goodness of fit and the stages are in the report.
    EXPECT_TRUE(j["goodness"]["represents"].get<bool>());
    EXPECT_LT(j["metrics"]["log_rmse"][0].get<double>(), 1e-6);
    EXPECT_FALSE(j["metrics"]["bands"].empty());
    EXPECT_FALSE(j["solver"]["stages"].empty());
    EXPECT_NE(j["covariance"].get<std::string>().find("sandwich"), std::string::npos);
    EXPECT_EQ(j["residual"], "log");
    EXPECT_TRUE(j["solver"]["usable"].get<bool>());
    EXPECT_EQ(j["model"], nlohmann::json::parse(gonio::brdf::model_to_json(*model)));
}

TEST(GonioFit, CompareRanksTheGeneratingModelFirst) {
    const std::string data = write_data();
    CliRun r = run_gonio("fit --compare blinn-phong,beckmann,ggx " + data);
    ASSERT_EQ(r.status, 0) << r.out;
    const std::size_t first = r.out.find("\n1 ");
    ASSERT_NE(first, std::string::npos) << r.out;
    EXPECT_EQ(r.out.substr(first + 1, 40).find("ggx"), 5u) << r.out;
    EXPECT_NE(r.out.find("beckmann"), std::string::npos);
    EXPECT_NE(r.out.find("blinn-phong"), std::string::npos);
}

TEST(GonioFit, ANonConvergedFitExitsNonZeroAndWritesNoModel) {
    const std::string data = write_data();
    const std::string out = fit_dir() + "/stopped.json";
    std::remove(out.c_str());
    CliRun r = run_gonio("fit " + data + " --model ggx --max-iterations 1 --starts 1 --out " + out);
    EXPECT_NE(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("DID NOT CONVERGE"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("parameters:"), std::string::npos) << r.out;
    EXPECT_FALSE(std::ifstream(out).good());
    EXPECT_TRUE(std::ifstream(fit_dir() + "/stopped.report.json").good());
}

TEST(GonioFit, AMisfitIsWrittenWithItsVerdictAndExitsZeroUnlessStrict) {
    // A retro-reflection peak that no microfacet lobe at the mirror direction follows.
    const std::string path = fit_dir() + "/retro.csv";
    gonio::brdf::Dataset d = gonio::fitting::testing::synthesize(
        ggx_truth(), gonio::fitting::testing::measurement_grid());
    for (gonio::brdf::Sample& s : d.samples) {
        const double c = s.wi().dot(s.wo());
        const double retro = c > 0 ? 20 * std::pow(c, 30) : 0;
        s.value += Rgbd(retro, 0.5 * retro, 0.2 * retro);
    }
    ASSERT_TRUE(gonio::brdf::write_dataset_csv(path, d));
    const std::string out = fit_dir() + "/misfit.json";
    const std::string err = fit_dir() + "/misfit.stderr";
    std::remove(out.c_str());
    CliRun r = run_gonio("fit " + path + " --model ggx --out " + out, err);
    EXPECT_EQ(r.status, 0) << r.out;
    // The verdict and the suggestion, once, in the summary (a misfit without --strict is no
    // error: nothing more on stderr).
    const std::size_t split = r.out.find("--- stderr ---");
    EXPECT_NE(r.out.substr(0, split).find("verdict: MISFIT: does not represent these data"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.substr(0, split).find("--model auto"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.substr(split).find("represent"), std::string::npos) << r.out;
    std::ifstream in(out);
    ASSERT_TRUE(in.good());
    std::stringstream ss;
    ss << in.rdbuf();
    const nlohmann::json j = nlohmann::json::parse(ss.str());
    EXPECT_FALSE(j.at("fit").at("represents").get<bool>());
    // The model file reads as a model (the verdict under "fit" is ignored by readers).
    EXPECT_TRUE(gonio::brdf::load_model_json(out));

    std::remove(out.c_str());
    CliRun strict = run_gonio("fit " + path + " --model ggx --strict --out " + out);
    EXPECT_EQ(strict.status, 1) << strict.out;
    EXPECT_NE(strict.out.find("--strict: the model does not represent these data"),
              std::string::npos)
        << strict.out;
    // Still written: --strict changes the exit status, not what a converged fit leaves.
    EXPECT_TRUE(std::ifstream(out).good());
}

TEST(GonioFit, BadInputsAreClearErrors) {
    CliRun missing = run_gonio("fit " + fit_dir() + "/does-not-exist.csv");
    EXPECT_NE(missing.status, 0);
    EXPECT_NE(missing.out.find("does-not-exist.csv"), std::string::npos) << missing.out;
    const std::string data = write_data();
    CliRun bad_model = run_gonio("fit " + data + " --model phong");
    EXPECT_NE(bad_model.status, 0);
    EXPECT_NE(bad_model.out.find("phong"), std::string::npos) << bad_model.out;
}

TEST(GonioFit, MalformedCsvRowsAreErrorsNamingFileLineAndColumn) {
    const std::size_t n = gonio::fitting::testing::measurement_grid().size();
    const std::string line = std::to_string(n + 2);  // header on line 1
    struct Case {
        std::string row, expect;
    };
    const Case cases[] = {
        {"0.3,0,0.4,3.1,nan,0.1,0.1\n", "bad1.csv:" + line + ":5: r = nan is not finite"},
        {"0.3,0,1.7,3.1,0.1,0.1,0.1\n", "bad2.csv:" + line + ":3: theta_o = 1.7"},
        {"0.3,0,0.4,3.1,1e308,0.1,0.1\n",
         "bad3.csv:" + line + ":5: r = 1e+308 outside [-1e9, 1e9]"},
        {"0.3,0,0.4,3.1,0.1,0.1\n", "bad4.csv:" + line + ": 6 fields, the header has 7"},
        {"0.3,0,0.4,3.1,0.1,x,0.1\n", "bad5.csv:" + line + ":6: g = \"x\" is not a number"},
    };
    int k = 1;
    for (const Case& c : cases) {
        const std::string name = "bad" + std::to_string(k++) + ".csv";
        const std::string out = fit_dir() + "/" + name + ".json";
        CliRun r = run_gonio("fit " + write_data(name, c.row) + " --out " + out);
        EXPECT_EQ(r.status, 1) << r.out;
        EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.expect << "\n" << r.out;
        EXPECT_EQ(r.out.find("rmse"), std::string::npos) << r.out;
        EXPECT_FALSE(std::ifstream(out).good());
    }
}

TEST(GonioFit, ModelAutoRanksCandidatesAndPolishesTheWinner) {
    // Beckmann data (exact) on 3,060 direction pairs, more than the 2,000 of the ranking set:
    // the candidates are ranked on a reduction, so the winner, another family than the default
    // GGX, is the result only once polished on all samples.
    gonio::brdf::ModelD truth = ggx_truth();
    truth.lobes[0].distribution = gonio::brdf::Distribution::kBeckmann;
    truth.lobes[0].alpha_x = truth.lobes[0].alpha_y = 0.2;
    std::vector<std::pair<gonio::brdf::Vec3d, gonio::brdf::Vec3d>> dirs;
    for (int ti = 5; ti <= 85; ti += 5) {
        for (int to = 0; to <= 85; to += 5) {
            for (int dphi = 0; dphi <= 180; dphi += 20) {
                const double deg = gonio::brdf::kPi / 180;
                dirs.emplace_back(gonio::brdf::spherical_to_cartesian(ti * deg, 0.0),
                                  gonio::brdf::spherical_to_cartesian(to * deg, dphi * deg));
            }
        }
    }
    const std::string data = fit_dir() + "/beckmann.csv";
    ASSERT_TRUE(
        gonio::brdf::write_dataset_csv(data, gonio::fitting::testing::synthesize(truth, dirs)));
    const std::string out = fit_dir() + "/auto.json";
    CliRun r = run_gonio("fit --model auto " + data + " --out " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("BIC"), std::string::npos) << r.out;
    for (const char* m : {"ggx", "beckmann", "blinn-phong", "ggx x2"}) {
        EXPECT_NE(r.out.find(m), std::string::npos) << m << "\n" << r.out;
    }
    // The generating family wins.
    EXPECT_NE(r.out.find("chosen: beckmann\n"), std::string::npos) << r.out;
    // Polished: the result is the fit on every valid sample, not on the ranking set, and it
    // reaches the truth.
    std::ifstream in(fit_dir() + "/auto.report.json");
    const nlohmann::json rep = nlohmann::json::parse(in);
    EXPECT_EQ(rep.at("samples").at("valid").get<std::size_t>(), dirs.size());
    EXPECT_EQ(rep.at("samples").at("used").get<std::size_t>(), dirs.size());
    ASSERT_FALSE(rep.at("solver").at("stages").empty());
    EXPECT_EQ(rep.at("solver").at("stages").back().at("samples").get<std::size_t>(), dirs.size());
    const nlohmann::json fitted = nlohmann::json::parse(gonio::testing::read_text(out));
    EXPECT_EQ(fitted.at("lobes").at(0).at("distribution"), "beckmann") << fitted.dump();
    EXPECT_NEAR(fitted.at("lobes").at(0).at("alpha").get<double>(), 0.2, 1e-4) << fitted.dump();
}

TEST(GonioFit, TheDefaultFitChoosesTheModelAndRepresentsTheDemoMaterial) {
    // The demo's red plastic (Beckmann with V-groove shadowing) measured with 2 % noise: `gonio
    // fit` without --model ranks the candidates, names the winner, and the winner is the truth's
    // family and represents the data (a GGX fit leaves its dark blue channel visibly off).
    auto truth = gonio::brdf::load_material("red-plastic");
    ASSERT_TRUE(truth) << truth.error().message;
    ASSERT_EQ(truth->lobes.size(), 1u);
    ASSERT_EQ(truth->lobes[0].distribution, gonio::brdf::Distribution::kBeckmann);
    ASSERT_EQ(truth->lobes[0].shadowing, gonio::brdf::Shadowing::kVGroove);
    const std::string data = fit_dir() + "/red-plastic.csv";
    ASSERT_TRUE(gonio::brdf::write_dataset_csv(
        data, gonio::fitting::testing::noisy_measurement(*truth, 11)));
    const std::string out = fit_dir() + "/default.json";
    CliRun r = run_gonio("fit " + data + " --verbose --out " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("request: model=auto;"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("model auto: BIC"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("chosen: beckmann v-groove"), std::string::npos) << r.out;
    auto fitted = gonio::brdf::load_model_json(out);
    ASSERT_TRUE(fitted) << fitted.error().message;
    ASSERT_EQ(fitted->lobes.size(), 1u);
    EXPECT_EQ(fitted->lobes[0].distribution, gonio::brdf::Distribution::kBeckmann);
    EXPECT_EQ(fitted->lobes[0].shadowing, gonio::brdf::Shadowing::kVGroove);
    const nlohmann::json rep =
        nlohmann::json::parse(gonio::testing::read_text(fit_dir() + "/default.report.json"));
    EXPECT_EQ(rep.at("goodness").at("verdict"), "represents") << rep.at("goodness").dump();
    // 2 % multiplicative noise gives a median relative error near 1.35 % in every channel.
    for (int c = 0; c < 3; ++c) {
        EXPECT_LT(rep.at("metrics").at("median_rel").at(c).get<double>(), 0.03) << c;
    }
    EXPECT_NEAR(fitted->lobes[0].alpha_x, truth->lobes[0].alpha_x, 0.05 * truth->lobes[0].alpha_x);

    // A structure option without --model describes one family: GGX with that structure.
    CliRun ggx = run_gonio("fit " + data + " --verbose --fresnel none");
    ASSERT_EQ(ggx.status, 0) << ggx.out;
    EXPECT_NE(ggx.out.find("request: model=ggx;"), std::string::npos) << ggx.out;
    EXPECT_EQ(ggx.out.find("chosen:"), std::string::npos) << ggx.out;
}

TEST(GonioFit, ReductionAndTemplateOptionsWork) {
    const std::string data = write_data();
    const std::string tmpl = fit_dir() + "/template.json";
    {
        gonio::brdf::ModelD start = ggx_truth();
        start.lobes[0].alpha_x = start.lobes[0].alpha_y = 0.3;
        std::ofstream t(tmpl);
        t << "{\"model\": " << gonio::brdf::model_to_json(start)
          << ", \"shared\": [\"diffuse\"], \"bounds\": {\"lobes[0].alpha_x\": [0.01, 0.5]}}";
    }
    CliRun r =
        run_gonio("fit " + data + " --template " + tmpl + " --max-samples 300 --residual cosine");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("used"), std::string::npos);
    // The shared diffuse is one parameter named without a channel index.
    EXPECT_NE(r.out.find("  diffuse "), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("diffuse[0]"), std::string::npos) << r.out;
}

}  // namespace
