// The report in a real browser (headless Chromium, 1280 x 900): a point campaign folder and an
// image campaign folder, each with a fit made by gonio's own fitter from data simulated from a
// known model. Every image decodes, nothing is wider than the window, and the first screen holds
// the verdict and the whole parameter table.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "browser_support.h"
#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/resample.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"
#include "gonio/fitting/spec.h"
#include "gonio/report/html_report.h"
#include "test_models.h"

namespace gonio::report {
namespace {

namespace fs = std::filesystem;
using gonio::test_units::kDeg;

fs::path fresh_page_dir(const std::string& name) {
    const fs::path d = fs::path(GONIO_BINARY_DIR) / "tests" / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

/// Fits GGX + Lambert to the data and writes fit.json and fit.report.json into dir.
void fit_into(const brdf::Dataset& data, const fs::path& dir) {
    auto spec = fitting::make_fit_spec(fitting::ModelOptions{});
    ASSERT_TRUE(spec) << spec.error().message;
    spec->options.num_threads = 1;
    spec->options.max_samples = 600;
    auto res = fitting::fit(data, *spec);
    ASSERT_TRUE(res) << res.error().message;
    ASSERT_TRUE(fitting::write_fit_report((dir / "fit.json").string(), *res));
}

/// Point-mode samples of the model: in-plane slices at four theta_i and an azimuthal ring, 2 %
/// noise with matching sigma (seed 7).
brdf::Dataset page_point_samples(const brdf::Brdf& truth) {
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 0.02);
    brdf::Dataset d;
    d.source = "dataset.csv";
    d.has_sigma = true;
    auto add = [&](double ti, double pi, double to, double po) {
        brdf::Sample s;
        s.theta_i = ti * kDeg;
        s.phi_i = pi * kDeg;
        s.theta_o = to * kDeg;
        s.phi_o = po * kDeg;
        const brdf::Rgbd f = truth.eval(s.wi(), s.wo());
        s.value = f * (1.0 + noise(rng));
        s.sigma = 0.02 * f;
        d.samples.push_back(s);
    };
    for (double ti : {10.0, 30.0, 50.0, 70.0}) {
        for (int to = -80; to <= 80; to += 5) {
            add(ti, 0, std::abs(to), to >= 0 ? 180 : 0);
        }
    }
    for (int a = 0; a <= 180; a += 15) {
        add(45, 0, 45, a);
    }
    return d;
}

TEST(ReportPage, PointCampaignLeadsWithTheResultAndFitsTheWindow) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_page_dir("report_page_point");
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    const brdf::Dataset data = page_point_samples(truth);
    ASSERT_TRUE(brdf::write_dataset_csv((dir / "dataset.csv").string(), data));
    std::ofstream(dir / "metadata.json") << R"J({"sample": "red plastic", "operator": "J. Doe",
        "created": "2026-12-01T10:00:00Z", "rig": {"name": "sim4", "description": {"axes": [1, 2]}},
        "calibration": {"white_reflectance": 0.99, "white_rate_counts_per_us": [1.5, 1.6, 1.7]},
        "runs": [{"started": "2026-12-01T10:00:00Z", "ended": "2026-12-01T10:20:00Z",
                  "state": "interrupted", "measured": 80, "pid": 11},
                 {"started": "2026-12-01T11:00:00Z", "ended": "2026-12-01T11:09:00Z",
                  "state": "completed", "measured": 65, "pid": 12}],
        "state": "completed", "measured": 145, "planned": 145})J";
    std::ofstream(dir / "campaign.json")
        << R"J({"sample": "red plastic", "plan": {"kind": "uniform",
        "uniform": {"n_theta": 7, "n_dphi": 5}}, "drift_every": 40})J";
    fit_into(data, dir);
    ReportOptions o;
    o.preview.size_px = 96;
    o.preview.env_samples = 24;
    auto r = build_report(dir.string(), o);
    ASSERT_TRUE(r) << r.error().message;
    std::ifstream in(r->html_path);
    const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // Result first: the verdict and the parameters come before any picture and before the history.
    const auto verdict = html.find("id=\"verdict\"");
    const auto params = html.find("class=\"grid params\"");
    const auto pictures = html.find("id=\"pictures\"");
    const auto history = html.find("id=\"history\"");
    const auto raw = html.find("id=\"raw\"");
    ASSERT_NE(verdict, std::string::npos);
    EXPECT_LT(verdict, params);
    EXPECT_LT(params, pictures);
    EXPECT_LT(pictures, history);
    EXPECT_LT(history, raw);
    // The raw descriptions are folded text, never tables of JSON.
    EXPECT_NE(html.find("<details><summary><code>metadata.json</code>"), std::string::npos);
    EXPECT_EQ(html.find("<table class=\"kv\"><tr><th>description"), std::string::npos);
    EXPECT_NE(html.find("measured 2026-12-01T10:00:00Z to 2026-12-01T11:09:00Z in 2 runs"),
              std::string::npos);
    EXPECT_NE(html.find("@media print"), std::string::npos);
    const nlohmann::json f = ::gonio::testing::page_layout_facts(r->html_path, dir / "browser");
    // in-plane, delta_phi, residuals, preview, coverage.
    ::gonio::testing::expect_report_layout(f, 5);
}

TEST(ReportPage, ImageCampaignShowsCoverageHolesCalibrationAndTheTablesFit) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh_page_dir("report_page_image");
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{30, 30, 60};
    to.threads = 1;
    brdf::TabulatedBrdf table = brdf::tabulate(truth, to);
    // A hole: theta_d above 60 degrees (bins 20 and up) not measured.
    const brdf::TableGrid& g = table.grid();
    for (int ih = 0; ih < g.n_theta_h; ++ih) {
        for (int id = 20; id < g.n_theta_d; ++id) {
            for (int ip = 0; ip < g.n_phi_d; ++ip) {
                table.set_bin_invalid(g.index(ih, id, ip));
            }
        }
    }
    ASSERT_TRUE(brdf::write_merl((dir / "table.gtab").string(), table));
    brdf::Dataset data = brdf::table_to_dataset(table);
    data.has_sigma = true;
    for (brdf::Sample& s : data.samples) {
        s.sigma = 0.01 * s.value;
    }
    ASSERT_GT(data.samples.size(), 1000u);
    ASSERT_TRUE(brdf::write_dataset_csv((dir / "dataset.csv").string(), data));
    std::ofstream(dir / "dataset.json") << R"J({"mode": "image", "sample": "red plastic",
        "rig": "embedded virtual rig (sim-image)",
        "table": {"n_theta_h": 30, "n_theta_d": 30, "n_phi_d": 60, "file": "table.gtab"},
        "calibration_counts_per_us_per_inv_sr": [12.5, 13.1, 9.7], "reference_albedo": 0.99,
        "sphere": {"radius_m": 0.02, "fit_rms_px": 0.21},
        "coverage": {"target": 0.9, "achieved": 0.66, "target_met": false,
                     "stop_reason": "no light position adds enough bins", "valid_bins": 40000,
                     "covered_bins": 26400, "reachable_bins": 30000},
        "pixels": {"on_sphere": 100000, "used": 80000, "saturated": 12},
        "frames": [{"light_arm_deg": 30, "used_pixels": 40000, "saturated_pixels": 0,
                    "exposures": [1, 1, 2], "coverage_after": 0.4},
                   {"light_arm_deg": 60, "used_pixels": 40000, "saturated_pixels": 12,
                    "exposures": [1, 1, 1], "coverage_after": 0.66}],
        "holes": [{"theta_d_deg": [60, 90], "theta_h_deg": [0, 90], "bins": 18000,
                   "reason": "light arm blind zone"}]
})J";
    fit_into(data, dir);
    ReportOptions o;
    o.preview.size_px = 96;
    o.preview.env_samples = 24;
    auto r = build_report(dir.string(), o);
    ASSERT_TRUE(r) << r.error().message;
    for (const std::string& n : r->notes) {
        std::printf("note: %s\n", n.c_str());
    }
    std::ifstream in(r->html_path);
    const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(html.find("image-mode campaign"), std::string::npos);
    EXPECT_NE(html.find("coverage 66.0 % of the valid bins (target 90 %)"), std::string::npos);
    EXPECT_NE(html.find("light arm blind zone"), std::string::npos);
    EXPECT_NE(html.find("12.5, 13.1, 9.7"), std::string::npos);  // calibration constants
    EXPECT_NE(html.find("Light positions in the order measured"), std::string::npos);
    EXPECT_NE(html.find("id=\"coverage\""), std::string::npos);
    EXPECT_TRUE(fs::exists(dir / "plots" / "coverage-map.png"));
    EXPECT_TRUE(fs::exists(dir / "previews" / "table-vs-fit.png"));
    EXPECT_EQ(html.find("No campaign.json"), std::string::npos);
    const nlohmann::json f = ::gonio::testing::page_layout_facts(r->html_path, dir / "browser");
    ::gonio::testing::expect_report_layout(f, 4);
}

}  // namespace
}  // namespace gonio::report
