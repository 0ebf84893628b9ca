// Fit reports: JSON on disk and the human-readable summary.

#include "gonio/fitting/report.h"

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/model_json.h"

namespace gonio::fitting {

namespace {

using nlohmann::json;

json rgb_json(const brdf::Rgbd& v) {
    return json::array({v[0], v[1], v[2]});
}

/// A number, or null when it is not finite (JSON has no NaN; no NaN leaves silently).
json number_or_null(double v) {
    return std::isfinite(v) ? json(v) : json(nullptr);
}

Expected<void> write_text(const std::string& path, const std::string& text) {
    return write_file_atomic(path, text);
}

}  // namespace

std::string report_path_for(const std::string& model_path) {
    const std::string ext = ".json";
    if (model_path.size() > ext.size() && ends_with(model_path, ext)) {
        return model_path.substr(0, model_path.size() - ext.size()) + ".report.json";
    }
    return model_path + ".report.json";
}

namespace {

/// The ranking of an automatic model choice, as the report's "auto" key.
json auto_choice_json(const AutoChoice& a) {
    json ranking = json::array();
    for (const RankedModel& m : a.ranking) {
        ranking.push_back({{"name", m.name},
                           {"parameters", m.parameters},
                           {"log_rmse", number_or_null(m.log_rmse)},
                           {"criterion", number_or_null(m.criterion)},
                           {"converged", m.converged}});
    }
    return {{"chosen", a.chosen}, {"criterion", a.criterion}, {"ranking", ranking}};
}

}  // namespace

std::string fit_report_json(const FitResult& r) {
    json j;
    j["model"] = json::parse(brdf::model_to_json(r.model));
    json params = json::array();
    for (const FittedParameter& p : r.parameters) {
        params.push_back({{"name", p.name},
                          {"value", number_or_null(p.value)},
                          {"sigma", p.sigma ? number_or_null(*p.sigma) : json(nullptr)},
                          {"free", p.free},
                          {"identifiable", p.identifiable},
                          {"at_bound", p.at_bound.empty() ? json(nullptr) : json(p.at_bound)}});
    }
    j["parameters"] = params;
    j["not_identifiable"] = r.not_identifiable;
    j["at_bounds"] = r.at_bounds;
    j["vanished_lobes"] = r.vanished_lobes;
    json bands = json::array();
    for (const BandResidual& b : r.metrics.bands) {
        bands.push_back({{"theta_h_deg", json::array({b.theta_h_lo_deg, b.theta_h_hi_deg})},
                         {"count", b.count},
                         {"mean_log", rgb_json(b.mean_log)},
                         {"log_rmse", rgb_json(b.log_rmse)}});
    }
    j["metrics"] = {{"rmse", rgb_json(r.metrics.rmse)},
                    {"rel_rmse", rgb_json(r.metrics.rel_rmse)},
                    {"log_rmse", rgb_json(r.metrics.log_rmse)},
                    {"median_rel", rgb_json(r.metrics.median_rel)},
                    {"bands", bands}};
    j["goodness"] = {{"verdict", to_string(r.goodness.verdict)},
                     {"headline", r.goodness.headline},
                     {"represents", r.goodness.represents},
                     {"reduced_chi_square",
                      r.goodness.reduced_chi_square ? number_or_null(*r.goodness.reduced_chi_square)
                                                    : json(nullptr)},
                     {"warnings", r.goodness.warnings},
                     {"suggestion", r.goodness.suggestion}};
    j["covariance"] = r.covariance_method;
    j["samples"] = {{"input", r.samples.input},
                    {"valid", r.samples.valid},
                    {"used", r.samples.used},
                    {"rejected", r.samples.rejected},
                    {"reference", r.samples.reference},
                    {"saturated", r.samples.saturated},
                    {"rejected_lines", r.samples.rejected_lines}};
    j["residual"] = to_string(r.residual);
    j["loss"] = to_string(r.loss);
    json stages = json::array();
    for (const StageInfo& st : r.solver.stages) {
        stages.push_back({{"name", st.name},
                          {"samples", st.samples},
                          {"iterations", st.iterations},
                          {"termination", st.termination},
                          {"time_s", st.time_s},
                          {"final_cost", number_or_null(st.final_cost)}});
    }
    j["solver"] = {{"iterations", r.solver.iterations},
                   {"stages", stages},
                   {"termination", r.solver.termination},
                   {"message", r.solver.message},
                   {"converged", r.solver.converged},
                   {"usable", r.solver.usable},
                   {"wall_time_s", r.solver.wall_time_s},
                   {"solve_time_s", r.solver.solve_time_s},
                   {"initial_cost", number_or_null(r.solver.initial_cost)},
                   {"final_cost", number_or_null(r.solver.final_cost)},
                   {"starts", r.solver.starts}};
    j["data"] = r.data;
    if (r.ground_truth) {
        j["ground_truth"] = json::parse(brdf::model_to_json(*r.ground_truth));
    }
    if (r.automatic) {
        j["auto"] = auto_choice_json(*r.automatic);
    }
    return j.dump(2) + "\n";
}

namespace {

/// The verdict written under "fit" in the model file: whether the model represents the data, the
/// figures that decide it, the warnings, the suggestion and the report's file name.
std::string fit_verdict_json(const FitResult& r, const std::string& report_path) {
    const std::size_t slash = report_path.find_last_of('/');
    json v = {{"verdict", to_string(r.goodness.verdict)},
              {"headline", r.goodness.headline},
              {"represents", r.goodness.represents},
              {"log_rmse", rgb_json(r.metrics.log_rmse)},
              {"median_rel", rgb_json(r.metrics.median_rel)},
              {"warnings", r.goodness.warnings},
              {"suggestion", r.goodness.suggestion},
              {"report", slash == std::string::npos ? report_path : report_path.substr(slash + 1)}};
    return v.dump();
}

}  // namespace

Expected<void> write_fit_report(const std::string& model_path, const FitResult& result) {
    const std::string report_path = report_path_for(model_path);
    // Both outputs checked before either is written: a folder or device at one of them leaves
    // nothing behind.
    for (const std::string& p : {model_path, report_path}) {
        if (auto ok = check_output_path(p); !ok) {
            return ok;
        }
    }
    Expected<void> w = write_text(report_path, fit_report_json(result));
    if (!w) {
        return w;
    }
    if (!result.solver.converged) {
        return make_error("fit did not converge (" + result.solver.termination + ": " +
                          result.solver.message + "); " + model_path + " not written, see " +
                          report_path);
    }
    // A converged misfit is the best that model can do: written, with its verdict beside it.
    return write_text(model_path,
                      brdf::model_to_json(result.model, fit_verdict_json(result, report_path)));
}

namespace {

// The fit report's reader: the strict reader of base/strict_json.h, so that an unknown key is
// refused with the keys allowed there, a wrong type names its key path, and the model inside is
// read by the model reader itself. The schema is the writer's, fit_report_json() above
// (docs/file-formats.md, "Fit files").

constexpr double kMaxCount = 9007199254740992.0;  // 2^53: every count a double holds exactly

/// A count (a whole number in [0, 2^53]) at `path`.
std::size_t read_count(const json& v, const std::string& path) {
    if (!v.is_number()) {
        json_fail(path + ": expected a whole number, got " + json_type(v));
    }
    const double x = v.get<double>();
    if (!std::isfinite(x) || x != std::floor(x) || x < 0 || x > kMaxCount) {
        json_fail(path + " = " + show_number(x) + ": must be a whole number in [0, 2^53]");
    }
    return static_cast<std::size_t>(x);
}

std::size_t count_key(JsonObject& o, const char* key) {
    return read_count(o.raw(key), o.key_path(key));
}

/// A number, or NaN for null (the writer's number_or_null).
double number_or_nan(const json& v, const std::string& path) {
    return v.is_null() ? std::nan("") : json_number_at(v, path);
}

/// An optional cost that may be null (not finite when written): 0 when absent or null, as in a
/// FitResult that never had it.
double optional_cost(JsonObject& o, const char* key) {
    const json* v = o.find(key);
    return v == nullptr || v->is_null() ? 0.0 : json_number_at(*v, o.key_path(key));
}

std::string text_at(const json& v, const std::string& path) {
    std::string s = json_string_at(v, path);
    if (s.size() > kMaxJsonString) {
        json_fail(path + ": " + std::to_string(s.size()) + " characters, at most " +
                  std::to_string(kMaxJsonString) + " allowed");
    }
    return s;
}

std::vector<std::string> string_list(JsonObject& o, const char* key) {
    std::vector<std::string> out;
    const json* v = o.find(key);
    if (v == nullptr) {
        return out;
    }
    const std::string at = o.key_path(key);
    if (!v->is_array()) {
        json_fail(at + ": expected an array of strings, got " + json_type(*v));
    }
    for (std::size_t i = 0; i < v->size(); ++i) {
        out.push_back(text_at((*v)[i], at + "[" + std::to_string(i) + "]"));
    }
    return out;
}

const json& array_key(JsonObject& o, const char* key) {
    const json& v = o.raw(key);
    if (!v.is_array()) {
        json_fail(o.key_path(key) + ": expected an array, got " + json_type(v));
    }
    return v;
}

brdf::Rgbd rgb_at(const json& v, const std::string& path) {
    if (!v.is_array() || v.size() != 3) {
        json_fail(path + ": expected [r, g, b], got " + json_type(v) +
                  (v.is_array() ? " of " + std::to_string(v.size()) : std::string()));
    }
    brdf::Rgbd out;
    for (int c = 0; c < 3; ++c) {
        out[c] = json_number_at(v[c], path + "[" + std::to_string(c) + "]");
    }
    return out;
}

brdf::Rgbd rgb_key(JsonObject& o, const char* key) {
    return rgb_at(o.raw(key), o.key_path(key));
}

std::string item_path(const std::string& at, std::size_t i) {
    return at + "[" + std::to_string(i) + "]";
}

/// The report's "auto" key (auto_choice_json): the winner, the criterion and every candidate.
AutoChoice read_auto_choice(const json& v) {
    JsonObject o(v, "auto");
    o.allow({"chosen", "criterion", "ranking"});
    o.finish();
    AutoChoice a;
    a.chosen = text_at(o.raw("chosen"), o.key_path("chosen"));
    a.criterion = text_at(o.raw("criterion"), o.key_path("criterion"));
    const json& ranking = array_key(o, "ranking");
    for (std::size_t i = 0; i < ranking.size(); ++i) {
        JsonObject m(ranking[i], item_path("auto.ranking", i));
        m.allow({"name", "parameters", "log_rmse", "criterion", "converged"});
        m.finish();
        RankedModel rm;
        rm.name = text_at(m.raw("name"), m.key_path("name"));
        m.raw("parameters");  // required
        rm.parameters = m.integer("parameters", 0, 0, 1 << 30);
        rm.log_rmse = number_or_nan(m.raw("log_rmse"), m.key_path("log_rmse"));
        rm.criterion = number_or_nan(m.raw("criterion"), m.key_path("criterion"));
        if (!m.raw("converged").is_boolean()) {
            json_fail(m.key_path("converged") + ": expected true or false, got " +
                      json_type(m.raw("converged")));
        }
        rm.converged = m.raw("converged").get<bool>();
        a.ranking.push_back(rm);
    }
    return a;
}

FittedParameter read_parameter(const json& v, const std::string& at) {
    JsonObject p(v, at);
    p.allow({"name", "value", "sigma", "free", "identifiable", "at_bound"});
    p.finish();
    FittedParameter fp;
    fp.name = text_at(p.raw("name"), p.key_path("name"));
    fp.value = number_or_nan(p.raw("value"), p.key_path("value"));
    if (const json& s = p.raw("sigma"); !s.is_null()) {
        fp.sigma = json_number_at(s, p.key_path("sigma"));
    }
    if (!p.raw("free").is_boolean() || !p.raw("identifiable").is_boolean()) {
        const char* bad = p.raw("free").is_boolean() ? "identifiable" : "free";
        json_fail(p.key_path(bad) + ": expected true or false, got " + json_type(p.raw(bad)));
    }
    fp.free = p.raw("free").get<bool>();
    fp.identifiable = p.raw("identifiable").get<bool>();
    if (const json* b = p.find("at_bound"); b != nullptr && !b->is_null()) {
        fp.at_bound = text_at(*b, p.key_path("at_bound"));
        if (fp.at_bound != "lower" && fp.at_bound != "upper") {
            json_fail(p.key_path("at_bound") + " = \"" + excerpt(fp.at_bound) +
                      "\": must be \"lower\", \"upper\" or null");
        }
    }
    return fp;
}

BandResidual read_band(const json& v, const std::string& at_band) {
    JsonObject b(v, at_band);
    b.allow({"theta_h_deg", "count", "mean_log", "log_rmse"});
    b.finish();
    BandResidual br;
    const json& range = b.raw("theta_h_deg");
    const std::string at = b.key_path("theta_h_deg");
    if (!range.is_array() || range.size() != 2) {
        json_fail(at + ": expected [lo, hi] in degrees, got " + json_type(range));
    }
    br.theta_h_lo_deg = json_number_at(range[0], at + "[0]");
    br.theta_h_hi_deg = json_number_at(range[1], at + "[1]");
    br.count = count_key(b, "count");
    br.mean_log = rgb_key(b, "mean_log");
    br.log_rmse = rgb_key(b, "log_rmse");
    return br;
}

Metrics read_metrics(const json& v) {
    JsonObject m(v, "metrics");
    m.allow({"rmse", "rel_rmse", "log_rmse", "median_rel", "bands"});
    m.finish();
    Metrics out;
    out.rmse = rgb_key(m, "rmse");
    out.rel_rmse = rgb_key(m, "rel_rmse");
    out.log_rmse = rgb_key(m, "log_rmse");
    if (m.has("median_rel")) {
        out.median_rel = rgb_key(m, "median_rel");
    }
    if (m.has("bands")) {
        const json& bands = array_key(m, "bands");
        for (std::size_t i = 0; i < bands.size(); ++i) {
            out.bands.push_back(read_band(bands[i], item_path("metrics.bands", i)));
        }
    }
    return out;
}

GoodnessOfFit read_goodness(const json& v) {
    JsonObject g(v, "goodness");
    g.allow({"verdict", "headline", "represents", "reduced_chi_square", "warnings", "suggestion"});
    g.finish();
    GoodnessOfFit out;
    out.represents = g.boolean("represents", true);
    // A report without a verdict (written before it existed): the two states it knew.
    out.verdict = out.represents ? Verdict::kRepresents : Verdict::kDoesNotRepresent;
    if (const json* verdict = g.find("verdict")) {
        auto parsed = parse_verdict(text_at(*verdict, g.key_path("verdict")));
        if (!parsed) {
            json_fail(g.key_path("verdict") + ": " + parsed.error().message);
        }
        out.verdict = *parsed;
    }
    out.headline = headline_of(out.verdict, "see the warnings");
    if (const json* h = g.find("headline")) {
        out.headline = text_at(*h, g.key_path("headline"));
    }
    if (const json* chi = g.find("reduced_chi_square"); chi != nullptr && !chi->is_null()) {
        out.reduced_chi_square = json_number_at(*chi, g.key_path("reduced_chi_square"));
    }
    out.warnings = string_list(g, "warnings");
    if (const json* s = g.find("suggestion")) {
        out.suggestion = text_at(*s, g.key_path("suggestion"));
    }
    return out;
}

SampleCounts read_sample_counts(const json& v) {
    JsonObject s(v, "samples");
    s.allow({"input", "valid", "used", "rejected", "reference", "saturated", "rejected_lines"});
    s.finish();
    SampleCounts out;
    out.input = count_key(s, "input");
    out.valid = count_key(s, "valid");
    out.used = count_key(s, "used");
    out.rejected = count_key(s, "rejected");
    if (s.has("reference")) {
        out.reference = count_key(s, "reference");
    }
    if (s.has("saturated")) {
        out.saturated = count_key(s, "saturated");
    }
    const json& lines = array_key(s, "rejected_lines");
    for (std::size_t i = 0; i < lines.size(); ++i) {
        out.rejected_lines.push_back(read_count(lines[i], item_path("samples.rejected_lines", i)));
    }
    return out;
}

/// The top level's "residual" and "loss" (defaults: log, none).
void read_residual_and_loss(JsonObject& top, FitResult* r) {
    const std::string residual = top.string("residual", "log", kMaxJsonString);
    const std::string loss = top.string("loss", "none", kMaxJsonString);
    Expected<ResidualForm> form = parse_residual(residual);
    if (!form) {
        json_fail("residual: " + form.error().message);
    }
    Expected<LossKind> loss_kind = parse_loss(loss);
    if (!loss_kind) {
        json_fail("loss: " + loss_kind.error().message);
    }
    r->residual = *form;
    r->loss = *loss_kind;
}

constexpr int kMaxIterations = 1 << 30;

StageInfo read_stage(const json& v, const std::string& at) {
    JsonObject st(v, at);
    st.allow({"name", "samples", "iterations", "termination", "time_s", "final_cost"});
    st.finish();
    StageInfo si;
    si.name = text_at(st.raw("name"), st.key_path("name"));
    si.samples = count_key(st, "samples");
    st.raw("iterations");  // required
    si.iterations = st.integer("iterations", 0, 0, kMaxIterations);
    si.termination = text_at(st.raw("termination"), st.key_path("termination"));
    si.time_s = json_number_at(st.raw("time_s"), st.key_path("time_s"));
    si.final_cost = optional_cost(st, "final_cost");
    return si;
}

SolverInfo read_solver(const json& v) {
    JsonObject sv(v, "solver");
    sv.allow({"iterations",
              "stages",
              "termination",
              "message",
              "converged",
              "usable",
              "wall_time_s",
              "solve_time_s",
              "initial_cost",
              "final_cost",
              "starts"});
    sv.finish();
    SolverInfo out;
    sv.raw("iterations");  // required
    out.iterations = sv.integer("iterations", 0, 0, kMaxIterations);
    out.termination = text_at(sv.raw("termination"), "solver.termination");
    out.message = text_at(sv.raw("message"), "solver.message");
    if (!sv.raw("usable").is_boolean()) {
        json_fail("solver.usable: expected true or false, got " + json_type(sv.raw("usable")));
    }
    out.usable = sv.raw("usable").get<bool>();
    out.converged = sv.boolean("converged", out.usable);
    if (sv.has("stages")) {
        const json& stages = array_key(sv, "stages");
        for (std::size_t i = 0; i < stages.size(); ++i) {
            out.stages.push_back(read_stage(stages[i], item_path("solver.stages", i)));
        }
    }
    out.wall_time_s = json_number_at(sv.raw("wall_time_s"), "solver.wall_time_s");
    out.initial_cost = optional_cost(sv, "initial_cost");
    out.final_cost = optional_cost(sv, "final_cost");
    out.starts = sv.integer("starts", 0, 0, kMaxIterations);
    out.solve_time_s = sv.number("solve_time_s", 0.0, 0.0, 1e12, "s");
    return out;
}

FitResult read_report_document(const json& j) {
    JsonObject top(j, "");
    top.allow({"model",
               "parameters",
               "not_identifiable",
               "at_bounds",
               "vanished_lobes",
               "metrics",
               "goodness",
               "covariance",
               "samples",
               "residual",
               "loss",
               "solver",
               "data",
               "ground_truth",
               "auto"});
    top.finish();
    FitResult r;
    r.model = brdf::read_model_json(top.raw("model"), "model");
    if (const json* gt = top.find("ground_truth")) {
        r.ground_truth = brdf::read_model_json(*gt, "ground_truth");
    }
    if (const json* a = top.find("auto")) {
        r.automatic = read_auto_choice(*a);
    }
    const json& params = array_key(top, "parameters");
    for (std::size_t i = 0; i < params.size(); ++i) {
        r.parameters.push_back(read_parameter(params[i], item_path("parameters", i)));
    }
    r.not_identifiable = string_list(top, "not_identifiable");
    r.at_bounds = string_list(top, "at_bounds");
    r.vanished_lobes = string_list(top, "vanished_lobes");
    r.metrics = read_metrics(top.raw("metrics"));
    if (const json* gj = top.find("goodness")) {
        r.goodness = read_goodness(*gj);
    }
    if (const json* c = top.find("covariance")) {
        r.covariance_method = text_at(*c, "covariance");
    }
    r.samples = read_sample_counts(top.raw("samples"));
    read_residual_and_loss(top, &r);
    r.solver = read_solver(top.raw("solver"));
    r.data = top.string("data", "", kMaxJsonString);
    return r;
}

}  // namespace

Expected<FitResult> parse_fit_report(const std::string& text, const std::string& name) {
    return read_strict_json(name,
                            [&] { return read_report_document(parse_json_checked(text, name)); });
}

Expected<FitResult> read_fit_report(const std::string& path) {
    Expected<std::string> text = read_input_file(path, kMaxJsonBytes);
    if (!text) {
        return tl::unexpected(text.error());
    }
    return parse_fit_report(*text, path);
}

namespace {

void format_samples(std::ostream& o, const FitResult& r) {
    o << "data: " << r.data << "\n";
    o << "samples: " << r.samples.input << " input, " << r.samples.valid << " valid, "
      << r.samples.used << " used, " << r.samples.reference << " reference, " << r.samples.saturated
      << " saturated, " << r.samples.rejected << " rejected";
    if (!r.samples.rejected_lines.empty()) {
        o << " (lines";
        for (std::size_t i = 0; i < r.samples.rejected_lines.size() && i < 10; ++i) {
            o << " " << r.samples.rejected_lines[i];
        }
        o << (r.samples.rejected_lines.size() > 10 ? " ...)" : ")");
    }
    o << "\n";
}

void format_solver(std::ostream& o, const FitResult& r) {
    char buf[512];
    std::snprintf(buf,
                  sizeof buf,
                  "solver: %s after %d iterations, %d starts, %.3f s (residual %s, loss %s)\n",
                  r.solver.termination.c_str(),
                  r.solver.iterations,
                  r.solver.starts,
                  r.solver.wall_time_s,
                  to_string(r.residual),
                  to_string(r.loss));
    o << buf;
    for (const StageInfo& st : r.solver.stages) {
        std::snprintf(buf,
                      sizeof buf,
                      "  stage %-11s %9zu samples %4d iterations  %-15s %.3f s\n",
                      st.name.c_str(),
                      st.samples,
                      st.iterations,
                      st.termination.c_str(),
                      st.time_s);
        o << buf;
    }
}

void format_bands(std::ostream& o, const std::vector<BandResidual>& bands) {
    if (bands.empty()) {
        return;
    }
    char buf[512];
    o << "  log residual by theta_h band (mean, rmse; r g b):\n";
    for (const BandResidual& b : bands) {
        std::snprintf(buf,
                      sizeof buf,
                      "    [%4g, %4g) deg %9zu  %+.3f %+.3f %+.3f   %.3f %.3f %.3f\n",
                      b.theta_h_lo_deg,
                      b.theta_h_hi_deg,
                      b.count,
                      b.mean_log[0],
                      b.mean_log[1],
                      b.mean_log[2],
                      b.log_rmse[0],
                      b.log_rmse[1],
                      b.log_rmse[2]);
        o << buf;
    }
}

/// The metrics, the warnings and the one headline (printed once) they amount to.
void format_goodness(std::ostream& o, const FitResult& r) {
    char buf[512];
    auto rgb = [&](const char* name, const brdf::Rgbd& v) {
        std::snprintf(buf, sizeof buf, "  %-9s %.6g %.6g %.6g\n", name, v[0], v[1], v[2]);
        o << buf;
    };
    o << "goodness of fit on all " << r.samples.valid << " valid samples (r g b):\n";
    rgb("log_rmse", r.metrics.log_rmse);
    rgb("median_rel", r.metrics.median_rel);
    rgb("rel_rmse", r.metrics.rel_rmse);
    rgb("rmse", r.metrics.rmse);
    if (r.goodness.reduced_chi_square) {
        std::snprintf(
            buf, sizeof buf, "  reduced chi-square %.4g\n", *r.goodness.reduced_chi_square);
        o << buf;
    }
    format_bands(o, r.metrics.bands);
    for (const std::string& w : r.goodness.warnings) {
        o << "warning: " << w << "\n";
    }
    o << "verdict: " << r.goodness.headline;
    if (r.goodness.verdict == Verdict::kDoesNotRepresent) {
        o << " (the parameters are this model's best fit, not a description of the material)";
    }
    o << "\n";
    if (!r.goodness.suggestion.empty()) {
        o << "suggestion: " << r.goodness.suggestion << "\n";
    }
}

void format_parameters(std::ostream& o, const FitResult& r) {
    char buf[512];
    o << "parameters";
    if (!r.covariance_method.empty()) {
        o << " (sigma: " << r.covariance_method << ")";
    }
    o << ":\n";
    for (const FittedParameter& p : r.parameters) {
        std::snprintf(buf, sizeof buf, "  %-26s %14.8g", p.name.c_str(), p.value);
        o << buf;
        if (!p.free) {
            o << "  (fixed)";
        } else if (!p.identifiable) {
            o << "  (not identifiable from these data)";
        } else if (p.sigma) {
            std::snprintf(buf, sizeof buf, "  +- %.3g", *p.sigma);
            o << buf;
        }
        if (!p.at_bound.empty()) {
            o << "  (at its " << p.at_bound << " bound)";
        }
        o << "\n";
    }
    if (!r.at_bounds.empty()) {
        o << "warning: " << r.at_bounds.size()
          << " parameter(s) ended on a bound (the data push them beyond it; the model or the "
             "bounds may not suit these data):";
        for (const std::string& b : r.at_bounds) {
            o << " " << b;
        }
        o << "\n";
    }
    for (const std::string& l : r.vanished_lobes) {
        o << "warning: " << l
          << " vanished (below 1e-3 of the fitted reflectance): the fit describes these data "
             "without it\n";
    }
}

}  // namespace

std::string format_summary(const FitResult& r) {
    std::ostringstream o;
    format_samples(o, r);
    format_solver(o, r);
    if (!r.solver.converged) {
        o << "FIT DID NOT CONVERGE: " << r.solver.message << "\n"
          << "its parameters are not a result and are not shown\n";
        return o.str();
    }
    // Goodness of fit first: whether the parameters below mean anything.
    format_goodness(o, r);
    format_parameters(o, r);
    return o.str();
}

}  // namespace gonio::fitting
