// Anisotropic samples end to end through the binary: a point campaign on the embedded virtual rig
// with `--anisotropic` (the spin axis turns the sample; the dataset keeps both azimuths), fitted
// with `gonio fit --anisotropic`: a brushed GGX truth with its brushing direction at 0 and at 30
// degrees gives back alpha_x, alpha_y and orientation_deg within the sigmas of the fit's report,
// and an isotropic truth measured with the same plan fits alpha_x = alpha_y within theirs.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "gonio/brdf/dataset.h"

namespace {

namespace fs = std::filesystem;

using gonio::testing::run_gonio;

std::string aniso_dir(const std::string& name) {
    return gonio::testing::test_folder("test_tools_aniso", name, false);
}

/// The largest error allowed of a recovered width (relative) and orientation (degrees) on the point campaign's 2-fold plan,
/// whatever the reported sigma.
constexpr double kRelativeCap = 0.05;
constexpr double kAngleCapDeg = 2.0;

struct Param {
    double value = 0;
    double sigma = -1;
};

/// The parameters of a fit report by name.
std::map<std::string, Param> report_params(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    const nlohmann::json j = nlohmann::json::parse(ss.str());
    std::map<std::string, Param> out;
    for (const auto& p : j.at("parameters")) {
        Param q;
        q.value = p.at("value").is_number() ? p.at("value").get<double>() : NAN;
        q.sigma = p.at("sigma").is_number() ? p.at("sigma").get<double>() : -1;
        out[p.at("name").get<std::string>()] = q;
    }
    return out;
}

std::string brushed_model(double ax, double ay, double phi_deg) {
    std::ostringstream m;
    m << R"({"diffuse": [0.05, 0.05, 0.05], "lobes": [{"distribution": "ggx", "alpha_x": )" << ax
      << R"(, "alpha_y": )" << ay << R"(, "orientation_deg": )" << phi_deg
      << R"(, "shadowing": "smith-correlated", "fresnel": {"type": "schlick", "f0": [0.9, 0.9,
         0.9]}, "scale": [1, 1, 1]}]})";
    return m.str();
}

/// Runs the anisotropic campaign of `truth` and fits it; returns the report's parameters.
std::map<std::string, Param> measure_and_fit(const std::string& name,
                                             const std::string& truth,
                                             const std::string& symmetry) {
    const std::string dir = aniso_dir(name);
    const std::string model = dir + "_truth.json";
    std::ofstream(model) << truth;
    int st = 0;
    const std::string acq =
        run_gonio("acquire --anisotropic --symmetry " + symmetry + " --brdf " + model + " --out " +
                      dir + " --n-theta 6 --n-dphi 4 --time-scale 500",
                  &st);
    EXPECT_EQ(st, 0) << acq;
    EXPECT_NE(acq.find("anisotropic"), std::string::npos) << acq;
    // The dataset keeps both azimuths: the light is not always at phi_i = 0.
    auto ds = gonio::brdf::read_dataset_csv(dir + "/dataset.csv");
    if (!ds) {
        ADD_FAILURE() << ds.error().message;
        return {};  // the callers' at() then fails the test instead of reading nothing
    }
    std::size_t off_axis = 0;
    for (const auto& s : ds->samples) {
        off_axis += std::abs(std::sin(s.phi_i)) > 0.3 && s.theta_i > 0.1;
    }
    EXPECT_GT(off_axis, ds->samples.size() / 4);
    const std::string fit =
        run_gonio("fit " + dir + "/dataset.csv --anisotropic --out " + dir + "/fit.json", &st);
    EXPECT_EQ(st, 0) << fit;
    if (st != 0) {
        return {};
    }
    return report_params(dir + "/fit.report.json");
}

/// |a - b| within k sigma, with an orientation compared modulo 180 degrees.
/// Within `k` of the reported sigmas of the truth, and within `cap` of it whatever the sigma (a
/// sigma grown large would otherwise let any value pass): a relative cap for a width, degrees for
/// an angle.
void expect_within(const Param& p, double truth, double k, bool angle, const char* what) {
    ASSERT_GT(p.sigma, 0) << what;
    double d = p.value - truth;
    if (angle) {
        d -= 180 * std::round(d / 180);
    }
    EXPECT_LE(std::abs(d), k * p.sigma)
        << what << " = " << p.value << " +- " << p.sigma << ", truth " << truth;
    const double cap = angle ? kAngleCapDeg : kRelativeCap * std::abs(truth);
    EXPECT_LE(std::abs(d), cap) << what << " = " << p.value << ", truth " << truth
                                << ": off by more than " << cap;
}

void expect_recovered(const std::string& name, double phi_deg) {
    const auto p = measure_and_fit(name, brushed_model(0.08, 0.3, phi_deg), "2-fold");
    const Param ax = p.at("lobes[0].alpha_x");
    const Param ay = p.at("lobes[0].alpha_y");
    const Param phi = p.at("lobes[0].orientation_deg");
    expect_within(ax, 0.08, 4, false, "alpha_x");
    expect_within(ay, 0.3, 4, false, "alpha_y");
    expect_within(phi, phi_deg, 4, true, "orientation_deg");
    // The canonical form and sigmas small enough to tell the lobe apart.
    EXPECT_LE(ax.value, ay.value);
    EXPECT_GE(phi.value, 0);
    EXPECT_LT(phi.value, 180);
    EXPECT_LT(ax.sigma, 0.01);
    EXPECT_LT(ay.sigma, 0.03);
    EXPECT_LT(phi.sigma, 3);
}

TEST(AnisotropicCampaign, BrushedAlongTheSampleAxisIsRecovered) {
    expect_recovered("brushed0", 0);
}

TEST(AnisotropicCampaign, BrushedAt30DegreesIsRecovered) {
    expect_recovered("brushed30", 30);
}

TEST(AnisotropicCampaign, IsotropicTruthFitsEqualSlopes) {
    const auto p = measure_and_fit(
        "iso",
        R"({"diffuse": [0.05, 0.05, 0.05], "lobes": [{"distribution": "ggx", "alpha": 0.15,
            "shadowing": "smith-correlated", "fresnel": {"type": "schlick",
            "f0": [0.9, 0.9, 0.9]}, "scale": [1, 1, 1]}]})",
        "none");
    const Param ax = p.at("lobes[0].alpha_x");
    const Param ay = p.at("lobes[0].alpha_y");
    ASSERT_GT(ax.sigma, 0);
    ASSERT_GT(ay.sigma, 0);
    EXPECT_LE(std::abs(ax.value - ay.value), 4 * std::hypot(ax.sigma, ay.sigma))
        << ax.value << " +- " << ax.sigma << " vs " << ay.value << " +- " << ay.sigma;
    expect_within(ax, 0.15, 4, false, "alpha_x");
}

TEST(AnisotropicCampaign, PlanOnlyFoldsBySymmetry) {
    int st = 0;
    auto count = [&](const std::string& sym) {
        const std::string out = run_gonio(
            "acquire --plan-only --anisotropic --n-theta 4 --n-dphi 4 --symmetry " + sym, &st);
        EXPECT_EQ(st, 0) << out;
        std::size_t planned = 0;
        std::size_t pos = 0;
        while ((pos = out.find("\nplanned,", pos)) != std::string::npos) {
            ++planned;
            ++pos;
        }
        const std::size_t unreachable = [&] {
            std::size_t n = 0, q = 0;
            while ((q = out.find("\nunreachable,", q)) != std::string::npos) {
                ++n;
                ++q;
            }
            return n;
        }();
        EXPECT_NE(out.find("# anisotropic plan"), std::string::npos) << out;
        return planned + unreachable;
    };
    // Burnside's counts of the 19 directions (unit_plan_aniso_test.cpp): 190, 112, 100.
    EXPECT_EQ(count("none"), 190u);
    EXPECT_EQ(count("mirror"), 112u);
    EXPECT_EQ(count("2-fold"), 100u);
}

TEST(AnisotropicCampaign, OptionsThatCannotBeHonouredAreRefused) {
    int st = 0;
    std::string out = run_gonio("acquire --plan-only --symmetry 2-fold", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--symmetry cannot be combined with an isotropic plan"), std::string::npos)
        << out;
    out = run_gonio("acquire --plan-only --anisotropic --plan half-diff", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--plan cannot be combined with --anisotropic"), std::string::npos) << out;
    out = run_gonio("acquire --plan-only --anisotropic --adaptive 2", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--adaptive cannot be combined with --anisotropic"), std::string::npos)
        << out;
    // Image mode measures anisotropic samples with its own 4-D table: no symmetry fold.
    out = run_gonio("acquire --mode image --plan-only --anisotropic --symmetry 2-fold", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--symmetry cannot be combined with --mode image"), std::string::npos)
        << out;
}

}  // namespace
