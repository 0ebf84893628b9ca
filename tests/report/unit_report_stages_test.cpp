// The campaign report built stage by stage gives the page it gave before its builder was split
// into stages: a point campaign folder (runs, drift references, calibration, run-time table, a
// broken description) and an image campaign folder (table, holes, light positions) are built and
// compared with the pages recorded from the single-function builder (tests/data/report/), with
// what may change between runs masked: the embedded pictures and their sizes (drawn by the plots),
// the time the page was written (and when its files were), the folder's path, and the verdict, the
// model and fit.report.json (owned by the fit report's format, tested in
// unit_html_report_test.cpp).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/resample.h"
#include "gonio/fitting/report.h"
#include "gonio/report/html_report.h"
#include "test_models.h"

namespace gonio::report {
namespace {

namespace fs = std::filesystem;
using gonio::test_units::kDeg;

void write(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
}

std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

fs::path fresh_stages_dir(const std::string& name) {
    const fs::path dir = fs::path(GONIO_BINARY_DIR) / "tests" / ("report_stages_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

/// Samples of the model on a grid, with sigma; `references` drift rows at the end.
brdf::Dataset samples_of(const brdf::Brdf& b, bool references) {
    brdf::Dataset d;
    d.has_sigma = true;
    for (int ti = 10; ti <= 60; ti += 25) {
        for (int to = 0; to <= 80; to += 10) {
            for (int p = 0; p <= 180; p += 90) {
                brdf::Sample s;
                s.theta_i = ti * kDeg;
                s.theta_o = to * kDeg;
                s.phi_o = p * kDeg;
                s.value = b.eval(s.wi(), s.wo());
                s.sigma = 0.02 * s.value;
                d.samples.push_back(s);
            }
        }
    }
    if (references) {
        d.has_flags = true;
        for (double factor : {1.0, 0.97}) {
            brdf::Sample s;
            s.theta_i = 30 * kDeg;
            s.theta_o = 30 * kDeg;
            s.phi_o = brdf::kPi;
            s.value = b.eval(s.wi(), s.wo()) * factor;
            s.flags = brdf::kFlagReference;
            d.samples.push_back(s);
        }
    }
    return d;
}

/// The fit report as the fitter writes it.
std::string fit_report(const brdf::ModelD& model) {
    fitting::FitResult fr;
    fr.model = model;
    fitting::FittedParameter ax;
    ax.name = "lobes[0].alpha_x";
    ax.value = 0.0801;
    ax.sigma = 0.0012;
    ax.free = true;
    fr.parameters = {ax};
    fr.metrics.log_rmse = brdf::Rgbd(0.004, 0.005, 0.006);
    fr.samples.input = fr.samples.valid = fr.samples.used = 81;
    fr.solver.iterations = 17;
    fr.solver.termination = "CONVERGENCE";
    fr.solver.converged = true;
    fr.solver.usable = true;
    fr.data = "dataset.csv";
    return fitting::fit_report_json(fr);
}

fs::path point_campaign() {
    const fs::path dir = fresh_stages_dir("point");
    const brdf::ModelD model = testing::every_model_type()[0].second;
    const brdf::AnalyticBrdf truth(model);
    EXPECT_TRUE(brdf::write_dataset_csv((dir / "dataset.csv").string(), samples_of(truth, true)));
    write(dir / "campaign.json",
          R"({"sample": {"name": "red <paint> & co"}, "operator": "J. Doe",
              "rig": {"name": "bench-2", "calibration": {"white_reference": 0.987}},
              "drift": [{"t_s": 0, "ratio": 1.0}, {"t_s": 600, "ratio": 0.994}]})");
    write(dir / "metadata.json",
          R"({"sample": "red paint", "planned": 83, "measured": 83, "state": "completed",
              "operator": "J. Doe", "rig": {"name": "bench-2"}, "pose_repeats": 1,
              "device_outages": 0, "drift_reference": {"ratio": 0.97},
              "runs": [{"started": "2026-12-06T09:00:00Z", "ended": "2026-12-06T09:05:00Z",
                        "state": "paused", "measured": 40},
                       {"started": "2026-12-06T09:10:00Z", "ended": "2026-12-06T09:14:00Z",
                        "state": "completed", "measured": 43}]})");
    write(dir / "dataset.json", "{ not json");
    write(dir / "fit.json", brdf::model_to_json(model));
    write(dir / "fit.report.json", fit_report(model));
    write(dir / "bench" / "runtime_vs_error.csv",
          "# made by the runtime study\nsamples,wall_time_s,log_rmse\n100,0.11,0.031\n"
          "1000,0.93,\"0.0123\"\n");
    return dir;
}

fs::path image_campaign() {
    const fs::path dir = fresh_stages_dir("image");
    const brdf::ModelD model = testing::every_model_type()[0].second;
    const brdf::AnalyticBrdf truth(model);
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{15, 15, 30};
    to.threads = 2;
    EXPECT_TRUE(brdf::write_merl((dir / "table.gtab").string(), brdf::tabulate(truth, to)));
    EXPECT_TRUE(brdf::write_dataset_csv((dir / "dataset.csv").string(), samples_of(truth, false)));
    write(dir / "dataset.json",
          R"({"mode": "image", "sample": "sphere of red paint", "rig": "sim-image",
              "ground_truth": "material:red-plastic",
              "table": {"file": "table.gtab", "grid": [15, 15, 30]},
              "coverage": {"achieved": 0.62, "target": 0.6, "stop_reason": "coverage target met"},
              "calibration_counts_per_us_per_inv_sr": [1.5, 1.6, 1.7],
              "reference_albedo": 0.99, "exposure_time_s": 0.0010003,
              "holes": [{"theta_h_deg": [80, 90], "theta_d_deg": [0, 10], "bins": 12,
                         "reason": "beyond the grazing limit"}, "junk"],
              "frames": [{"light_arm_deg": 30, "used_pixels": 1200, "saturated_pixels": 0,
                          "exposures": [100, 120, 140], "coverage_after": 0.3},
                         {"light_arm_deg": 60, "used_pixels": 1100, "saturated_pixels": 3,
                          "exposures": [90, 110, 130], "coverage_after": 0.62}]})");
    write(dir / "fit.json", brdf::model_to_json(model));
    return dir;
}

/// The page with what may change between runs masked.
std::string masked(std::string page, const fs::path& dir) {
    const std::string png = "data:image/png;base64,";
    for (auto p = page.find(png); p != std::string::npos; p = page.find(png, p + 3)) {
        const auto end = page.find('"', p);
        page.replace(p, end - p, "IMG");
    }
    page = std::regex_replace(
        page, std::regex("page written [^<]* by gonio [^<]*\\."), "page written WHEN.");
    for (auto p = page.find(dir.string()); p != std::string::npos; p = page.find(dir.string(), p)) {
        page.replace(p, dir.string().size(), "DIR");
    }
    // The pictures' sizes are the plots' business.
    page = std::regex_replace(page, std::regex(" width=\"[0-9]+\" height=\"[0-9]+\""), "");
    // When a file was written, as the facts may quote it.
    page =
        std::regex_replace(page,
                           std::regex("written [0-9]{4}-[0-9]{2}-[0-9]{2} [0-9]{2}:[0-9]{2} UTC"),
                           "written WHEN");
    // The verdict and the model: from the verdict to the end of the result.
    const auto v = page.find("<div id=\"verdict\"");
    const auto e = page.find("</header>");
    if (v != std::string::npos && e != std::string::npos && e > v) {
        page.replace(v, e - v, "RESULT");
    }
    const auto r = page.find("<details><summary><code>fit.report.json");
    if (r != std::string::npos) {
        page.replace(r, page.find("</details>", r) + 10 - r, "FIT REPORT");
    }
    return page;
}

void expect_recorded_page(const fs::path& dir, const std::string& recorded) {
    auto r = build_report(dir.string());
    ASSERT_TRUE(r) << r.error().message;
    const std::string page = masked(read(r->html_path), dir);
    write(dir.parent_path() / (dir.filename().string() + ".masked.html"), page);
    const std::string expected =
        read(fs::path(GONIO_SOURCE_DIR) / "tests" / "data" / "report" / recorded);
    ASSERT_FALSE(expected.empty()) << recorded;
    EXPECT_EQ(page, expected) << "the page differs from " << recorded << "; this run's is "
                              << dir.string() << ".masked.html";
}

TEST(ReportStages, PointCampaignPageIsTheRecordedOne) {
    expect_recorded_page(point_campaign(), "point_campaign.masked.html");
}

TEST(ReportStages, ImageCampaignPageIsTheRecordedOne) {
    expect_recorded_page(image_campaign(), "image_campaign.masked.html");
}

}  // namespace
}  // namespace gonio::report
