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
    const bool usable = rep.solver.usable;
    const bool represents = rep.goodness.represents;
    const bool ok = usable && represents;
    os << "<div id=\"verdict\" class=\"verdict " << (ok ? "ok" : "bad")
       << "\"><p><b>Verdict: " << (usable ? "fit usable" : "fit NOT USABLE") << "; "
       << (represents ? "the model represents these data"
                      : "the model does NOT represent these data")
       << "</b>";
    os << " (solver " << html_escape(rep.solver.termination.empty() ? "-" : rep.solver.termination)
       << ", " << rep.solver.iterations << " iterations, " << fmt_num(rep.solver.wall_time_s)
       << " s)</p>\n";
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
.verdict.bad{border-color:#c22;background:#fdf2f2}.warnings{margin:.2em 0;color:#a40}
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

}  // namespace

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
    const fs::path dataset_json_path = root / "dataset.json";
    const fs::path fit_path = root / "fit.json";
    const fs::path fit_report_path = root / "fit.report.json";
    if (!fs::exists(data_path) && !fs::exists(campaign_path) && !fs::exists(fit_path) &&
        !fs::exists(dataset_json_path)) {
        return make_error(dir +
                          ": neither dataset.csv, dataset.json, campaign.json nor fit.json: not a "
                          "campaign folder");
    }

    Expected<json> campaign = read_optional_json(campaign_path, notes);
    Expected<json> metadata = read_optional_json(metadata_path, notes);
    Expected<json> dataset_meta = read_optional_json(dataset_json_path, notes);
    Expected<json> fit_report = read_optional_json(fit_report_path, notes);
    // The verdict and the parameters come from the strict reader of fit reports: a report it
    // refuses is named in the notes with the key path, and no verdict is drawn from it.
    std::optional<fitting::FitResult> fit_result;
    if (fit_report && fit_report->is_object()) {
        Expected<fitting::FitResult> r = fitting::read_fit_report(fit_report_path.string());
        if (r) {
            fit_result = std::move(*r);
        } else {
            notes.push_back(r.error().message + "; no verdict drawn from it");
        }
    }
    for (const Expected<json>* j : {&campaign, &metadata, &dataset_meta, &fit_report}) {
        if (!*j) {
            return tl::unexpected(j->error());
        }
    }
    const bool image_mode = dataset_meta->is_object() && text_of(*dataset_meta, "mode") == "image";

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

    // The table of an image campaign.
    std::unique_ptr<brdf::Brdf> table_brdf;
    const brdf::TabulatedBrdf* table = nullptr;
    if (image_mode) {
        const json* t = member(*dataset_meta, "table");
        const std::string file = t != nullptr ? text_of(*t, "file") : std::string();
        if (file.empty() || file.find('/') != std::string::npos) {
            notes.push_back(dataset_json_path.string() +
                            ": table.file missing or not a plain name");
        } else if (auto b = brdf::load_brdf((root / file).string()); b) {
            table_brdf = std::move(*b);
            table = dynamic_cast<const brdf::TabulatedBrdf*>(table_brdf.get());
        } else {
            notes.push_back(b.error().message);
        }
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
        // Measurement against fit when the measurement is a table, else the fit alone.
        auto sheet =
            table != nullptr
                ? preview_sheet(*table,
                                "measured: " + table->describe(),
                                fit.get(),
                                "fit: " + fit->describe(),
                                options.preview)
                : preview_sheet(*fit, "fit: " + fit->describe(), nullptr, "", options.preview);
        const std::string p =
            (previews_dir / (table != nullptr ? "table-vs-fit.png" : "fit.png")).string();
        if (!sheet) {
            notes.push_back("preview: " + sheet.error().message);
        } else if (auto w = write_png(p, *sheet); !w) {
            notes.push_back(w.error().message);
        } else {
            result.generated.push_back(p);
        }
    }
    if (options.blender) {
        if (auto b = write_blender_preview(root.string(), options.preview.size_px); b) {
            result.generated.push_back(*b);
        } else {
            notes.push_back(b.error().message);
        }
    }

    // What was measured and when.
    const json& meta = *metadata;
    const json& dsm = *dataset_meta;
    std::string sample = text_of(meta, "sample");
    if (sample.empty()) {
        sample = text_of(dsm, "sample");
    }
    if (sample.empty() && campaign->is_object()) {
        for (const char* k : {"sample", "material", "name"}) {
            if (const json* v = member(*campaign, k)) {
                sample =
                    v->is_object() ? text_of(*v, "name") : (is_scalar(*v) ? scalar_text(*v) : "");
                if (!sample.empty()) {
                    break;
                }
            }
        }
    }
    std::string title = "gonio campaign report" + (sample.empty() ? "" : ": " + sample);
    std::vector<std::string> facts;
    facts.push_back(image_mode ? "image-mode campaign (curved sample imaged by the camera)"
                               : "point-mode campaign");
    std::string when;
    if (const json* runs = member(meta, "runs");
        runs != nullptr && runs->is_array() && !runs->empty()) {
        const std::string first = text_of(runs->front(), "started");
        std::string last = text_of(runs->back(), "ended");
        if (last.rfind("unknown", 0) == 0) {
            last.clear();
        }
        when = "measured " + first + (last.empty() ? "" : " to " + last);
        if (runs->size() > 1) {
            when += " in " + std::to_string(runs->size()) + " runs";
        }
    } else if (!text_of(meta, "created").empty()) {
        when = "created " + text_of(meta, "created");
    } else if (image_mode) {
        when = "written " + file_time_text(dataset_json_path);
    } else if (fs::exists(data_path)) {
        when = "dataset written " + file_time_text(data_path);
    }
    if (!when.empty()) {
        facts.push_back(when);
    }
    std::string rig = image_mode ? text_of(dsm, "rig") : std::string();
    if (const json* r = member(meta, "rig"); r != nullptr && r->is_object()) {
        rig = text_of(*r, "name");
    }
    if (!rig.empty()) {
        facts.push_back("rig " + rig);
    }
    if (data) {
        std::string n = std::to_string(data->samples.size()) + " samples";
        if (!text_of(meta, "planned").empty()) {
            n += " (" + text_of(meta, "planned") + " planned)";
        }
        if (!references.empty()) {
            n += " besides " + std::to_string(references.size()) + " drift-reference rows";
        }
        facts.push_back(n);
    }
    if (image_mode) {
        if (const json* c = member(dsm, "coverage"); c != nullptr && c->is_object()) {
            const json* a = member(*c, "achieved");
            const json* t = member(*c, "target");
            if (a != nullptr && a->is_number() && t != nullptr && t->is_number()) {
                char buf[96];
                std::snprintf(buf,
                              sizeof buf,
                              "coverage %.1f %% of the valid bins (target %.0f %%)",
                              100 * a->get<double>(),
                              100 * t->get<double>());
                facts.push_back(buf);
            }
        }
    }
    if (!text_of(meta, "operator").empty()) {
        facts.push_back("operator " + text_of(meta, "operator"));
    }
    if (const json* gt = member(dsm, "ground_truth"); gt != nullptr && gt->is_string()) {
        facts.push_back("simulated ground truth " + gt->get<std::string>());
    }

    std::time_t now = std::time(nullptr);
    char written[64];
    std::strftime(written, sizeof written, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
    std::ostringstream h;
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>"
      << html_escape(title) << "</title>" << kStyle << "</head><body>\n";
    h << "<header id=\"result\"><h1>" << html_escape(title) << "</h1>\n<p class=\"facts\">";
    for (std::size_t i = 0; i < facts.size(); ++i) {
        h << (i ? "; " : "") << html_escape(facts[i]);
    }
    h << ".</p>\n";

    // The result: verdict, model, parameters.
    if (fit_result) {
        h << verdict_block(*fit_result) << model_block(*fit_result, model_summary);
    } else if (fit_report->is_object()) {
        h << "<div id=\"verdict\" class=\"verdict bad\"><p><b>Verdict: none</b>. "
             "fit.report.json is not a fit report this version reads (see the notes).</p>"
             "</div>\n";
    } else {
        h << "<div id=\"verdict\" class=\"verdict bad\"><p><b>Verdict: no fit</b>. No "
             "fit.report.json in this folder (run <code>gonio fit</code> on dataset.csv).</p>"
             "</div>\n";
        if (!model_summary.empty()) {
            h << "<p>Model (<code>fit.json</code>): <code>" << html_escape(model_summary)
              << "</code></p>\n";
        }
    }
    h << "</header>\n";

    // Pictures.
    h << "<h2 id=\"pictures\">Pictures</h2>\n";
    std::vector<fs::path> plots = pngs_in(plots_dir);
    // Known plots first, in the order of the page's story.
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
    std::size_t figures = 0;
    for (const fs::path& p : plots) {
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
    for (const fs::path& p : pngs_in(previews_dir)) {
        auto img = read_png(p.string());
        if (img) {
            h << figure(*img,
                        "preview-" + p.stem().string(),
                        p.stem() == "blender"
                            ? blender_preview_caption(previews_dir.string())
                            : "Sphere preview (previews/" + p.filename().string() +
                                  "): the BRDFs named on each row rendered on a sphere under a "
                                  "directional light and a sky/ground environment, one exposure.");
            ++figures;
        } else {
            notes.push_back(img.error().message);
        }
    }
    if (table != nullptr) {
        auto cov = plot_table_coverage(
            *table, holes_of(dsm), options.plot, sample.empty() ? "table" : sample);
        if (cov) {
            h << figure(*cov,
                        "coverage",
                        "Coverage of the half/difference table: fraction of the phi_d bins of "
                        "each (theta_h, theta_d) cell holding a measured value; holes outlined.");
            ++figures;
            if (fs::create_directories(plots_dir, ec); !ec) {
                const std::string p = (plots_dir / "coverage-map.png").string();
                if (auto w = write_png(p, *cov); w) {
                    result.generated.push_back(p);
                }
            }
        } else {
            notes.push_back(cov.error().message);
        }
    } else if (data) {
        auto cov = plot_coverage(*data, options.plot);
        if (cov) {
            h << figure(*cov,
                        "coverage",
                        "Coverage of the angular domain: each measured (wi, wo) pair's outgoing "
                        "direction seen from above (left) and at its (theta_h, theta_d) (right), "
                        "coloured by theta_i.");
            ++figures;
        } else {
            h << "<p class=\"note\">" << html_escape(cov.error().message) << "</p>\n";
        }
    }
    if (figures == 0) {
        h << "<p class=\"note\">No pictures: no dataset and no fit in this folder.</p>\n";
    }

    // Coverage details, calibration and drift.
    h << "<h2 id=\"calibration\">Coverage, calibration and drift</h2>\n";
    if (data && !data->rejected.empty()) {
        h << "<p class=\"note\">" << data->rejected.size()
          << " rows of dataset.csv rejected (first: line " << data->rejected.front().line << ", "
          << html_escape(data->rejected.front().reason) << ").</p>\n";
    }
    if (image_mode) {
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
        if (!holes.empty()) {
            h << "<h3>Holes</h3>\n<table class=\"grid\"><tr><th>theta_h [deg]</th><th>theta_d "
                 "[deg]</th><th>bins</th><th>reason</th></tr>";
            const json& hj = dsm["holes"];
            for (const json& e : hj) {
                if (!e.is_object()) {
                    continue;
                }
                h << "<tr><td>" << html_escape(rgb_text(e.value("theta_h_deg", json())))
                  << "</td><td>" << html_escape(rgb_text(e.value("theta_d_deg", json())))
                  << "</td><td>" << html_escape(text_of(e, "bins", "-")) << "</td><td>"
                  << html_escape(text_of(e, "reason", "-")) << "</td></tr>";
            }
            h << "</table>\n";
        }
    }
    json cal = calibration_and_drift(*campaign);
    const json run_cal = calibration_and_drift(meta);
    for (auto it = run_cal.begin(); it != run_cal.end(); ++it) {
        cal[it.key() + (cal.contains(it.key()) ? " (run)" : "")] = *it;
    }
    if (!cal.empty()) {
        std::vector<std::pair<std::string, std::string>> rows;
        flatten(cal, "", rows);
        h << kv_table(rows);
    } else if (!image_mode) {
        h << "<p class=\"note\">No calibration or drift settings in campaign.json or "
             "metadata.json.</p>\n";
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

    // Run history.
    h << "<h2 id=\"history\">Run history</h2>\n";
    if (const json* runs = member(meta, "runs");
        runs != nullptr && runs->is_array() && !runs->empty()) {
        h << "<table class=\"grid\"><tr><th>#</th><th>started</th><th>ended</th><th>state</th>"
             "<th>measured</th></tr>";
        int i = 0;
        for (const json& r : *runs) {
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
    } else if (const json* frames = member(dsm, "frames");
               frames != nullptr && frames->is_array() && !frames->empty()) {
        h << "<p>Light positions in the order measured.</p>\n<table class=\"grid\"><tr><th>#</th>"
             "<th>light arm [deg]</th><th>pixels used</th><th>pixels saturated</th>"
             "<th>exposures (r g b)</th><th>coverage after</th></tr>";
        int i = 0;
        for (const json& f : *frames) {
            h << "<tr><td>" << ++i << "</td><td>" << html_escape(text_of(f, "light_arm_deg", "-"))
              << "</td><td>" << html_escape(text_of(f, "used_pixels", "-")) << "</td><td>"
              << html_escape(text_of(f, "saturated_pixels", "-")) << "</td><td>"
              << html_escape(f.is_object() && f.contains("exposures") ? rgb_text(f["exposures"])
                                                                      : "-")
              << "</td><td>" << html_escape(text_of(f, "coverage_after", "-")) << "</td></tr>";
        }
        h << "</table>\n";
        if (const json* c = member(dsm, "coverage")) {
            h << "<p>Stopped: " << html_escape(text_of(*c, "stop_reason", "-")) << ".</p>\n";
        }
    } else {
        h << "<p class=\"note\">No run history (no metadata.json runs, no image-mode "
             "frames).</p>\n";
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

    // Raw descriptions, folded.
    h << "<h2 id=\"raw\">Raw descriptions</h2>\n";
    const std::string raw = raw_details("campaign.json", *campaign) +
                            raw_details("metadata.json", meta) + raw_details("dataset.json", dsm) +
                            raw_details("fit.report.json", *fit_report);
    h << (raw.empty() ? "<p class=\"note\">No JSON description in this folder.</p>\n" : raw);

    if (!notes.empty()) {
        h << "<h2 id=\"notes\">Notes</h2>\n<ul>";
        for (const std::string& n : notes) {
            h << "<li>" << html_escape(n) << "</li>";
        }
        h << "</ul>\n";
    }
    h << "<p class=\"facts\">Folder <code>" << html_escape(dir) << "</code>; page written "
      << written << " by gonio " << GONIO_VERSION_STRING << ".</p>\n";
    h << "</body></html>\n";

    const fs::path out = root / "report.html";
    if (auto w = write_file_atomic(out.string(), h.str()); !w) {
        return tl::unexpected(w.error());
    }
    result.html_path = out.string();
    return result;
}

}  // namespace gonio::report
