// The verdict of `gonio fit` agrees with what it shows: one headline with three states decided per
// channel, the same in the summary, the report JSON, the model file and the exit status under
// --strict, printed once; suggestions that never name what was used (after --model auto: the
// measurement itself as a table, with that table's error); a misfit's verdict carried into its
// export; f0 = 1 exported with a stated mapping instead of a conductor of eta 4e12.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "../fitting/fit_test_util.h"
#include "cli_run.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/material_library.h"

namespace {

using gonio::brdf::Rgbd;
using gonio::testing::CliRun;
using gonio::testing::read_text;
using gonio::testing::run_gonio;

std::string verdict_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("integration_fit_verdict").string();
    return d;
}

/// The demo's material (Ngan 2005 red plastic: Beckmann + V-groove), noise-free on the grid.
std::string red_plastic() {
    const std::string path = verdict_dir() + "/red_plastic.csv";
    auto m = gonio::brdf::load_material("red-plastic");
    EXPECT_TRUE(m) << m.error().message;
    gonio::brdf::Dataset d =
        gonio::fitting::testing::synthesize(*m, gonio::fitting::testing::measurement_grid());
    EXPECT_TRUE(gonio::brdf::write_dataset_csv(path, d));
    return path;
}

/// A retro-reflection peak that no microfacet lobe at the mirror direction follows.
std::string retro() {
    const std::string path = verdict_dir() + "/retro.csv";
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = Rgbd(0.3, 0.3, 0.3);
    gonio::brdf::Dataset d =
        gonio::fitting::testing::synthesize(m, gonio::fitting::testing::measurement_grid());
    for (gonio::brdf::Sample& s : d.samples) {
        const double c = s.wi().dot(s.wo());
        const double peak = c > 0 ? 20 * std::pow(c, 30) : 0;
        s.value += Rgbd(peak, 0.5 * peak, 0.2 * peak);
    }
    EXPECT_TRUE(gonio::brdf::write_dataset_csv(path, d));
    return path;
}

nlohmann::json report_of(const std::string& model_path) {
    return nlohmann::json::parse(
        read_text(model_path.substr(0, model_path.size() - 5) + ".report.json"));
}

std::size_t count(const std::string& text, const std::string& piece) {
    std::size_t n = 0;
    for (std::size_t at = text.find(piece); at != std::string::npos;
         at = text.find(piece, at + 1)) {
        ++n;
    }
    return n;
}

TEST(GonioFit, AVisibleMisfitOfADarkChannelIsTheHeadlineNotUsableAndRepresents) {
    const std::string data = red_plastic();
    const std::string out = verdict_dir() + "/ggx.json";
    CliRun r = run_gonio("fit " + data + " --model ggx --out " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    const nlohmann::json rep = report_of(out);
    // The blue channel's relative error is above 0.05: the headline says so, naming it.
    ASSERT_GT(rep["metrics"]["median_rel"][2].get<double>(), 0.05);
    EXPECT_EQ(rep["goodness"]["verdict"], "visible-misfit");
    const std::string headline = rep["goodness"]["headline"];
    EXPECT_NE(headline.find("visible misfit"), std::string::npos) << headline;
    EXPECT_NE(headline.find("channel b"), std::string::npos) << headline;
    EXPECT_NE(r.out.find("verdict: " + headline), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("represents these data"), std::string::npos) << r.out;
    // The model file carries the same headline.
    const nlohmann::json model = nlohmann::json::parse(read_text(out));
    EXPECT_EQ(model["fit"]["headline"], headline);
    EXPECT_EQ(model["fit"]["verdict"], "visible-misfit");
    // A visible misfit is usable: --strict does not fail it.
    EXPECT_EQ(run_gonio("fit " + data + " --model ggx --strict").status, 0);
    // The family that fits it: the headline is then "represents".
    const std::string out_b = verdict_dir() + "/beckmann.json";
    CliRun b = run_gonio("fit " + data + " --model beckmann --shadowing v-groove --out " + out_b);
    ASSERT_EQ(b.status, 0) << b.out;
    EXPECT_EQ(report_of(out_b)["goodness"]["verdict"], "represents");
    EXPECT_NE(b.out.find("verdict: represents these data"), std::string::npos) << b.out;
    EXPECT_EQ(b.out.find("suggestion:"), std::string::npos) << b.out;
}

TEST(GonioFit, AMisfitIsPrintedOnceAndStrictFailsIt) {
    const std::string data = retro();
    const std::string err = verdict_dir() + "/once.stderr";
    CliRun r = run_gonio("fit " + data + " --model ggx", err);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(count(r.out, "MISFIT"), 1u) << r.out;
    EXPECT_EQ(count(r.out, "verdict:"), 1u) << r.out;
    // No request line unless asked for; a fit without --out says nothing was written and how.
    EXPECT_EQ(r.out.find("request:"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("nothing written: give --out FILE.json"), std::string::npos) << r.out;
    CliRun v = run_gonio("fit " + data + " --model ggx --verbose");
    EXPECT_NE(v.out.find("request: model=ggx;"), std::string::npos) << v.out;
    CliRun strict = run_gonio("fit " + data + " --model ggx --strict", err);
    EXPECT_EQ(strict.status, 1) << strict.out;
    EXPECT_NE(strict.out.find("--strict: the model does not represent these data"),
              std::string::npos)
        << strict.out;
}

TEST(GonioFit, SuggestionsNeverNameWhatWasUsed) {
    const std::string data = retro();
    struct Case {
        std::string options;
        std::string never;
    };
    for (const Case& c : {Case{"--lobes 2", "--lobes 2"},
                          Case{"--fresnel schlick-rgb", "schlick-rgb"},
                          Case{"--roughness rgb", "--roughness rgb"},
                          Case{"--model beckmann", "--model beckmann"},
                          Case{"--model student-t", "--model student-t"}}) {
        const std::string out = verdict_dir() + "/suggest.json";
        CliRun r = run_gonio("fit " + data + " " + c.options + " --out " + out);
        ASSERT_EQ(r.status, 0) << r.out;
        const nlohmann::json rep = report_of(out);
        ASSERT_NE(rep["goodness"]["verdict"], "represents") << c.options;
        const std::string s = rep["goodness"]["suggestion"];
        EXPECT_FALSE(s.empty()) << c.options;
        EXPECT_EQ(s.find(c.never), std::string::npos) << c.options << ": " << s;
    }
}

TEST(GonioFit, AfterModelAutoTheSuggestionIsTheMeasurementAsATableWithItsError) {
    const std::string data = retro();
    const std::string out = verdict_dir() + "/auto.json";
    CliRun r = run_gonio("fit " + data + " --model auto --out " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    const nlohmann::json rep = report_of(out);
    ASSERT_EQ(rep["goodness"]["verdict"], "does-not-represent") << r.out;
    const std::string s = rep["goodness"]["suggestion"];
    EXPECT_EQ(s.find("--model auto"), std::string::npos) << s;
    EXPECT_NE(s.find("gonio convert " + data + " table.gtab --grid 32x16x8"), std::string::npos)
        << s;
    // The table's own error, a number, smaller than the best family's.
    const std::size_t at = s.find("log RMSE against these data is ");
    ASSERT_NE(at, std::string::npos) << s;
    const double table_error = std::stod(s.substr(at + 31));
    double family_error = 0;
    for (const auto& v : rep["metrics"]["log_rmse"]) {
        family_error += v.get<double>() / 3;
    }
    EXPECT_GT(table_error, 0);
    EXPECT_LT(table_error, family_error) << s;
}

TEST(GonioFit, AnExportOfAMisfitCarriesItsVerdictAndWarns) {
    const std::string data = retro();
    const std::string model = verdict_dir() + "/misfit.json";
    ASSERT_EQ(run_gonio("fit " + data + " --model ggx --out " + model).status, 0);
    for (const std::string to : {"mitsuba", "pbrt"}) {
        const std::string out = verdict_dir() + "/misfit." + (to == "mitsuba" ? "xml" : "pbrt");
        const std::string err = verdict_dir() + "/export.stderr";
        CliRun r = run_gonio("export " + model + " --to " + to + " --out " + out, err);
        ASSERT_EQ(r.status, 0) << r.out;
        EXPECT_NE(r.out.find("warning: " + model + ": the fit's verdict is \"MISFIT"),
                  std::string::npos)
            << r.out;
        const std::string text = read_text(out);
        EXPECT_NE(text.find("gonio fit verdict: MISFIT: does not represent these data"),
                  std::string::npos)
            << text;
    }
    // A fit that represents its data exports without either.
    const std::string good = verdict_dir() + "/good.json";
    ASSERT_EQ(
        run_gonio("fit " + red_plastic() + " --model beckmann --shadowing v-groove --out " + good)
            .status,
        0);
    CliRun g = run_gonio("export " + good + " --to mitsuba --out " + verdict_dir() + "/good.xml");
    ASSERT_EQ(g.status, 0) << g.out;
    EXPECT_EQ(g.out.find("warning:"), std::string::npos) << g.out;
    EXPECT_EQ(read_text(verdict_dir() + "/good.xml").find("gonio fit verdict"), std::string::npos);
}

TEST(GonioExport, SchlickF0OfOneIsMappedToAConductorWithItsReasonNotEta4e12) {
    const std::string model = verdict_dir() + "/mirror.json";
    std::ofstream(model) << R"({"diffuse": [0.1, 0.1, 0.1], "lobes": [{"distribution": "ggx",
        "alpha": 0.1, "shadowing": "smith-correlated", "fresnel": {"type": "schlick", "f0": [1, 0.5, 1]}, "scale": [1, 1, 1]}]})";
    const std::string out = verdict_dir() + "/mirror.xml";
    const std::string err = verdict_dir() + "/mirror.stderr";
    CliRun r = run_gonio("export " + model + " --to mitsuba --out " + out, err);
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string text = read_text(out);
    EXPECT_EQ(text.find("e+12"), std::string::npos) << text;
    EXPECT_NE(text.find("<rgb name=\"eta\" value=\"1, 1, 1\"/>"), std::string::npos) << text;
    // k = 2 sqrt(f0) / sqrt(1 - f0): 1e4 where f0 = 1, 2 where f0 = 0.5; F(0) = k^2 / (4 + k^2).
    const std::string k_key = "<rgb name=\"k\" value=\"";
    const std::size_t k_at = text.find(k_key);
    ASSERT_NE(k_at, std::string::npos) << text;
    std::istringstream k(text.substr(k_at + k_key.size()));
    double k0, k1, k2;
    char comma;
    k >> k0 >> comma >> k1 >> comma >> k2;
    EXPECT_NEAR(k0, 1e4, 1e-6);
    EXPECT_NEAR(k1 * k1 / (4 + k1 * k1), 0.5, 1e-9);
    EXPECT_NE(r.out.find("reaches 1, which no dielectric index gives"), std::string::npos) << r.out;
}

}  // namespace
