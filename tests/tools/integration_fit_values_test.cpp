// `gonio fit` on measured values as they come: a dark channel measured with noise lands a little
// below zero (the dark frame subtracted), and those values are kept and fitted; a value far below
// zero is refused, naming its row. Datasets with and without sigma columns.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "../fitting/fit_test_util.h"
#include "cli_run.h"
#include "gonio/brdf/dataset.h"

namespace {

using gonio::testing::CliRun;
using gonio::testing::run_gonio;

std::string values_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("integration_fit_values").string();
    return d;
}

/// A yellow material (its blue channel nearly black) measured with additive noise of `noise`
/// 1/sr, as a rig's dark-frame subtraction leaves it: about half of the darkest blue values land
/// below zero. Returns the dataset and counts its values below zero in *below.
gonio::brdf::Dataset yellow_measurement(double noise, bool with_sigma, int* below) {
    gonio::brdf::ModelD truth;
    truth.has_diffuse = true;
    truth.diffuse = gonio::brdf::Rgbd(0.55, 0.45, 1e-7);
    gonio::brdf::Lobe<double> l;
    l.distribution = gonio::brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.2;
    l.fresnel.type = gonio::brdf::FresnelType::kSchlick;
    l.fresnel.f0 = gonio::brdf::Rgbd::Constant(0.04);
    l.scale = gonio::brdf::Rgbd(1, 1, 1e-6);
    truth.lobes.push_back(l);
    gonio::brdf::Dataset d =
        gonio::fitting::testing::synthesize(truth, gonio::fitting::testing::measurement_grid());
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n(0.0, noise);
    *below = 0;
    for (gonio::brdf::Sample& s : d.samples) {
        s.value[2] += n(rng);
        *below += s.value[2] < 0 ? 1 : 0;
        if (with_sigma) {
            s.sigma = gonio::brdf::Rgbd(1e-3 * s.value[0], 1e-3 * s.value[1], noise);
        }
    }
    d.has_sigma = with_sigma;
    return d;
}

/// Fits `d` written to NAME; returns the run and the report.
CliRun fit(const gonio::brdf::Dataset& d, const std::string& name, nlohmann::json* report) {
    const std::string data = values_dir() + "/" + name + ".csv";
    EXPECT_TRUE(gonio::brdf::write_dataset_csv(data, d));
    const std::string out = values_dir() + "/" + name + ".fit.json";
    CliRun r = run_gonio("fit " + data + " --model ggx --out " + out);
    std::ifstream in(values_dir() + "/" + name + ".fit.report.json");
    if (in && report != nullptr) {
        *report = nlohmann::json::parse(in);
    }
    return r;
}

TEST(GonioFit, ValuesBelowZeroWithinTheirSigmaAreKeptAndFitted) {
    int below = 0;
    const gonio::brdf::Dataset d = yellow_measurement(1e-7, true, &below);
    ASSERT_GT(below, 50);  // the blue channel really crosses zero
    nlohmann::json rep;
    CliRun r = fit(d, "sigma", &rep);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(rep["samples"]["valid"].get<std::size_t>(), d.samples.size());
    EXPECT_EQ(rep["samples"]["rejected"].get<std::size_t>(), 0u);
    // The bright channels are fitted as if the blue one were not there.
    EXPECT_NEAR(rep["model"]["diffuse"][0].get<double>(), 0.55, 1e-3);
    EXPECT_NEAR(rep["model"]["diffuse"][1].get<double>(), 0.45, 1e-3);
    EXPECT_TRUE(std::isfinite(rep["metrics"]["log_rmse"][2].get<double>()));
}

TEST(GonioFit, ValuesBelowZeroWithinTheNoiseADatasetWithoutSigmaImpliesAreKept) {
    int below = 0;
    const gonio::brdf::Dataset d = yellow_measurement(1e-6, false, &below);
    ASSERT_GT(below, 50);
    nlohmann::json rep;
    CliRun r = fit(d, "nosigma", &rep);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(rep["samples"]["valid"].get<std::size_t>(), d.samples.size());
    EXPECT_NEAR(rep["model"]["diffuse"][0].get<double>(), 0.55, 1e-3);
}

TEST(GonioFit, AValueFarBelowZeroIsRefusedNamingItsRow) {
    int below = 0;
    gonio::brdf::Dataset d = yellow_measurement(1e-7, true, &below);
    d.samples[40].value[2] = -0.05;  // 5e5 sigmas below zero: no measurement of a dark value
    const std::string data = values_dir() + "/far.csv";
    ASSERT_TRUE(gonio::brdf::write_dataset_csv(data, d));
    CliRun r = run_gonio("fit " + data);
    EXPECT_EQ(r.status, 1) << r.out;
    // Line 42: the header is line 1, sample 40 is the 41st row. Column 7 is b.
    EXPECT_NE(r.out.find("far.csv:42:7: b = -0.05"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("below zero beyond its noise"), std::string::npos) << r.out;
    // Without sigma columns the implied noise (1e-4 of the largest value) decides.
    for (gonio::brdf::Sample& s : d.samples) {
        s.sigma = gonio::brdf::Rgbd::Zero();
    }
    d.has_sigma = false;
    const std::string plain = values_dir() + "/far_nosigma.csv";
    ASSERT_TRUE(gonio::brdf::write_dataset_csv(plain, d));
    CliRun p = run_gonio("fit " + plain);
    EXPECT_EQ(p.status, 1) << p.out;
    EXPECT_NE(p.out.find("far_nosigma.csv:42:7: b = -0.05"), std::string::npos) << p.out;
}

}  // namespace
