#include "gonio/report/html_report.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/fitting/report.h"
#include "gonio/fitting/spec.h"
#include "gonio/report/blender_report.h"
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

/// A duration for people: "1.0 ms", "0.42 s", "2.1 min".
std::string duration_text(double s) {
    if (!std::isfinite(s) || s < 0) {
        return fmt_num(s) + " s";
    }
    char buf[40];
    if (s < 1) {
        std::snprintf(buf, sizeof buf, "%.2g ms", 1000 * s);
    } else if (s < 120) {
        std::snprintf(buf, sizeof buf, "%.3g s", s);
    } else {
        std::snprintf(buf, sizeof buf, "%.3g min", s / 60);
    }
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

std::string img_tag(const Image& img, const std::string& alt) {
    auto png = encode_png(img);
    if (!png) {
        return "<p class=\"note\">" + html_escape(alt + ": " + png.error().message) + "</p>";
    }
    return "<img alt=\"" + html_escape(alt) + "\" width=\"" + std::to_string(img.width) +
           "\" height=\"" + std::to_string(img.height) + "\" src=\"data:image/png;base64," +
           base64_encode(*png) + "\">";
}

std::string figure(const Image& img, const std::string& id, const std::string& caption) {
    return "<figure id=\"" + html_escape(id) + "\">" + img_tag(img, caption) + "<figcaption>" +
           html_escape(caption) + "</figcaption></figure>\n";
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

/// Flattens JSON into (dotted key path, text) rows: scalars as text, arrays of scalars as comma
/// lists, empty containers as "[]" / "{}", arrays of objects as "n entries" (shown whole in the
/// raw descriptions). Never nested tables.
void flatten(const json& j,
             const std::string& prefix,
             std::vector<std::pair<std::string, std::string>>& out) {
    if (is_scalar(j)) {
        out.push_back({prefix, scalar_text(j)});
        return;
    }
    if (j.is_object()) {
        if (j.empty()) {
            out.push_back({prefix, "{}"});
        }
        for (auto it = j.begin(); it != j.end(); ++it) {
            flatten(*it, prefix.empty() ? it.key() : prefix + "." + it.key(), out);
        }
        return;
    }
    const bool all_scalar =
        std::all_of(j.begin(), j.end(), [](const json& e) { return is_scalar(e); });
    if (j.empty() || all_scalar) {
        std::string s;
        for (const json& e : j) {
            s += (s.empty() ? "" : ", ") + scalar_text(e);
        }
        out.push_back({prefix, j.empty() ? "[]" : s});
        return;
    }
    out.push_back({prefix, std::to_string(j.size()) + " entries (see the raw descriptions)"});
}

/// A two-column table of flattened key paths.
std::string kv_table(const std::vector<std::pair<std::string, std::string>>& rows) {
    std::ostringstream os;
    os << "<table class=\"kv\">";
    for (const auto& [k, v] : rows) {
        os << "<tr><th>" << html_escape(k) << "</th><td>" << html_escape(v) << "</td></tr>";
    }
    os << "</table>\n";
    return os.str();
}

/// A folded raw description: the file's JSON, indented, as text.
std::string raw_details(const std::string& name, const json& j) {
    if (j.is_null()) {
        return {};
    }
    return "<details><summary><code>" + html_escape(name) + "</code></summary><pre>" +
           html_escape(j.dump(2)) + "</pre></details>\n";
}

/// Calibration and drift records: top-level keys or keys one level down whose name contains
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

const json* member(const json& j, const char* key) {
    if (j.is_object() && j.contains(key)) {
        return &j[key];
    }
    return nullptr;
}

std::string text_of(const json& j, const char* key, const std::string& fallback = {}) {
    const json* v = member(j, key);
    return v != nullptr && is_scalar(*v) && !v->is_null() ? scalar_text(*v) : fallback;
}

/// "r g b" of a three-number array, else the scalar text.
std::string rgb_text(const json& j) {
    if (j.is_array()) {
        std::string s;
        for (const json& e : j) {
            s += (s.empty() ? "" : " ") + scalar_text(e);
        }
        return s;
    }
    return scalar_text(j);
}

std::string rgb_text(const brdf::Rgbd& v) {
    return fmt_num(v[0]) + " " + fmt_num(v[1]) + " " + fmt_num(v[2]);
}

/// The verdict of the fit report (read strictly by fitting::read_fit_report): usable or not,
/// whether the model represents the data, the figures the verdict rests on, the warnings and the
/// suggestion.
std::string verdict_block(const fitting::FitResult& rep) {
    std::ostringstream os;
    // The one headline of the fit (fitting/fit.h, Verdict), as `gonio fit` prints it.
    const bool converged = rep.solver.converged;
    const fitting::Verdict v = rep.goodness.verdict;
    const char* cls = !converged || v == fitting::Verdict::kDoesNotRepresent ? "bad"
                      : v == fitting::Verdict::kVisibleMisfit                ? "warn"
                                                                             : "ok";
    os << "<div id=\"verdict\" class=\"verdict " << cls << "\" data-verdict=\""
       << (converged ? fitting::to_string(v) : "not-converged") << "\"><p><b>Verdict: "
       << html_escape(converged ? rep.goodness.headline : "the fit did NOT converge") << "</b>";
    os << " (solver " << html_escape(rep.solver.termination.empty() ? "-" : rep.solver.termination)
       << ", " << rep.solver.iterations << " iterations, " << duration_text(rep.solver.wall_time_s)
       << ")</p>\n";
    if (!rep.solver.converged && !rep.solver.message.empty()) {
        os << "<p>Solver: " << html_escape(rep.solver.message) << "</p>\n";
    }
    // The figures the verdict rests on (fitting/fit.h, GoodnessOfFit).
    std::string line = "log RMSE " + rgb_text(rep.metrics.log_rmse) + "; median relative error " +
                       rgb_text(rep.metrics.median_rel);
    if (rep.goodness.reduced_chi_square) {
        line += "; reduced chi-square " + fmt_num(*rep.goodness.reduced_chi_square);
    }
    os << "<p>" << html_escape(line) << "</p>\n";
    if (!rep.goodness.warnings.empty()) {
        os << "<ul class=\"warnings\">";
        for (const std::string& w : rep.goodness.warnings) {
            os << "<li>warning: " << html_escape(w) << "</li>";
        }
        os << "</ul>\n";
    }
    if (!rep.goodness.suggestion.empty()) {
        os << "<p>Suggestion: " << html_escape(rep.goodness.suggestion) << "</p>\n";
    }
    os << "</div>\n";
    return os.str();
}

/// The fitted model: parameters with uncertainties, the error metrics (each named with what it
/// measures) and the samples used.
std::string model_block(const fitting::FitResult& rep, const std::string& model_summary) {
    std::ostringstream os;
    os << "<div id=\"model\">";
    if (!model_summary.empty()) {
        os << "<p>Fitted model: <code>" << html_escape(model_summary) << "</code></p>\n";
    }
    if (!rep.parameters.empty()) {
        os << "<table class=\"grid params\"><tr><th>parameter</th><th>value</th>"
              "<th>uncertainty (1 s.d.)</th><th>status</th></tr>";
        for (const fitting::FittedParameter& p : rep.parameters) {
            std::string status;
            if (!p.free) {
                status = "fixed";
            } else if (!p.identifiable) {
                status = "not identifiable from these data";
            }
            if (!p.at_bound.empty()) {
                status +=
                    (status.empty() ? "" : "; ") + std::string("at its ") + p.at_bound + " bound";
            }
            os << "<tr><td><code>" << html_escape(p.name) << "</code></td><td>"
               << html_escape(fmt_num(p.value)) << "</td><td>"
               << (p.sigma ? "&plusmn; " + html_escape(fmt_num(*p.sigma))
                           : std::string("not available"))
               << "</td><td>" << html_escape(status.empty() ? "ok" : status) << "</td></tr>";
        }
        os << "</table>\n";
    }
    os << "<p class=\"metrics\"><b>log RMSE</b> (r g b) "
       << html_escape(rgb_text(rep.metrics.log_rmse))
       << " &mdash; per channel, the rms difference of ln(1 + f cos&theta;<sub>i</sub>) "
          "between data and fit over the valid samples. Relative RMSE (r g b) "
       << html_escape(rgb_text(rep.metrics.rel_rmse)) << ". RMSE (r g b) "
       << html_escape(rgb_text(rep.metrics.rmse)) << " 1/sr.</p>\n";
    os << "<p>Samples: " << rep.samples.used << " used of " << rep.samples.input << " read ("
       << rep.samples.rejected << " rejected); residual " << fitting::to_string(rep.residual)
       << ", loss " << fitting::to_string(rep.loss) << ", uncertainties by "
       << html_escape(rep.covariance_method.empty() ? "-" : rep.covariance_method) << ".</p>\n";
    os << "</div>\n";
    return os.str();
}

/// How `--model auto` chose the model: every candidate tried, its error and criterion, the
/// winner marked (fitting::AutoChoice, the report's "auto" key).
std::string auto_choice_block(const fitting::AutoChoice& a) {
    std::ostringstream os;
    os << "<div id=\"auto-choice\"><p><b>Model chosen automatically</b> (<code>--model "
          "auto</code>): <b>"
       << html_escape(a.chosen) << "</b> of " << a.ranking.size() << " candidates, ranked by "
       << html_escape(a.criterion) << ".</p>\n";
    os << "<table class=\"grid auto-ranking\"><tr><th>rank</th><th>model</th><th>free "
          "parameters</th><th>log RMSE (channel mean)</th><th>BIC</th><th></th></tr>";
    for (std::size_t i = 0; i < a.ranking.size(); ++i) {
        const fitting::RankedModel& m = a.ranking[i];
        const bool chosen = m.name == a.chosen;
        os << "<tr" << (chosen ? " class=\"chosen\"" : "") << "><td>" << i + 1 << "</td><td><code>"
           << html_escape(m.name) << "</code></td><td>" << m.parameters << "</td><td>"
           << html_escape(fmt_num(m.log_rmse)) << "</td><td>" << html_escape(fmt_num(m.criterion))
           << "</td><td>"
           << (chosen        ? "chosen"
               : m.converged ? ""
                             : "not ranked (did not converge)")
           << "</td></tr>";
    }
    os << "</table></div>\n";
    return os.str();
}

/// Caption of a known picture: what it shows, in the report's words and units.
std::string caption_for(const std::string& file) {
    if (file == "in_plane.png") {
        return "In-plane slices: BRDF luminance Y [1/sr] against theta_o in the plane of "
               "incidence, measured (markers, +-1 sigma) and fit (curves); the radius scale is "
               "stated under the plot.";
    }
    if (file == "delta_phi.png") {
        return "Azimuthal slices: BRDF luminance Y [1/sr] against delta_phi at fixed theta_i, "
               "theta_o.";
    }
    if (file == "residuals.png") {
        return "Residual map: mean of log10(Y measured / Y fit) per 5-degree (theta_h, theta_d) "
               "bin. Its rms (in the subtitle) is a decimal log of the luminance ratio over all "
               "samples; the log RMSE above is per channel, natural log of 1 + f cos theta_i, so "
               "the two figures differ.";
    }
    return file;
}

const char* kStyle = R"(<style>
*{box-sizing:border-box}
body{font-family:sans-serif;max-width:1000px;margin:1.2em auto;padding:0 1em;color:#222;line-height:1.35}
h1{font-size:1.5em;margin:.2em 0}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.4em}
table{border-collapse:collapse;margin:.4em 0;max-width:100%;table-layout:fixed}
th,td{border:1px solid #ccc;padding:.15em .45em;text-align:left;vertical-align:top;font-size:.9em;
overflow-wrap:anywhere}
table.kv{width:100%}table.kv th{background:#f4f4f4;width:34%;font-weight:normal}
table.grid th{background:#eef}table.params{width:100%}
figure{margin:1em 0;break-inside:avoid}img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444}.note{color:#a40}code{font-size:.95em;overflow-wrap:anywhere}
.facts{margin:.2em 0 .6em}.verdict{border-left:6px solid #2a2;padding:.2em .8em;background:#f3fbf3}
.verdict.bad{border-color:#c22;background:#fdf2f2}.verdict.warn{border-color:#d80;background:#fdf8ee}.warnings{margin:.2em 0;color:#a40}
pre{white-space:pre-wrap;overflow-wrap:anywhere;font-size:.8em;background:#f7f7f7;padding:.5em}
details{margin:.3em 0}summary{cursor:pointer}
@media print{body{max-width:none;margin:0}details{display:block}details>pre{display:block}
h2{break-after:avoid}.verdict{-webkit-print-color-adjust:exact;print-color-adjust:exact}}
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

namespace {

/// Reads an optional JSON input: null when missing, a note when not valid JSON.
Expected<json> read_optional_json(const fs::path& p, std::vector<std::string>& notes) {
    if (!fs::exists(p)) {
        return json();
    }
    Expected<json> j = read_report_json(p);
    if (!j) {
        return tl::unexpected(j.error());
    }
    if (j->is_discarded()) {
        notes.push_back(p.string() + ": not valid JSON; not shown");
        return json();
    }
    return std::move(*j);
}

std::string file_time_text(const fs::path& p) {
    std::error_code ec;
    const auto t = fs::last_write_time(p, ec);
    if (ec) {
        return {};
    }
    const auto sys = std::chrono::time_point_cast<std::chrono::system_clock::duration>(
        t - fs::file_time_type::clock::now() + std::chrono::system_clock::now());
    const std::time_t tt = std::chrono::system_clock::to_time_t(sys);
    char buf[64];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&tt));
    return buf;
}

/// Holes listed in an image campaign's dataset.json.
std::vector<TableHole> holes_of(const json& ds) {
    std::vector<TableHole> out;
    const json* h = member(ds, "holes");
    if (h == nullptr || !h->is_array()) {
        return out;
    }
    auto range = [](const json& e, const char* k, double& lo, double& hi) {
        if (e.contains(k) && e[k].is_array() && e[k].size() == 2 && e[k][0].is_number() &&
            e[k][1].is_number()) {
            lo = e[k][0].get<double>();
            hi = e[k][1].get<double>();
            return true;
        }
        return false;
    };
    for (const json& e : *h) {
        TableHole t;
        if (!e.is_object() || !range(e, "theta_h_deg", t.theta_h_min_deg, t.theta_h_max_deg) ||
            !range(e, "theta_d_deg", t.theta_d_min_deg, t.theta_d_max_deg)) {
            continue;
        }
        t.reason = text_of(e, "reason");
        out.push_back(t);
    }
    return out;
}
/// What a report folder holds, read once: the JSON descriptions, the samples, the table of an
/// image campaign, the fit, and where the pictures are.
struct ReportInputs {
    fs::path root;
    fs::path data_path, campaign_path, metadata_path, dataset_json_path, fit_path, fit_report_path;
    fs::path plots_dir, previews_dir;
    json campaign, metadata, dataset_meta, fit_report;
    std::optional<fitting::FitResult> fit_result;
    bool image_mode = false;
    std::unique_ptr<brdf::Dataset> data;
    std::vector<brdf::Sample> references;  ///< Drift-reference rows, kept apart from the data.
    std::unique_ptr<brdf::Brdf> table_brdf;
    const brdf::TabulatedBrdf* table = nullptr;
    std::unique_ptr<brdf::Brdf> fit;
    std::string model_summary;
    /// A fit of a data file (gonio fit FILE --out DIR/fit.json): a folder with a fit and its report
    /// but no campaign. The page is that fit's, drawn from the file its report names.
    bool file_fit = false;
    std::string data_file;  ///< As fit.report.json names it.
};

/// The folder's JSON descriptions. The verdict and the parameters come from the strict reader of
/// fit reports: a report it refuses is named in the notes with the key path, and no verdict is
/// drawn from it.
Expected<void> read_descriptions(ReportInputs& in, std::vector<std::string>& notes) {
    Expected<json> campaign = read_optional_json(in.campaign_path, notes);
    Expected<json> metadata = read_optional_json(in.metadata_path, notes);
    Expected<json> dataset_meta = read_optional_json(in.dataset_json_path, notes);
    Expected<json> fit_report = read_optional_json(in.fit_report_path, notes);
    if (fit_report && fit_report->is_object()) {
        Expected<fitting::FitResult> r = fitting::read_fit_report(in.fit_report_path.string());
        if (r) {
            in.fit_result = std::move(*r);
        } else {
            notes.push_back(r.error().message + "; no verdict drawn from it");
        }
    }
    for (const Expected<json>* j : {&campaign, &metadata, &dataset_meta, &fit_report}) {
        if (!*j) {
            return tl::unexpected(j->error());
        }
    }
    in.campaign = std::move(*campaign);
    in.metadata = std::move(*metadata);
    in.dataset_meta = std::move(*dataset_meta);
    in.fit_report = std::move(*fit_report);
    in.image_mode = in.dataset_meta.is_object() && text_of(in.dataset_meta, "mode") == "image";
    return {};
}

/// The data file a fit of a file names: as named (relative to the current folder), else beside
/// the fit; "" when neither exists.
std::string find_data_file(const ReportInputs& in) {
    std::error_code ec;
    const fs::path named(in.data_file);
    for (const fs::path& p : {named, in.root / named, in.root / named.filename()}) {
        if (fs::is_regular_file(p, ec)) {
            return p.string();
        }
    }
    return {};
}

/// The samples of the data file a fit of a file names (a dataset, a table or an RGL material).
void read_file_samples(ReportInputs& in, std::vector<std::string>& notes) {
    const std::string path = find_data_file(in);
    if (path.empty()) {
        notes.push_back(in.fit_report_path.string() + ": data = \"" + in.data_file +
                        "\": not found (as named, nor in this folder); no plots");
        return;
    }
    auto d = brdf::load_samples(path);
    if (!d) {
        notes.push_back(d.error().message);
        return;
    }
    in.data = std::make_unique<brdf::Dataset>(without_reference_rows(*d));
}

/// The samples of dataset.csv; drift-reference rows are kept apart.
void read_samples(ReportInputs& in, std::vector<std::string>& notes) {
    if (in.file_fit) {
        read_file_samples(in, notes);
        return;
    }
    if (!fs::exists(in.data_path)) {
        notes.push_back(in.data_path.string() + ": missing; no coverage, no plots");
        return;
    }
    auto d = brdf::read_dataset_csv(in.data_path.string());
    if (!d) {
        notes.push_back(d.error().message);
        return;
    }
    for (const brdf::Sample& s : d->samples) {
        if (s.flags & brdf::kFlagReference) {
            in.references.push_back(s);
        }
    }
    in.data = std::make_unique<brdf::Dataset>(without_reference_rows(*d));
}

/// The table of an image campaign (dataset.json's table.file, a plain name in the folder).
void read_table(ReportInputs& in, std::vector<std::string>& notes) {
    if (!in.image_mode) {
        return;
    }
    const json* t = member(in.dataset_meta, "table");
    const std::string file = t != nullptr ? text_of(*t, "file") : std::string();
    if (file.empty() || file.find('/') != std::string::npos) {
        notes.push_back(in.dataset_json_path.string() + ": table.file missing or not a plain name");
    } else if (auto b = brdf::load_brdf((in.root / file).string()); b) {
        in.table_brdf = std::move(*b);
        in.table = dynamic_cast<const brdf::TabulatedBrdf*>(in.table_brdf.get());
    } else {
        notes.push_back(b.error().message);
    }
}

/// The fitted model of fit.json.
void read_fit(ReportInputs& in, std::vector<std::string>& notes) {
    if (!fs::exists(in.fit_path)) {
        return;
    }
    auto b = brdf::load_brdf(in.fit_path.string());
    if (b) {
        in.fit = std::move(*b);
        in.model_summary = in.fit->describe();
    } else {
        notes.push_back(b.error().message);
    }
}

/// The plots of the dataset, when missing (or all of them with `regenerate`).
void draw_missing_plots(const ReportInputs& in,
                        const ReportOptions& options,
                        ReportResult& result) {
    if (!in.data || in.data->samples.empty() ||
        !(options.regenerate || pngs_in(in.plots_dir).empty())) {
        return;
    }
    auto set = write_plots(*in.data, in.fit.get(), options.plot, in.plots_dir.string());
    if (!set) {
        result.notes.push_back("plots: " + set.error().message);
        return;
    }
    for (const WrittenPlot& w : set->written) {
        result.generated.push_back(w.path);
    }
    for (const std::string& s : set->skipped) {
        result.notes.push_back("plot skipped: " + s);
    }
}

/// The sphere preview of the fit, when missing (or with `regenerate`): measurement against fit
/// when the measurement is a table, else the fit alone.
void draw_missing_preview(const ReportInputs& in,
                          const ReportOptions& options,
                          ReportResult& result) {
    if (!in.fit || !(options.regenerate || pngs_in(in.previews_dir).empty())) {
        return;
    }
    std::error_code ec;
    fs::create_directories(in.previews_dir, ec);
    const brdf::Brdf& fit = *in.fit;
    auto sheet = in.table != nullptr
                     ? preview_sheet(*in.table,
                                     "measured: " + in.table->describe(),
                                     &fit,
                                     "fit: " + fit.describe(),
                                     options.preview)
                     : preview_sheet(fit, "fit: " + fit.describe(), nullptr, "", options.preview);
    const std::string p =
        (in.previews_dir / (in.table != nullptr ? "table-vs-fit.png" : "fit.png")).string();
    if (!sheet) {
        result.notes.push_back("preview: " + sheet.error().message);
    } else if (auto w = write_png(p, *sheet); !w) {
        result.notes.push_back(w.error().message);
    } else {
        result.generated.push_back(p);
    }
}

/// The pictures that are missing: plots (when there is a dataset), the sphere preview (when there
/// is a fit), and with `blender` Blender's render of the exported fit.
void draw_missing_pictures(const ReportInputs& in,
                           const ReportOptions& options,
                           ReportResult& result) {
    draw_missing_plots(in, options, result);
    draw_missing_preview(in, options, result);
    if (options.blender) {
        if (auto b = write_blender_preview(in.root.string(), options.preview.size_px); b) {
            result.generated.push_back(*b);
        } else {
            result.notes.push_back(b.error().message);
        }
    }
}

/// The sample's name: metadata.json's, dataset.json's, else campaign.json's sample, material or
/// name.
std::string sample_name(const ReportInputs& in) {
    std::string sample = text_of(in.metadata, "sample");
    if (sample.empty()) {
        sample = text_of(in.dataset_meta, "sample");
    }
    if (sample.empty() && in.campaign.is_object()) {
        for (const char* k : {"sample", "material", "name"}) {
            if (const json* v = member(in.campaign, k)) {
                sample =
                    v->is_object() ? text_of(*v, "name") : (is_scalar(*v) ? scalar_text(*v) : "");
                if (!sample.empty()) {
                    break;
                }
            }
        }
    }
    return sample;
}

/// When it was measured: the runs of metadata.json, else when a file was written.
std::string when_measured(const ReportInputs& in) {
    const json& meta = in.metadata;
    if (const json* runs = member(meta, "runs");
        runs != nullptr && runs->is_array() && !runs->empty()) {
        const std::string first = text_of(runs->front(), "started");
        std::string last = text_of(runs->back(), "ended");
        if (last.rfind("unknown", 0) == 0) {
            last.clear();
        }
        std::string when = "measured " + first + (last.empty() ? "" : " to " + last);
        if (runs->size() > 1) {
            when += " in " + std::to_string(runs->size()) + " runs";
        }
        return when;
    }
    if (!text_of(meta, "created").empty()) {
        return "created " + text_of(meta, "created");
    }
    if (in.image_mode) {
        return "written " + file_time_text(in.dataset_json_path);
    }
    if (fs::exists(in.data_path)) {
        return "dataset written " + file_time_text(in.data_path);
    }
    return {};
}

/// The achieved coverage of an image campaign against its target ("" when not recorded).
std::string coverage_fact(const json& dsm) {
    const json* c = member(dsm, "coverage");
    if (c == nullptr || !c->is_object()) {
        return {};
    }
    const json* a = member(*c, "achieved");
    const json* t = member(*c, "target");
    if (a == nullptr || !a->is_number() || t == nullptr || !t->is_number()) {
        return {};
    }
    char buf[96];
    std::snprintf(buf,
                  sizeof buf,
                  "coverage %.1f %% of the valid bins (target %.0f %%)",
                  100 * a->get<double>(),
                  100 * t->get<double>());
    return buf;
}

/// A fit of a file: which file, how many samples, when it was fitted.
std::vector<std::string> file_fit_facts(const ReportInputs& in) {
    std::vector<std::string> facts = {"fit of the file " + in.data_file};
    if (in.data) {
        facts.push_back(std::to_string(in.data->samples.size()) + " samples");
    }
    facts.push_back("fitted " + file_time_text(in.fit_report_path));
    return facts;
}

/// What was measured and when: the facts under the title.
std::vector<std::string> campaign_facts(const ReportInputs& in) {
    if (in.file_fit) {
        return file_fit_facts(in);
    }
    const json& meta = in.metadata;
    const json& dsm = in.dataset_meta;
    std::vector<std::string> facts;
    facts.push_back(in.image_mode ? "image-mode campaign (curved sample imaged by the camera)"
                                  : "point-mode campaign");
    if (std::string when = when_measured(in); !when.empty()) {
        facts.push_back(when);
    }
    std::string rig = in.image_mode ? text_of(dsm, "rig") : std::string();
    if (const json* r = member(meta, "rig"); r != nullptr && r->is_object()) {
        rig = text_of(*r, "name");
    }
    if (!rig.empty()) {
        facts.push_back("rig " + rig);
    }
    if (in.data) {
        std::string n = std::to_string(in.data->samples.size()) + " samples";
        if (!text_of(meta, "planned").empty()) {
            n += " (" + text_of(meta, "planned") + " planned)";
        }
        if (!in.references.empty()) {
            n += " besides " + std::to_string(in.references.size()) + " drift-reference rows";
        }
        facts.push_back(n);
    }
    if (in.image_mode) {
        if (std::string c = coverage_fact(dsm); !c.empty()) {
            facts.push_back(c);
        }
    }
    if (!text_of(meta, "operator").empty()) {
        facts.push_back("operator " + text_of(meta, "operator"));
    }
    if (const json* gt = member(dsm, "ground_truth"); gt != nullptr && gt->is_string()) {
        facts.push_back("simulated ground truth " + gt->get<std::string>());
    }
    return facts;
}

/// The page's head, its title and the facts line.
void write_head(std::ostream& h, const std::string& title, const std::vector<std::string>& facts) {
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>"
      << html_escape(title) << "</title>" << kStyle << "</head><body>\n";
    h << "<header id=\"result\"><h1>" << html_escape(title) << "</h1>\n<p class=\"facts\">";
    for (std::size_t i = 0; i < facts.size(); ++i) {
        h << (i ? "; " : "") << html_escape(facts[i]);
    }
    h << ".</p>\n";
}

/// The result: verdict, model, parameters.
void write_result(std::ostream& h, const ReportInputs& in) {
    if (in.fit_result) {
        h << verdict_block(*in.fit_result) << model_block(*in.fit_result, in.model_summary);
        if (in.fit_result->automatic) {
            h << auto_choice_block(*in.fit_result->automatic);
        }
    } else if (in.fit_report.is_object()) {
        h << "<div id=\"verdict\" class=\"verdict bad\"><p><b>Verdict: none</b>. "
             "fit.report.json is not a fit report this version reads (see the notes).</p>"
             "</div>\n";
    } else {
        h << "<div id=\"verdict\" class=\"verdict bad\"><p><b>Verdict: no fit</b>. No "
             "fit.report.json in this folder (run <code>gonio fit</code> on dataset.csv).</p>"
             "</div>\n";
        if (!in.model_summary.empty()) {
            h << "<p>Model (<code>fit.json</code>): <code>" << html_escape(in.model_summary)
              << "</code></p>\n";
        }
    }
    h << "</header>\n";
}

/// The PNG files of plots/, the known plots first in the order of the page's story.
std::vector<fs::path> plots_in_story_order(const fs::path& plots_dir) {
    std::vector<fs::path> plots = pngs_in(plots_dir);
    const char* order[] = {"in_plane.png", "delta_phi.png", "residuals.png"};
    std::stable_sort(plots.begin(), plots.end(), [&](const fs::path& a, const fs::path& b) {
        auto rank = [&](const fs::path& p) {
            for (int i = 0; i < 3; ++i) {
                if (p.filename() == order[i]) {
                    return i;
                }
            }
            return 3;
        };
        return rank(a) < rank(b);
    });
    return plots;
}

/// The plots and previews on disk as figures; returns how many.
std::size_t write_picture_files(std::ostream& h,
                                const ReportInputs& in,
                                std::vector<std::string>& notes) {
    std::size_t figures = 0;
    for (const fs::path& p : plots_in_story_order(in.plots_dir)) {
        if (p.filename() == "coverage.png") {
            continue;  // drawn below from the data
        }
        auto img = read_png(p.string());
        if (img) {
            h << figure(*img, "plot-" + p.stem().string(), caption_for(p.filename().string()));
            ++figures;
        } else {
            notes.push_back(img.error().message);
        }
    }
    for (const fs::path& p : pngs_in(in.previews_dir)) {
        auto img = read_png(p.string());
        if (img) {
            h << figure(*img,
                        "preview-" + p.stem().string(),
                        p.stem() == "blender"
                            ? blender_preview_caption(in.previews_dir.string())
                            : "Sphere preview (previews/" + p.filename().string() +
                                  "): the BRDFs named on each row rendered on a sphere under a "
                                  "directional light and a sky/ground environment, one exposure.");
            ++figures;
        } else {
            notes.push_back(img.error().message);
        }
    }
    return figures;
}

/// The coverage figure, drawn now: of the table (also written to plots/coverage-map.png) or of
/// the dataset. Returns how many figures it wrote (0 or 1).
std::size_t write_coverage_figure(std::ostream& h,
                                  const ReportInputs& in,
                                  const ReportOptions& options,
                                  const std::string& sample,
                                  ReportResult& result) {
    std::error_code ec;
    if (in.table != nullptr) {
        auto cov = plot_table_coverage(
            *in.table, holes_of(in.dataset_meta), options.plot, sample.empty() ? "table" : sample);
        if (!cov) {
            result.notes.push_back(cov.error().message);
            return 0;
        }
        h << figure(*cov,
                    "coverage",
                    "Coverage of the half/difference table: fraction of the phi_d bins of "
                    "each (theta_h, theta_d) cell holding a measured value; holes outlined.");
        if (fs::create_directories(in.plots_dir, ec); !ec) {
            const std::string p = (in.plots_dir / "coverage-map.png").string();
            if (auto w = write_png(p, *cov); w) {
                result.generated.push_back(p);
            }
        }
        return 1;
    }
    if (!in.data) {
        return 0;
    }
    auto cov = plot_coverage(*in.data, options.plot);
    if (!cov) {
        h << "<p class=\"note\">" << html_escape(cov.error().message) << "</p>\n";
        return 0;
    }
    h << figure(*cov,
                "coverage",
                "Coverage of the angular domain: each measured (wi, wo) pair's outgoing "
                "direction seen from above (left) and at its (theta_h, theta_d) (right), "
                "coloured by theta_i.");
    return 1;
}

/// The pictures section.
void write_pictures(std::ostream& h,
                    const ReportInputs& in,
                    const ReportOptions& options,
                    const std::string& sample,
                    ReportResult& result) {
    h << "<h2 id=\"pictures\">Pictures</h2>\n";
    std::size_t figures = write_picture_files(h, in, result.notes);
    figures += write_coverage_figure(h, in, options, sample, result);
    if (figures == 0) {
        h << "<p class=\"note\">No pictures: no dataset and no fit in this folder.</p>\n";
    }
}

/// An image campaign's calibration, coverage and capture figures, and its holes.
void write_image_calibration(std::ostream& h, const json& dsm) {
    std::vector<std::pair<std::string, std::string>> rows;
    for (const char* k : {"coverage",
                          "calibration_counts_per_us_per_inv_sr",
                          "reference_albedo",
                          "sphere",
                          "pixels",
                          "table",
                          "captures",
                          "exposure_time_s"}) {
        if (const json* v = member(dsm, k)) {
            flatten(*v, k, rows);
        }
    }
    h << kv_table(rows);
    const std::vector<TableHole> holes = holes_of(dsm);
    if (holes.empty()) {
        return;
    }
    h << "<h3>Holes</h3>\n<table class=\"grid\"><tr><th>theta_h [deg]</th><th>theta_d "
         "[deg]</th><th>bins</th><th>reason</th></tr>";
    const json& hj = dsm["holes"];
    for (const json& e : hj) {
        if (!e.is_object()) {
            continue;
        }
        h << "<tr><td>" << html_escape(rgb_text(e.value("theta_h_deg", json()))) << "</td><td>"
          << html_escape(rgb_text(e.value("theta_d_deg", json()))) << "</td><td>"
          << html_escape(text_of(e, "bins", "-")) << "</td><td>"
          << html_escape(text_of(e, "reason", "-")) << "</td></tr>";
    }
    h << "</table>\n";
}

/// The same configuration measured again during the campaign, in file order.
void write_drift_references(std::ostream& h, const std::vector<brdf::Sample>& references) {
    if (references.empty()) {
        return;
    }
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

/// Coverage details, calibration and drift.
void write_calibration(std::ostream& h, const ReportInputs& in) {
    h << "<h2 id=\"calibration\">Coverage, calibration and drift</h2>\n";
    if (in.data && !in.data->rejected.empty()) {
        h << "<p class=\"note\">" << in.data->rejected.size()
          << " rows of dataset.csv rejected (first: line " << in.data->rejected.front().line << ", "
          << html_escape(in.data->rejected.front().reason) << ").</p>\n";
    }
    if (in.image_mode) {
        write_image_calibration(h, in.dataset_meta);
    }
    json cal = calibration_and_drift(in.campaign);
    const json run_cal = calibration_and_drift(in.metadata);
    for (auto it = run_cal.begin(); it != run_cal.end(); ++it) {
        cal[it.key() + (cal.contains(it.key()) ? " (run)" : "")] = *it;
    }
    if (!cal.empty()) {
        std::vector<std::pair<std::string, std::string>> rows;
        flatten(cal, "", rows);
        h << kv_table(rows);
    } else if (!in.image_mode) {
        h << "<p class=\"note\">No calibration or drift settings in campaign.json or "
             "metadata.json.</p>\n";
    }
    write_drift_references(h, in.references);
}

/// A point campaign's runs (metadata.json) and its counts.
void write_point_runs(std::ostream& h, const json& meta, const json& runs) {
    h << "<table class=\"grid\"><tr><th>#</th><th>started</th><th>ended</th><th>state</th>"
         "<th>measured</th></tr>";
    int i = 0;
    for (const json& r : runs) {
        h << "<tr><td>" << ++i << "</td><td>" << html_escape(text_of(r, "started", "-"))
          << "</td><td>" << html_escape(text_of(r, "ended", "-")) << "</td><td>"
          << html_escape(text_of(r, "state", "-")) << "</td><td>"
          << html_escape(text_of(r, "measured", "-")) << "</td></tr>";
    }
    h << "</table>\n<p>State " << html_escape(text_of(meta, "state", "-")) << "; "
      << html_escape(text_of(meta, "measured", "-")) << " measured of "
      << html_escape(text_of(meta, "planned", "-")) << " planned; pose repeats "
      << html_escape(text_of(meta, "pose_repeats", "0")) << ", device outages "
      << html_escape(text_of(meta, "device_outages", "0")) << ".</p>\n";
}

/// An image campaign's light positions (dataset.json's frames) and why it stopped.
void write_image_frames(std::ostream& h, const json& dsm, const json& frames) {
    h << "<p>Light positions in the order measured.</p>\n<table class=\"grid\"><tr><th>#</th>"
         "<th>light arm [deg]</th><th>pixels used</th><th>pixels saturated</th>"
         "<th>exposures (r g b)</th><th>coverage after</th></tr>";
    int i = 0;
    for (const json& f : frames) {
        h << "<tr><td>" << ++i << "</td><td>" << html_escape(text_of(f, "light_arm_deg", "-"))
          << "</td><td>" << html_escape(text_of(f, "used_pixels", "-")) << "</td><td>"
          << html_escape(text_of(f, "saturated_pixels", "-")) << "</td><td>"
          << html_escape(f.is_object() && f.contains("exposures") ? rgb_text(f["exposures"]) : "-")
          << "</td><td>" << html_escape(text_of(f, "coverage_after", "-")) << "</td></tr>";
    }
    h << "</table>\n";
    if (const json* c = member(dsm, "coverage")) {
        h << "<p>Stopped: " << html_escape(text_of(*c, "stop_reason", "-")) << ".</p>\n";
    }
}

/// Run history: a point campaign's runs, or an image campaign's light positions.
void write_history(std::ostream& h, const ReportInputs& in) {
    h << "<h2 id=\"history\">Run history</h2>\n";
    if (const json* runs = member(in.metadata, "runs");
        runs != nullptr && runs->is_array() && !runs->empty()) {
        write_point_runs(h, in.metadata, *runs);
    } else if (const json* frames = member(in.dataset_meta, "frames");
               frames != nullptr && frames->is_array() && !frames->empty()) {
        write_image_frames(h, in.dataset_meta, *frames);
    } else {
        h << "<p class=\"note\">No run history (no metadata.json runs, no image-mode "
             "frames).</p>\n";
    }
}

/// bench/runtime_vs_error.csv as a table, when the folder has one.
void write_runtime(std::ostream& h, const fs::path& root) {
    const fs::path bench_path = root / "bench" / "runtime_vs_error.csv";
    if (!fs::exists(bench_path)) {
        return;
    }
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

/// Raw descriptions (folded), the notes, and where and when the page was written.
void write_tail(std::ostream& h,
                const ReportInputs& in,
                const std::vector<std::string>& notes,
                const std::string& dir) {
    h << "<h2 id=\"raw\">Raw descriptions</h2>\n";
    const std::string raw = raw_details("campaign.json", in.campaign) +
                            raw_details("metadata.json", in.metadata) +
                            raw_details("dataset.json", in.dataset_meta) +
                            raw_details("fit.report.json", in.fit_report);
    h << (raw.empty() ? "<p class=\"note\">No JSON description in this folder.</p>\n" : raw);
    if (!notes.empty()) {
        h << "<h2 id=\"notes\">Notes</h2>\n<ul>";
        for (const std::string& n : notes) {
            h << "<li>" << html_escape(n) << "</li>";
        }
        h << "</ul>\n";
    }
    std::time_t now = std::time(nullptr);
    char written[64];
    std::strftime(written, sizeof written, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
    h << "<p class=\"facts\">Folder <code>" << html_escape(dir) << "</code>; page written "
      << written << " by gonio " << GONIO_VERSION_STRING << ".</p>\n";
    h << "</body></html>\n";
}

/// The folder's inputs: its descriptions, samples, table and fit, and the missing pictures drawn.
Expected<ReportInputs> read_inputs(const fs::path& root,
                                   const ReportOptions& options,
                                   ReportResult& result) {
    ReportInputs in;
    in.root = root;
    in.data_path = root / "dataset.csv";
    in.campaign_path = root / "campaign.json";
    in.metadata_path = root / "metadata.json";
    in.dataset_json_path = root / "dataset.json";
    in.fit_path = root / "fit.json";
    in.fit_report_path = root / "fit.report.json";
    in.plots_dir = root / "plots";
    in.previews_dir = root / "previews";
    if (!fs::exists(in.data_path) && !fs::exists(in.campaign_path) && !fs::exists(in.fit_path) &&
        !fs::exists(in.dataset_json_path)) {
        return make_error(root.string() +
                          ": neither dataset.csv, dataset.json, campaign.json nor fit.json: not a "
                          "campaign folder");
    }
    if (auto r = read_descriptions(in, result.notes); !r) {
        return tl::unexpected(r.error());
    }
    // No campaign's description nor its samples, and a fit report that names its data: the page
    // of a fit of that file.
    if (in.fit_result && !in.fit_result->data.empty() && !fs::exists(in.data_path) &&
        !fs::exists(in.campaign_path) && !fs::exists(in.metadata_path) &&
        !fs::exists(in.dataset_json_path)) {
        in.file_fit = true;
        in.data_file = in.fit_result->data;
    }
    read_samples(in, result.notes);
    read_table(in, result.notes);
    read_fit(in, result.notes);
    draw_missing_pictures(in, options, result);
    return in;
}

}  // namespace

Expected<ReportResult> build_report(const std::string& dir, const ReportOptions& options) {
    std::error_code ec;
    const fs::path root(dir);
    if (!fs::is_directory(root, ec)) {
        return make_error(dir + ": not a folder");
    }
    ReportResult result;
    auto in = read_inputs(root, options, result);
    if (!in) {
        return tl::unexpected(in.error());
    }
    const std::string sample =
        in->file_fit ? fs::path(in->data_file).filename().string() : sample_name(*in);
    const std::string title = (in->file_fit ? "gonio fit report" : "gonio campaign report") +
                              (sample.empty() ? std::string() : ": " + sample);
    std::ostringstream h;
    write_head(h, title, campaign_facts(*in));
    write_result(h, *in);
    write_pictures(h, *in, options, sample, result);
    if (!in->file_fit) {
        // A fit of a file has no campaign: no calibration, no drift, no runs to show.
        write_calibration(h, *in);
        write_history(h, *in);
    }
    write_runtime(h, root);
    write_tail(h, *in, result.notes, dir);
    const fs::path out = root / "report.html";
    if (auto w = write_file_atomic(out.string(), h.str()); !w) {
        return tl::unexpected(w.error());
    }
    result.html_path = out.string();
    return result;
}

}  // namespace gonio::report
