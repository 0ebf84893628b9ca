#include "gonio/report/html_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/base/atomic_file.h"
#include "gonio/brdf/brdf.h"
#include "gonio/base/limits.h"
#include "gonio/brdf/model_json.h"
#include "gonio/report/image.h"
#include "gonio/version.h"

namespace gonio::report {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

/// Reads a JSON input of the report within the documented limits (size, nesting depth): an error
/// names the file and the limit; a syntax error gives a discarded value (shown as a note).
Expected<json> read_report_json(const fs::path& p) {
    Expected<std::string> text = read_input_file(p.string(), kMaxJsonBytes);
    if (!text) {
        return tl::unexpected(text.error());
    }
    if (auto ok = check_json_text(*text, p.string()); !ok) {
        return tl::unexpected(ok.error());
    }
    return json::parse(*text, nullptr, false);
}

std::string fmt_num(double v) {
    if (!std::isfinite(v)) {
        // Reported as text so that a NaN in an input file stays visible.
        return std::isnan(v) ? "NaN" : (v > 0 ? "+Inf" : "-Inf");
    }
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

std::string scalar_text(const json& j) {
    if (j.is_string()) {
        return j.get<std::string>();
    }
    if (j.is_number_float()) {
        return fmt_num(j.get<double>());
    }
    if (j.is_null()) {
        return "-";
    }
    return j.dump();
}

bool is_scalar(const json& j) {
    return !j.is_object() && !j.is_array();
}

/// Renders any JSON value as nested HTML: objects as key/value tables, arrays of objects as tables
/// with the union of their keys as columns, arrays of scalars as comma lists.
std::string json_html(const json& j, int depth = 0) {
    if (is_scalar(j)) {
        return html_escape(scalar_text(j));
    }
    if (depth > 6) {
        return "<code>" + html_escape(j.dump()) + "</code>";
    }
    std::ostringstream os;
    if (j.is_object()) {
        if (j.empty()) {
            return "{}";
        }
        os << "<table class=\"kv\">";
        for (auto it = j.begin(); it != j.end(); ++it) {
            os << "<tr><th>" << html_escape(it.key()) << "</th><td>" << json_html(*it, depth + 1)
               << "</td></tr>";
        }
        os << "</table>";
        return os.str();
    }
    // Array.
    if (j.empty()) {
        return "[]";
    }
    const bool all_scalar =
        std::all_of(j.begin(), j.end(), [](const json& e) { return is_scalar(e); });
    if (all_scalar) {
        std::string s;
        for (const json& e : j) {
            s += (s.empty() ? "" : ", ") + html_escape(scalar_text(e));
        }
        return s;
    }
    const bool all_objects =
        std::all_of(j.begin(), j.end(), [](const json& e) { return e.is_object(); });
    if (all_objects) {
        std::vector<std::string> cols;
        for (const json& e : j) {
            for (auto it = e.begin(); it != e.end(); ++it) {
                if (std::find(cols.begin(), cols.end(), it.key()) == cols.end()) {
                    cols.push_back(it.key());
                }
            }
        }
        os << "<table class=\"grid\"><tr>";
        for (const std::string& c : cols) {
            os << "<th>" << html_escape(c) << "</th>";
        }
        os << "</tr>";
        for (const json& e : j) {
            os << "<tr>";
            for (const std::string& c : cols) {
                os << "<td>" << (e.contains(c) ? json_html(e[c], depth + 1) : "") << "</td>";
            }
            os << "</tr>";
        }
        os << "</table>";
        return os.str();
    }
    os << "<ol>";
    for (const json& e : j) {
        os << "<li>" << json_html(e, depth + 1) << "</li>";
    }
    os << "</ol>";
    return os.str();
}

std::string img_tag(const Image& img, const std::string& alt) {
    auto png = encode_png(img);
    if (!png) {
        return "<p class=\"note\">" + html_escape(alt + ": " + png.error().message) + "</p>";
    }
    return "<img alt=\"" + html_escape(alt) + "\" src=\"data:image/png;base64," +
           base64_encode(*png) + "\">";
}

std::string figure(const Image& img, const std::string& caption) {
    return "<figure>" + img_tag(img, caption) + "<figcaption>" + html_escape(caption) +
           "</figcaption></figure>\n";
}

std::vector<fs::path> pngs_in(const fs::path& d) {
    std::vector<fs::path> out;
    std::error_code ec;
    if (!fs::is_directory(d, ec)) {
        return out;
    }
    for (const auto& e : fs::directory_iterator(d, ec)) {
        if (e.is_regular_file() && e.path().extension() == ".png") {
            out.push_back(e.path());
        }
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<std::string> split_csv_line(const std::string& line) {
    std::vector<std::string> cells;
    std::string cur;
    bool quoted = false;
    for (char c : line) {
        if (c == '"') {
            quoted = !quoted;
        } else if (c == ',' && !quoted) {
            cells.push_back(cur);
            cur.clear();
        } else if (c != '\r') {
            cur += c;
        }
    }
    cells.push_back(cur);
    return cells;
}

/// Finds calibration and drift records: top-level keys or keys one level down whose name contains
/// "calib" or "drift".
json calibration_and_drift(const json& campaign) {
    json out = json::object();
    if (!campaign.is_object()) {
        return out;
    }
    auto wanted = [](const std::string& k) {
        return k.find("calib") != std::string::npos || k.find("drift") != std::string::npos;
    };
    for (auto it = campaign.begin(); it != campaign.end(); ++it) {
        if (wanted(it.key())) {
            out[it.key()] = *it;
        } else if (it->is_object()) {
            for (auto jt = it->begin(); jt != it->end(); ++jt) {
                if (wanted(jt.key())) {
                    out[it.key() + "." + jt.key()] = *jt;
                }
            }
        }
    }
    return out;
}

std::string fit_section(const json& rep) {
    std::ostringstream os;
    // Goodness of fit first: whether the parameters below mean anything.
    if (rep.contains("goodness") && rep["goodness"].is_object()) {
        const json& g = rep["goodness"];
        const bool usable = rep.contains("solver") && rep["solver"].is_object() &&
                            rep["solver"].value("usable", false);
        os << "<h3>Goodness of fit</h3><p><b>" << (usable ? "usable" : "NOT USABLE") << "</b>";
        if (g.contains("represents") && g["represents"].is_boolean() &&
            !g["represents"].get<bool>()) {
            os << ": the model cannot represent these data";
        }
        os << "</p>\n";
        if (rep.contains("metrics") && rep["metrics"].is_object() &&
            rep["metrics"].contains("log_rmse")) {
            os << "<p>log RMSE (r g b): " << json_html(rep["metrics"]["log_rmse"]);
            if (g.contains("reduced_chi_square") && g["reduced_chi_square"].is_number()) {
                os << "; reduced chi-square " << html_escape(scalar_text(g["reduced_chi_square"]));
            }
            os << "</p>\n";
        }
        if (g.contains("warnings") && g["warnings"].is_array()) {
            for (const json& w : g["warnings"]) {
                os << "<p class=\"note\">warning: " << html_escape(scalar_text(w)) << "</p>\n";
            }
        }
        if (g.contains("suggestion") && g["suggestion"].is_string() &&
            !g["suggestion"].get<std::string>().empty()) {
            os << "<p>suggestion: " << html_escape(g["suggestion"].get<std::string>()) << "</p>\n";
        }
        if (rep.contains("covariance") && rep["covariance"].is_string()) {
            os << "<p>sigmas: " << html_escape(rep["covariance"].get<std::string>()) << "</p>\n";
        }
    }
    if (rep.contains("parameters") && rep["parameters"].is_array()) {
        os << "<table class=\"grid\"><tr><th>parameter</th><th>value</th><th>sigma (1 s.d.)</th>"
              "<th>free</th><th>identifiable</th></tr>";
        for (const json& p : rep["parameters"]) {
            if (!p.is_object()) {
                continue;
            }
            auto field = [&](const char* k) { return p.contains(k) ? p[k] : json(); };
            const json sigma = field("sigma");
            std::string sig =
                sigma.is_number() ? "&plusmn; " + html_escape(scalar_text(sigma)) : "not available";
            os << "<tr><td><code>" << html_escape(scalar_text(field("name"))) << "</code></td><td>"
               << html_escape(scalar_text(field("value"))) << "</td><td>" << sig << "</td><td>"
               << html_escape(scalar_text(field("free"))) << "</td><td>"
               << html_escape(scalar_text(field("identifiable"))) << "</td></tr>";
        }
        os << "</table>\n";
    }
    if (rep.contains("not_identifiable") && !rep["not_identifiable"].empty()) {
        os << "<p>Not identifiable from these data: " << json_html(rep["not_identifiable"])
           << "</p>\n";
    }
    for (const char* k : {"metrics", "samples", "solver"}) {
        if (rep.contains(k)) {
            os << "<h3>" << k << "</h3>" << json_html(rep[k]) << "\n";
        }
    }
    for (const char* k : {"residual", "loss", "data"}) {
        if (rep.contains(k)) {
            os << "<p>" << k << ": " << json_html(rep[k]) << "</p>\n";
        }
    }
    return os.str();
}

const char* kStyle = R"(<style>
body{font-family:sans-serif;max-width:1000px;margin:2em auto;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.4em 0}th,td{border:1px solid #ccc;padding:.2em .5em;
text-align:left;vertical-align:top;font-size:.92em}table.kv>tbody>tr>th,table.kv>tr>th{background:#f4f4f4}
table.grid th{background:#eef}figure{margin:1em 0}img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#555}.note{color:#a40}code{font-size:.95em}
</style>)";

}  // namespace

std::string html_escape(const std::string& s) {
    std::string o;
    o.reserve(s.size());
    for (char c : s) {
        switch (c) {
            case '&':
                o += "&amp;";
                break;
            case '<':
                o += "&lt;";
                break;
            case '>':
                o += "&gt;";
                break;
            case '"':
                o += "&quot;";
                break;
            case '\'':
                o += "&#39;";
                break;
            default:
                o += c;
        }
    }
    return o;
}

Expected<ReportResult> build_report(const std::string& dir, const ReportOptions& options) {
    std::error_code ec;
    const fs::path root(dir);
    if (!fs::is_directory(root, ec)) {
        return make_error(dir + ": not a folder");
    }
    ReportResult result;
    std::vector<std::string>& notes = result.notes;
    const fs::path data_path = root / "dataset.csv";
    const fs::path campaign_path = root / "campaign.json";
    const fs::path metadata_path = root / "metadata.json";
    const fs::path fit_path = root / "fit.json";
    const fs::path fit_report_path = root / "fit.report.json";
    if (!fs::exists(data_path) && !fs::exists(campaign_path) && !fs::exists(fit_path)) {
        return make_error(
            dir + ": neither dataset.csv, campaign.json nor fit.json: not a campaign folder");
    }

    // Campaign metadata.
    json campaign;
    if (fs::exists(campaign_path)) {
        Expected<json> j = read_report_json(campaign_path);
        if (!j) {
            return tl::unexpected(j.error());
        }
        campaign = std::move(*j);
        if (campaign.is_discarded()) {
            notes.push_back(campaign_path.string() + ": not valid JSON; metadata not shown");
            campaign = json();
        }
    } else {
        notes.push_back(campaign_path.string() + ": missing; no campaign metadata");
    }

    json metadata;
    if (fs::exists(metadata_path)) {
        Expected<json> j = read_report_json(metadata_path);
        if (!j) {
            return tl::unexpected(j.error());
        }
        metadata = std::move(*j);
        if (metadata.is_discarded()) {
            notes.push_back(metadata_path.string() + ": not valid JSON; run metadata not shown");
            metadata = json();
        }
    }

    // Dataset; drift-reference rows are kept apart.
    std::unique_ptr<brdf::Dataset> data;
    std::vector<brdf::Sample> references;
    if (fs::exists(data_path)) {
        auto d = brdf::read_dataset_csv(data_path.string());
        if (d) {
            for (const brdf::Sample& s : d->samples) {
                if (s.flags & brdf::kFlagReference) {
                    references.push_back(s);
                }
            }
            data = std::make_unique<brdf::Dataset>(without_reference_rows(*d));
        } else {
            notes.push_back(d.error().message);
        }
    } else {
        notes.push_back(data_path.string() + ": missing; no coverage, no plots");
    }

    // Fit.
    std::unique_ptr<brdf::Brdf> fit;
    std::string model_summary;
    if (fs::exists(fit_path)) {
        auto b = brdf::load_brdf(fit_path.string());
        if (b) {
            fit = std::move(*b);
            model_summary = fit->describe();
        } else {
            notes.push_back(b.error().message);
        }
    }
    json fit_report;
    if (fs::exists(fit_report_path)) {
        Expected<json> j = read_report_json(fit_report_path);
        if (!j) {
            return tl::unexpected(j.error());
        }
        fit_report = std::move(*j);
        if (fit_report.is_discarded()) {
            notes.push_back(fit_report_path.string() + ": not valid JSON");
            fit_report = json();
        }
    }

    // Plots and previews: generate what is missing.
    const fs::path plots_dir = root / "plots";
    const fs::path previews_dir = root / "previews";
    if (data && !data->samples.empty() && (options.regenerate || pngs_in(plots_dir).empty())) {
        auto set = write_plots(*data, fit.get(), options.plot, plots_dir.string());
        if (!set) {
            notes.push_back("plots: " + set.error().message);
        } else {
            for (const WrittenPlot& w : set->written) {
                result.generated.push_back(w.path);
            }
            for (const std::string& s : set->skipped) {
                notes.push_back("plot skipped: " + s);
            }
        }
    }
    if (fit && (options.regenerate || pngs_in(previews_dir).empty())) {
        fs::create_directories(previews_dir, ec);
        auto sheet = preview_sheet(*fit, "fit: " + fit->describe(), nullptr, "", options.preview);
        const std::string p = (previews_dir / "fit.png").string();
        if (!sheet) {
            notes.push_back("preview: " + sheet.error().message);
        } else if (auto w = write_png(p, *sheet); !w) {
            notes.push_back(w.error().message);
        } else {
            result.generated.push_back(p);
        }
    }

    // The page.
    std::ostringstream h;
    std::string title = "gonio campaign report";
    if (campaign.is_object()) {
        for (const char* k : {"sample", "material", "name"}) {
            if (campaign.contains(k)) {
                const json& v = campaign[k];
                title += ": " + (v.is_object() && v.contains("name")
                                     ? scalar_text(v["name"])
                                     : (is_scalar(v) ? scalar_text(v) : std::string()));
                break;
            }
        }
    }
    std::time_t now = std::time(nullptr);
    char when[64];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
      << html_escape(title) << "</title>" << kStyle << "</head><body>\n";
    h << "<h1>" << html_escape(title) << "</h1>\n<p>Folder <code>" << html_escape(dir)
      << "</code>; page written " << when << " by gonio " << GONIO_VERSION_STRING << ".</p>\n";

    h << "<h2 id=\"metadata\">Campaign metadata</h2>\n";
    auto without_calibration = [](const json& j) {
        json shown = j;
        if (j.is_object()) {
            for (auto it = j.begin(); it != j.end(); ++it) {
                const std::string& k = it.key();
                if (k.find("calib") != std::string::npos || k.find("drift") != std::string::npos) {
                    shown.erase(k);
                }
            }
        }
        return shown;
    };
    if (!campaign.is_null()) {
        h << "<h3>Description (campaign.json)</h3>\n"
          << json_html(without_calibration(campaign)) << "\n";
    } else {
        h << "<p class=\"note\">No campaign.json.</p>\n";
    }
    if (!metadata.is_null()) {
        h << "<h3>Runs (metadata.json)</h3>\n" << json_html(without_calibration(metadata)) << "\n";
    }

    h << "<h2 id=\"coverage\">Coverage of the angular domain</h2>\n";
    if (data) {
        h << "<p>" << data->samples.size() << " samples read from <code>dataset.csv</code>";
        if (!references.empty()) {
            h << " (besides " << references.size() << " drift-reference rows)";
        }
        if (!data->rejected.empty()) {
            h << "; " << data->rejected.size() << " rows rejected (first: line "
              << data->rejected.front().line << ", " << html_escape(data->rejected.front().reason)
              << ")";
        }
        h << ".</p>\n";
        auto cov = plot_coverage(*data, options.plot);
        if (cov) {
            h << figure(*cov, "Measured directions: outgoing directions and (theta_h, theta_d)");
        } else {
            h << "<p class=\"note\">" << html_escape(cov.error().message) << "</p>\n";
        }
    } else {
        h << "<p class=\"note\">No dataset.</p>\n";
    }

    h << "<h2 id=\"calibration\">Calibration and drift</h2>\n";
    json cal = calibration_and_drift(campaign);
    const json run_cal = calibration_and_drift(metadata);
    for (auto it = run_cal.begin(); it != run_cal.end(); ++it) {
        cal[it.key() + (cal.contains(it.key()) ? " (run)" : "")] = *it;
    }
    if (cal.empty()) {
        h << "<p class=\"note\">No calibration or drift settings in campaign.json or "
             "metadata.json.</p>\n";
    } else {
        h << json_html(cal) << "\n";
    }
    if (!references.empty()) {
        const double y0 = luminance(references.front().value);
        h << "<h3>Drift reference re-measurements</h3>\n<p>The same configuration measured "
             "again during the campaign (rows flagged as reference in dataset.csv), in file "
             "order.</p>\n<table class=\"grid\"><tr><th>#</th><th>theta_i [deg]</th>"
             "<th>theta_o [deg]</th><th>luminance Y [1/sr]</th><th>sigma Y</th><th>ratio to "
             "first</th></tr>";
        for (std::size_t i = 0; i < references.size(); ++i) {
            const brdf::Sample& s = references[i];
            const double y = luminance(s.value);
            h << "<tr><td>" << i + 1 << "</td><td>" << fmt_num(s.theta_i * 180 / brdf::kPi)
              << "</td><td>" << fmt_num(s.theta_o * 180 / brdf::kPi) << "</td><td>" << fmt_num(y)
              << "</td><td>" << fmt_num(luminance_sigma(s.sigma)) << "</td><td>"
              << (y0 > 0 ? fmt_num(y / y0) : std::string("-")) << "</td></tr>";
        }
        h << "</table>\n";
    }

    h << "<h2 id=\"fit\">Fit</h2>\n";
    if (!model_summary.empty()) {
        h << "<p>Model (<code>fit.json</code>): " << html_escape(model_summary) << "</p>\n";
    }
    if (fit_report.is_object()) {
        h << fit_section(fit_report);
    } else {
        h << "<p class=\"note\">No fit.report.json.</p>\n";
    }

    h << "<h2 id=\"plots\">Plots</h2>\n";
    const auto plots = pngs_in(plots_dir);
    if (plots.empty()) {
        h << "<p class=\"note\">No plots.</p>\n";
    }
    for (const fs::path& p : plots) {
        auto img = read_png(p.string());
        if (img) {
            h << figure(*img, "plots/" + p.filename().string());
        } else {
            notes.push_back(img.error().message);
        }
    }
    h << "<h2 id=\"previews\">Previews</h2>\n";
    const auto previews = pngs_in(previews_dir);
    if (previews.empty()) {
        h << "<p class=\"note\">No previews.</p>\n";
    }
    for (const fs::path& p : previews) {
        auto img = read_png(p.string());
        if (img) {
            h << figure(*img, "previews/" + p.filename().string());
        } else {
            notes.push_back(img.error().message);
        }
    }

    const fs::path bench_path = root / "bench" / "runtime_vs_error.csv";
    if (fs::exists(bench_path)) {
        h << "<h2 id=\"runtime\">Run time against error</h2>\n<table class=\"grid\">";
        std::ifstream f(bench_path);
        std::string line;
        bool header = true;
        while (std::getline(f, line)) {
            if (line.empty() || line[0] == '#') {
                continue;
            }
            h << "<tr>";
            for (const std::string& c : split_csv_line(line)) {
                h << (header ? "<th>" : "<td>") << html_escape(c) << (header ? "</th>" : "</td>");
            }
            h << "</tr>";
            header = false;
        }
        h << "</table>\n";
    }

    if (!notes.empty()) {
        h << "<h2 id=\"notes\">Notes</h2>\n<ul>";
        for (const std::string& n : notes) {
            h << "<li>" << html_escape(n) << "</li>";
        }
        h << "</ul>\n";
    }
    h << "</body></html>\n";

    const fs::path out = root / "report.html";
    if (auto w = write_file_atomic(out.string(), h.str()); !w) {
        return tl::unexpected(w.error());
    }
    result.html_path = out.string();
    return result;
}

}  // namespace gonio::report
