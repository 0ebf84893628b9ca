// The campaign report: one self-contained page with the embedded pictures, the metadata, the
// calibration and drift records, the fit table with uncertainties and the run-time table.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model_json.h"
#include "gonio/fitting/report.h"
#include "gonio/report/html_report.h"
#include "test_models.h"

namespace gonio::report {
namespace {

namespace fs = std::filesystem;
using gonio::test_units::kDeg;

void write(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream f(p);
    f << text;
}

std::size_t count(const std::string& s, const std::string& what) {
    std::size_t n = 0;
    for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) {
        ++n;
    }
    return n;
}

/// Base64 decoding of the first `n` characters (for checking the embedded PNG signature).
std::vector<unsigned char> b64_decode(const std::string& s) {
    std::vector<unsigned char> out;
    unsigned val = 0;
    int bits = -8;
    for (char c : s) {
        const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        const char* p = std::strchr(table, c);
        if (c == '=' || p == nullptr || c == '\0') {
            break;
        }
        val = ((val << 6) | static_cast<unsigned>(p - table)) & 0xFFFFFFu;
        bits += 6;
        if (bits >= 0) {
            out.push_back(static_cast<unsigned char>((val >> bits) & 0xFF));
            bits -= 8;
        }
    }
    return out;
}

fs::path make_campaign(const std::string& name) {
    const fs::path dir = fs::path(GONIO_BINARY_DIR) / "tests" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    const brdf::ModelD model = testing::every_model_type()[0].second;
    const brdf::AnalyticBrdf truth(model);
    brdf::Dataset d;
    d.has_sigma = true;
    for (int ti = 10; ti <= 60; ti += 25) {
        for (int to = 0; to <= 80; to += 5) {
            for (int p = 0; p <= 180; p += 45) {
                brdf::Sample s;
                s.theta_i = ti * kDeg;
                s.theta_o = to * kDeg;
                s.phi_o = p * kDeg;
                s.value = truth.eval(s.wi(), s.wo());
                s.sigma = 0.02 * s.value;
                d.samples.push_back(s);
            }
        }
    }
    // Two drift-reference rows: the lamp lost 3 %.
    d.has_flags = true;
    for (double factor : {1.0, 0.97}) {
        brdf::Sample s;
        s.theta_i = 30 * kDeg;
        s.theta_o = 30 * kDeg;
        s.phi_o = brdf::kPi;
        s.value = truth.eval(s.wi(), s.wo()) * factor;
        s.flags = brdf::kFlagReference;
        d.samples.push_back(s);
    }
    EXPECT_TRUE(brdf::write_dataset_csv((dir / "dataset.csv").string(), d));
    write(dir / "campaign.json",
          R"({"sample": {"name": "red <paint> & co"}, "operator": "J. Doe",
              "rig": {"name": "bench-2", "calibration": {"white_reference": 0.987}},
              "drift": [{"t_s": 0, "ratio": 1.0}, {"t_s": 600, "ratio": 0.994}],
              "software": "gonio 0.1.0"})");
    write(dir / "fit.json", brdf::model_to_json(model));
    // The report as the fitter writes it.
    fitting::FitResult fr;
    fr.model = model;
    fitting::FittedParameter ax;
    ax.name = "lobes[0].alpha_x";
    ax.value = 0.0801;
    ax.sigma = 0.0012;
    ax.free = true;
    fitting::FittedParameter kd;
    kd.name = "diffuse[0]";
    kd.value = 0.05;
    kd.free = true;
    kd.identifiable = false;
    fr.parameters = {ax, kd};
    fr.not_identifiable = {"diffuse[0]"};
    fr.metrics.rmse = brdf::Rgbd(0.1, 0.2, 0.3);
    fr.metrics.rel_rmse = brdf::Rgbd(0.01, 0.02, 0.03);
    fr.metrics.log_rmse = brdf::Rgbd(0.004, 0.005, 0.006);
    fr.samples.input = fr.samples.valid = fr.samples.used = 255;
    fr.solver.iterations = 17;
    fr.solver.termination = "CONVERGENCE";
    fr.solver.message = "ok";
    fr.solver.converged = true;
    fr.solver.usable = true;
    fr.solver.wall_time_s = 0.42;
    fr.data = "dataset.csv";
    write(dir / "fit.report.json", fitting::fit_report_json(fr));
    write(dir / "bench" / "runtime_vs_error.csv",
          "samples,wall_time_s,log_rmse\n100,0.11,0.031\n1000,0.93,0.0123\n");
    return dir;
}

TEST(HtmlReport, SelfContainedPageWithEverySection) {
    const fs::path dir = make_campaign("report_campaign");
    ReportOptions o;
    o.preview.size_px = 64;
    o.preview.env_samples = 24;
    auto r = build_report(dir.string(), o);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(fs::path(r->html_path), dir / "report.html");
    // Missing plots and the preview were drawn.
    for (const char* f :
         {"plots/in_plane.png", "plots/delta_phi.png", "plots/residuals.png", "previews/fit.png"}) {
        EXPECT_TRUE(fs::exists(dir / f)) << f;
    }
    std::ifstream in(r->html_path);
    const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // Coverage + 3 plots + 1 preview, all embedded; no external reference.
    EXPECT_EQ(count(html, "src=\"data:image/png;base64,"), 5u);
    EXPECT_EQ(count(html, "src=\"http"), 0u);
    EXPECT_EQ(count(html, "href="), 0u);
    const auto p = html.find("base64,") + 7;
    const auto bytes = b64_decode(html.substr(p, 16));
    ASSERT_GE(bytes.size(), 8u);
    EXPECT_EQ(bytes[0], 0x89);
    EXPECT_EQ(bytes[1], 'P');
    EXPECT_EQ(bytes[2], 'N');
    EXPECT_EQ(bytes[3], 'G');
    // Metadata (escaped), calibration and drift, the fit table, the run-time table.
    EXPECT_NE(html.find("red &lt;paint&gt; &amp; co"), std::string::npos);
    EXPECT_NE(html.find("J. Doe"), std::string::npos);
    EXPECT_NE(html.find("white_reference"), std::string::npos);
    EXPECT_NE(html.find("0.994"), std::string::npos);
    EXPECT_NE(html.find("Drift reference re-measurements"), std::string::npos);
    EXPECT_NE(html.find("<td>0.97</td></tr>"), std::string::npos);
    EXPECT_NE(html.find("besides 2 drift-reference rows"), std::string::npos);
    EXPECT_NE(html.find("lobes[0].alpha_x"), std::string::npos);
    EXPECT_NE(html.find("0.0801"), std::string::npos);
    EXPECT_NE(html.find("&plusmn; 0.0012"), std::string::npos);
    EXPECT_NE(html.find("not available"), std::string::npos);
    EXPECT_NE(html.find("CONVERGENCE"), std::string::npos);
    EXPECT_NE(html.find("<th>wall_time_s</th>"), std::string::npos);
    EXPECT_NE(html.find("<td>0.0123</td>"), std::string::npos);
}

TEST(HtmlReport, ToleratesMissingAndBrokenInputs) {
    const fs::path dir = make_campaign("report_campaign_partial");
    fs::remove(dir / "fit.json");
    fs::remove(dir / "fit.report.json");
    fs::remove_all(dir / "bench");
    write(dir / "campaign.json", "{ not json");
    ReportOptions o;
    auto r = build_report(dir.string(), o);
    ASSERT_TRUE(r) << r.error().message;
    std::ifstream in(r->html_path);
    const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(html.find("campaign.json: not valid JSON"), std::string::npos);
    EXPECT_NE(html.find("No fit.report.json"), std::string::npos);
    // Coverage, in-plane and delta_phi plots; no residuals and no preview without a fit.
    EXPECT_EQ(count(html, "src=\"data:image/png;base64,"), 3u);
    EXPECT_FALSE(fs::exists(dir / "previews"));
}

TEST(HtmlReport, FitReportIsReadStrictlyAndARefusedOneGivesNoVerdict) {
    const fs::path dir = make_campaign("report_campaign_bad_fit");
    // A report whose solver record carries a misspelt key: the strict reader names it, the page
    // shows no verdict from it, and the rest of the page is still drawn.
    std::ifstream in0(dir / "fit.report.json");
    std::string text((std::istreambuf_iterator<char>(in0)), std::istreambuf_iterator<char>());
    const auto at = text.find("\"usable\"");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, 8, "\"usabel\"");
    write(dir / "fit.report.json", text);
    ReportOptions o;
    o.preview.size_px = 32;
    o.preview.env_samples = 8;
    auto r = build_report(dir.string(), o);
    ASSERT_TRUE(r) << r.error().message;
    std::ifstream in(r->html_path);
    const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(html.find("Verdict: none"), std::string::npos);
    EXPECT_EQ(html.find("Verdict: fit usable"), std::string::npos);
    EXPECT_NE(html.find("solver.usabel"), std::string::npos) << "the key path is named";
    EXPECT_EQ(html.find("&plusmn; 0.0012"), std::string::npos);
    // The dataset's pictures are still there.
    EXPECT_GE(count(html, "src=\"data:image/png;base64,"), 3u);
}

TEST(HtmlReport, NotACampaignFolderIsAnError) {
    const fs::path dir = fs::path(GONIO_BINARY_DIR) / "tests" / "report_not_a_campaign";
    fs::remove_all(dir);
    fs::create_directories(dir);
    auto r = build_report(dir.string());
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("not a campaign folder"), std::string::npos);
    EXPECT_FALSE(build_report((dir / "missing").string()));
}

}  // namespace
}  // namespace gonio::report
