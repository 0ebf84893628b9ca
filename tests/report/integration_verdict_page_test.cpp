// The headline of a report page in a real browser (headless Chromium, 1280 x 900) says what its
// warnings say: demo-like folders (the demo's red plastic measured with 2 % noise) fitted three
// ways, each giving one of the three verdicts:
//   --model auto      represents these data: no warning of a misfit;
//   --model ggx       usable, with a visible misfit: each finding the headline names has a
//                     visible warning of a visible misfit, none says "does not represent";
//   a retro-reflection peak no lobe follows: does not represent: each finding named has a
//                     visible warning saying so.
// After --model auto the page also shows the ranking: every candidate tried, its error, and which
// won.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../fitting/fit_test_util.h"
#include "browser_support.h"
#include "gonio/brdf/material_library.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"
#include "gonio/fitting/spec.h"
#include "gonio/report/html_report.h"

namespace gonio::report {
namespace {

namespace fs = std::filesystem;

fs::path fresh(const std::string& name) {
    const fs::path d = fs::path(GONIO_BINARY_DIR) / "tests" / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

/// The demo's material on a goniometer's grid with 2 % noise (seed 5).
brdf::Dataset demo_like() {
    Expected<brdf::ModelD> m = brdf::load_material("red-plastic");
    EXPECT_TRUE(m) << m.error().message;
    brdf::Dataset d = fitting::testing::noisy_measurement(*m, 5);
    d.source = "dataset.csv";
    return d;
}

/// The same with a retro-reflection peak added, which no microfacet lobe follows.
brdf::Dataset with_retro_peak(brdf::Dataset d) {
    for (brdf::Sample& s : d.samples) {
        const double c = s.wi().dot(s.wo());
        const double retro = c > 0 ? 20 * std::pow(c, 30) : 0;
        s.value += brdf::Rgbd(retro, 0.5 * retro, 0.2 * retro);
    }
    return d;
}

/// Writes dataset.csv, fit.json and fit.report.json into `dir` and builds the page.
std::string page_of(const brdf::Dataset& data, const fitting::FitResult& fit, const fs::path& dir) {
    EXPECT_TRUE(brdf::write_dataset_csv((dir / "dataset.csv").string(), data));
    EXPECT_TRUE(fitting::write_fit_report((dir / "fit.json").string(), fit));
    ReportOptions o;
    o.preview.size_px = 64;
    o.preview.env_samples = 16;
    Expected<ReportResult> r = build_report(dir.string(), o);
    EXPECT_TRUE(r) << r.error().message;
    return r ? r->html_path : std::string();
}

/// What the reader sees of the verdict and of the automatic choice, recorded by a script in the
/// page after load: the verdict's state, its headline, each warning shown (with whether it is
/// visible: laid out with a size and not hidden), and the ranking's rows.
const char* kVerdictProbe = R"(<script>
(function () {
  function visible(e) {
    var r = e.getBoundingClientRect();
    var s = window.getComputedStyle(e);
    return r.width > 0 && r.height > 0 && s.visibility !== 'hidden' && s.display !== 'none';
  }
  function run() {
    var v = document.getElementById('verdict');
    var facts = {state: v ? v.getAttribute('data-verdict') : '', cls: v ? v.className : '',
                 headline: '', warnings: [], ranking: [], chosen_text: ''};
    if (v) {
      var b = v.querySelector('b');
      facts.headline = b ? b.textContent : '';
      facts.headline_visible = b ? visible(b) : false;
      v.querySelectorAll('ul.warnings li').forEach(function (li) {
        facts.warnings.push({text: li.textContent, visible: visible(li)});
      });
    }
    var a = document.getElementById('auto-choice');
    if (a) {
      facts.chosen_text = a.querySelector('p b:nth-of-type(2)') ?
          a.querySelector('p b:nth-of-type(2)').textContent : '';
      a.querySelectorAll('table.auto-ranking tr').forEach(function (tr, i) {
        if (i === 0) { return; }
        var td = tr.querySelectorAll('td');
        facts.ranking.push({name: td[1].textContent, log_rmse: parseFloat(td[3].textContent),
                            chosen: tr.classList.contains('chosen'), visible: visible(tr)});
      });
    }
    var pre = document.createElement('pre');
    pre.id = 'verdict-facts';
    pre.textContent = JSON.stringify(facts);
    document.body.appendChild(pre);
  }
  if (document.readyState === 'complete') { run(); } else { window.addEventListener('load', run); }
})();
</script>)";

nlohmann::json verdict_facts(const std::string& html_path, const fs::path& work) {
    std::ifstream in(html_path);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string page = ss.str();
    const auto body_end = page.rfind("</body>");
    if (body_end == std::string::npos) {
        return nullptr;
    }
    page.insert(body_end, kVerdictProbe);
    fs::create_directories(work);
    const fs::path probe = work / "probe.html";
    std::ofstream(probe) << page;
    const std::string dom = ::gonio::testing::chromium_dump_dom(
        "file://" + fs::absolute(probe).string(), work / "profile");
    const std::string facts = ::gonio::testing::element_text(dom, "verdict-facts");
    return facts.empty() ? nlohmann::json(nullptr) : nlohmann::json::parse(facts, nullptr, false);
}

/// The findings a headline's list names ("channel b (median relative error 0.09 above 0.05);
/// ..."): split at "; ", each up to its " (".
std::vector<std::string> named_findings(const std::string& list) {
    std::vector<std::string> out;
    std::stringstream ss(list);
    std::string item;
    while (std::getline(ss, item, ';')) {
        const auto b = item.find_first_not_of(' ');
        item = item.substr(b, item.find(" (") - b);
        out.push_back(item);
    }
    return out;
}

/// The headline's state agrees with the visible warnings.
void expect_headline_matches_warnings(const nlohmann::json& f, const std::string& state) {
    ASSERT_TRUE(f.is_object()) << "no facts from Chromium";
    std::printf("verdict facts: %s\n", f.dump().c_str());
    EXPECT_EQ(f["state"], state);
    EXPECT_TRUE(f["headline_visible"].get<bool>());
    const std::string headline = f["headline"];
    const auto warned = [&](const std::string& finding, const std::string& words) {
        for (const nlohmann::json& w : f["warnings"]) {
            const std::string t = w["text"];
            if (w["visible"].get<bool>() && t.find(finding) != std::string::npos &&
                t.find(words) != std::string::npos) {
                return true;
            }
        }
        return false;
    };
    const auto any_warning_says = [&](const std::string& words) { return warned("", words); };
    if (state == "represents") {
        EXPECT_NE(headline.find("represents these data"), std::string::npos) << headline;
        EXPECT_EQ(f["cls"], "verdict ok");
        EXPECT_FALSE(any_warning_says("visible misfit"));
        EXPECT_FALSE(any_warning_says("does not represent"));
        return;
    }
    const bool visible = state == "visible-misfit";
    EXPECT_EQ(f["cls"], visible ? "verdict warn" : "verdict bad");
    const std::string prefix = visible ? "Verdict: usable, with a visible misfit: "
                                       : "Verdict: MISFIT: does not represent these data: ";
    ASSERT_EQ(headline.rfind(prefix, 0), 0u) << headline;
    const std::vector<std::string> findings = named_findings(headline.substr(prefix.size()));
    ASSERT_FALSE(findings.empty()) << headline;
    for (const std::string& finding : findings) {
        EXPECT_TRUE(warned(finding, visible ? "a visible misfit" : "does not represent"))
            << finding << " is named in the headline without its visible warning";
    }
    if (visible) {
        EXPECT_FALSE(any_warning_says("does not represent"));
    }
}

TEST(VerdictPage, AutoFitRepresentsTheDemoMaterialAndShowsItsRanking) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh("verdict_page_auto");
    const brdf::Dataset data = demo_like();
    fitting::FitOptions options = fitting::make_fit_spec({})->options;
    options.num_threads = 1;
    Expected<fitting::AutoFitResult> a = fitting::fit_auto(data, fitting::auto_candidates(options));
    ASSERT_TRUE(a) << a.error().message;
    const nlohmann::json f = verdict_facts(page_of(data, a->best, dir), dir / "browser");
    expect_headline_matches_warnings(f, "represents");
    // Every candidate tried is a visible row with its error; exactly one, the winner, is marked.
    ASSERT_EQ(f["ranking"].size(), a->ranking.size());
    int chosen = 0;
    for (std::size_t i = 0; i < a->ranking.size(); ++i) {
        const nlohmann::json& row = f["ranking"][i];
        EXPECT_EQ(row["name"], a->ranking[i].name);
        EXPECT_NEAR(
            row["log_rmse"].get<double>(), a->ranking[i].log_rmse, 1e-5 * a->ranking[i].log_rmse);
        EXPECT_TRUE(row["visible"].get<bool>());
        if (row["chosen"].get<bool>()) {
            ++chosen;
            EXPECT_EQ(row["name"], a->chosen);
        }
    }
    EXPECT_EQ(chosen, 1);
    EXPECT_EQ(f["chosen_text"], a->chosen);
    EXPECT_GE(a->ranking.size(), 9u);  // four families, two with two lobes, V-groove, table
}

TEST(VerdictPage, DefaultGgxOnTheDemoMaterialNamesItsVisibleMisfit) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh("verdict_page_ggx");
    const brdf::Dataset data = demo_like();
    Expected<fitting::FitResult> r = fitting::fit(data, *fitting::make_fit_spec({}));
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_EQ(r->goodness.verdict, fitting::Verdict::kVisibleMisfit) << r->goodness.headline;
    const nlohmann::json f = verdict_facts(page_of(data, *r, dir), dir / "browser");
    expect_headline_matches_warnings(f, "visible-misfit");
    EXPECT_TRUE(f["ranking"].empty());  // no automatic choice was made
}

TEST(VerdictPage, RetroReflectionThatNoLobeFollowsDoesNotRepresent) {
    GONIO_REQUIRE_CHROMIUM();
    const fs::path dir = fresh("verdict_page_retro");
    const brdf::Dataset data = with_retro_peak(demo_like());
    Expected<fitting::FitResult> r = fitting::fit(data, *fitting::make_fit_spec({}));
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->solver.converged);
    ASSERT_EQ(r->goodness.verdict, fitting::Verdict::kDoesNotRepresent) << r->goodness.headline;
    const nlohmann::json f = verdict_facts(page_of(data, *r, dir), dir / "browser");
    expect_headline_matches_warnings(f, "does-not-represent");
}

}  // namespace
}  // namespace gonio::report
