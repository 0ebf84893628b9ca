#pragma once

// Headless Chromium for page tests: a copy of a page with a script that writes layout facts into
// the DOM after load (images decoded, elements wider than the viewport, where the verdict and the
// parameter table end), read back from --dump-dom. Chromium runs with a fresh profile folder, no
// sandbox (root in CI), no network services, a 1280 x 900 window.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>

namespace gonio::testing {

inline bool have_chromium() {
    return std::system("command -v chromium > /dev/null 2>&1") == 0;
}

/// Skips the test (fails it when CI=true) without Chromium.
#define GONIO_REQUIRE_CHROMIUM()                                                      \
    do {                                                                              \
        if (!::gonio::testing::have_chromium()) {                                     \
            const char* ci = std::getenv("CI");                                       \
            if (ci != nullptr && std::string(ci) == "true") {                         \
                FAIL() << "chromium is not installed (scripts/setup.sh installs it)"; \
            }                                                                         \
            GTEST_SKIP() << "chromium is not installed; page tests skipped";          \
        }                                                                             \
    } while (0)

/// The DOM of `url` after its scripts ran (virtual time budget in ms).
inline std::string chromium_dump_dom(const std::string& url,
                                     const std::filesystem::path& profile,
                                     int budget_ms = 5000) {
    std::filesystem::create_directories(profile);
    const std::string cmd =
        "chromium --headless --no-sandbox --disable-gpu --disable-background-networking "
        "--disable-component-update --no-first-run --user-data-dir=" +
        profile.string() +
        " --window-size=1280,900 --virtual-time-budget=" + std::to_string(budget_ms) +
        " --dump-dom '" + url + "' 2>/dev/null";
    std::string out;
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) {
        return out;
    }
    char buf[65536];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) {
        out.append(buf, n);
    }
    pclose(p);
    return out;
}

/// The text of the element with this id in a dumped DOM, HTML entities of text decoded.
inline std::string element_text(const std::string& dom, const std::string& id) {
    const std::string open = "id=\"" + id + "\">";
    const auto a = dom.find(open);
    if (a == std::string::npos) {
        return {};
    }
    const auto start = a + open.size();
    const auto end = dom.find("</", start);
    std::string t = dom.substr(start, end - start);
    std::string o;
    const std::pair<const char*, char> entities[] = {
        {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&nbsp;", ' '}};
    for (std::size_t i = 0; i < t.size(); ++i) {
        bool decoded = false;
        for (const auto& [ent, ch] : entities) {
            const std::size_t n = std::strlen(ent);
            if (t.compare(i, n, ent) == 0) {
                o += ch;
                i += n - 1;
                decoded = true;
                break;
            }
        }
        if (!decoded) {
            o += t[i];
        }
    }
    return o;
}

/// The script that records the layout facts (in a <pre id="layout-facts">, as JSON).
inline const char* layout_probe_script() {
    return R"(<script>
(function () {
  function run() {
    var vw = document.documentElement.clientWidth;
    var imgs = Array.prototype.slice.call(document.images);
    var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); }).length;
    var wide = [];
    document.querySelectorAll('body *').forEach(function (e) {
      var r = e.getBoundingClientRect();
      if (r.width > 0 && (r.right > vw + 0.5 || r.left < -0.5)) {
        wide.push(e.tagName + (e.id ? '#' + e.id : '') + ' right ' + Math.round(r.right));
      }
    });
    var v = document.getElementById('verdict');
    var p = document.querySelector('table.params');
    var facts = {
      viewport: vw, screen_height: window.innerHeight,
      scroll_width: document.documentElement.scrollWidth,
      images: imgs.length, images_broken: broken,
      too_wide: wide.slice(0, 10), too_wide_count: wide.length,
      verdict_bottom: v ? v.getBoundingClientRect().bottom : -1,
      verdict_text: v ? v.textContent : '',
      params_bottom: p ? p.getBoundingClientRect().bottom : -1,
      params_rows: p ? p.rows.length : 0,
      height: document.documentElement.scrollHeight
    };
    var pre = document.createElement('pre');
    pre.id = 'layout-facts';
    pre.textContent = JSON.stringify(facts);
    document.body.appendChild(pre);
  }
  if (document.readyState === 'complete') { run(); } else { window.addEventListener('load', run); }
})();
</script>)";
}

/// Loads a copy of the page with the probe in Chromium and returns the facts (null on failure).
inline nlohmann::json page_layout_facts(const std::filesystem::path& html,
                                        const std::filesystem::path& work) {
    std::ifstream in(html);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string page = ss.str();
    const auto body_end = page.rfind("</body>");
    if (body_end == std::string::npos) {
        return nullptr;
    }
    page.insert(body_end, layout_probe_script());
    std::filesystem::create_directories(work);
    const std::filesystem::path probe = work / "probe.html";
    std::ofstream(probe) << page;
    const std::string dom =
        chromium_dump_dom("file://" + std::filesystem::absolute(probe).string(), work / "profile");
    const std::string facts = element_text(dom, "layout-facts");
    if (facts.empty()) {
        return nullptr;
    }
    return nlohmann::json::parse(facts, nullptr, false);
}

/// The assertions every report page must meet in a 1280 x 900 window.
inline void expect_report_layout(const nlohmann::json& f, std::size_t min_images) {
    ASSERT_TRUE(f.is_object()) << "no layout facts from Chromium";
    std::printf("layout: %s\n", f.dump().c_str());
    // The window is 1280 px wide; the vertical scroll bar takes its share.
    EXPECT_GE(f["viewport"].get<int>(), 1250);
    EXPECT_LE(f["viewport"].get<int>(), 1280);
    EXPECT_GE(f["images"].get<std::size_t>(), min_images);
    EXPECT_EQ(f["images_broken"].get<int>(), 0) << "an image did not decode";
    EXPECT_EQ(f["too_wide_count"].get<int>(), 0) << f["too_wide"].dump();
    EXPECT_LE(f["scroll_width"].get<int>(), 1280);
    // The first screen holds the verdict and the whole parameter table.
    EXPECT_GT(f["verdict_bottom"].get<double>(), 0);
    EXPECT_LE(f["verdict_bottom"].get<double>(), f["screen_height"].get<double>());
    EXPECT_GT(f["params_rows"].get<int>(), 1);
    EXPECT_LE(f["params_bottom"].get<double>(), f["screen_height"].get<double>());
    EXPECT_NE(f["verdict_text"].get<std::string>().find("Verdict"), std::string::npos);
}

}  // namespace gonio::testing
