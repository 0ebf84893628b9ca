// Fit reports: JSON on disk and the human-readable summary.

#include "gonio/fitting/report.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/base/atomic_file.h"
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

Expected<brdf::Rgbd> read_rgb(const json& j, const std::string& at) {
    if (!j.is_array() || j.size() != 3) {
        return make_error(at + ": expected [r, g, b]");
    }
    brdf::Rgbd v;
    for (int c = 0; c < 3; ++c) {
        if (!j[c].is_number()) {
            return make_error(at + "[" + std::to_string(c) + "]: expected a number");
        }
        v[c] = j[c].get<double>();
    }
    return v;
}

}  // namespace

std::string report_path_for(const std::string& model_path) {
    const std::string ext = ".json";
    if (model_path.size() > ext.size() && ends_with(model_path, ext)) {
        return model_path.substr(0, model_path.size() - ext.size()) + ".report.json";
    }
    return model_path + ".report.json";
}

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
    j["goodness"] = {{"represents", r.goodness.represents},
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
    return j.dump(2) + "\n";
}

namespace {

/// The verdict written under "fit" in the model file: whether the model represents the data, the
/// figures that decide it, the warnings, the suggestion and the report's file name.
std::string fit_verdict_json(const FitResult& r, const std::string& report_path) {
    const std::size_t slash = report_path.find_last_of('/');
    json v = {{"represents", r.goodness.represents},
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

Expected<FitResult> read_fit_report(const std::string& path) {
    std::ifstream in(path);
    if (!in) {
        return make_error(path + ": cannot open the fit report");
    }
    std::stringstream ss;
    ss << in.rdbuf();
    json j;
    try {
        j = json::parse(ss.str());
    } catch (const json::exception& e) {
        return make_error(path + ": not JSON: " + gonio::json_error_text(e.what()));
    }
    FitResult r;
    try {
        for (const char* key : {"model", "parameters", "metrics", "samples", "solver"}) {
            if (!j.contains(key)) {
                return make_error(path + ": missing key \"" + key + "\"");
            }
        }
        Expected<brdf::ModelD> model = brdf::parse_model_json(j["model"].dump(), path + ": model");
        if (!model) {
            return make_error(model.error().message);
        }
        r.model = *model;
        if (j.contains("ground_truth")) {
            Expected<brdf::ModelD> gt =
                brdf::parse_model_json(j["ground_truth"].dump(), path + ": ground_truth");
            if (!gt) {
                return make_error(gt.error().message);
            }
            r.ground_truth = *gt;
        }
        for (const json& p : j.at("parameters")) {
            FittedParameter fp;
            fp.name = p.at("name").get<std::string>();
            fp.value = p.at("value").is_null() ? std::nan("") : p.at("value").get<double>();
            if (!p.at("sigma").is_null()) {
                fp.sigma = p.at("sigma").get<double>();
            }
            fp.free = p.at("free").get<bool>();
            fp.identifiable = p.at("identifiable").get<bool>();
            if (p.contains("at_bound") && p["at_bound"].is_string()) {
                fp.at_bound = p["at_bound"].get<std::string>();
            }
            r.parameters.push_back(fp);
        }
        if (j.contains("not_identifiable")) {
            r.not_identifiable = j["not_identifiable"].get<std::vector<std::string>>();
        }
        if (j.contains("at_bounds")) {
            r.at_bounds = j["at_bounds"].get<std::vector<std::string>>();
        }
        if (j.contains("vanished_lobes")) {
            r.vanished_lobes = j["vanished_lobes"].get<std::vector<std::string>>();
        }
        const json& m = j.at("metrics");
        for (auto [key, dst] : {std::make_pair("rmse", &r.metrics.rmse),
                                std::make_pair("rel_rmse", &r.metrics.rel_rmse),
                                std::make_pair("log_rmse", &r.metrics.log_rmse)}) {
            Expected<brdf::Rgbd> v = read_rgb(m.at(key), path + ": metrics." + key);
            if (!v) {
                return make_error(v.error().message);
            }
            *dst = *v;
        }
        if (m.contains("median_rel")) {
            Expected<brdf::Rgbd> v = read_rgb(m["median_rel"], path + ": metrics.median_rel");
            if (!v) {
                return make_error(v.error().message);
            }
            r.metrics.median_rel = *v;
        }
        if (m.contains("bands") && m["bands"].is_array()) {
            for (const json& b : m["bands"]) {
                BandResidual br;
                br.theta_h_lo_deg = b.at("theta_h_deg").at(0).get<double>();
                br.theta_h_hi_deg = b.at("theta_h_deg").at(1).get<double>();
                br.count = b.at("count").get<std::size_t>();
                Expected<brdf::Rgbd> mean = read_rgb(b.at("mean_log"), path + ": bands.mean_log");
                Expected<brdf::Rgbd> rm = read_rgb(b.at("log_rmse"), path + ": bands.log_rmse");
                if (!mean || !rm) {
                    return make_error(!mean ? mean.error().message : rm.error().message);
                }
                br.mean_log = *mean;
                br.log_rmse = *rm;
                r.metrics.bands.push_back(br);
            }
        }
        if (j.contains("goodness") && j["goodness"].is_object()) {
            const json& g = j["goodness"];
            r.goodness.represents = g.value("represents", true);
            if (g.contains("reduced_chi_square") && g["reduced_chi_square"].is_number()) {
                r.goodness.reduced_chi_square = g["reduced_chi_square"].get<double>();
            }
            if (g.contains("warnings")) {
                r.goodness.warnings = g["warnings"].get<std::vector<std::string>>();
            }
            r.goodness.suggestion = g.value("suggestion", std::string());
        }
        r.covariance_method = j.value("covariance", std::string());
        const json& s = j.at("samples");
        r.samples.reference = s.value("reference", std::size_t{0});
        r.samples.saturated = s.value("saturated", std::size_t{0});
        r.samples.input = s.at("input").get<std::size_t>();
        r.samples.valid = s.at("valid").get<std::size_t>();
        r.samples.used = s.at("used").get<std::size_t>();
        r.samples.rejected = s.at("rejected").get<std::size_t>();
        r.samples.rejected_lines = s.at("rejected_lines").get<std::vector<std::size_t>>();
        Expected<ResidualForm> form = parse_residual(j.value("residual", std::string("log")));
        Expected<LossKind> loss = parse_loss(j.value("loss", std::string("none")));
        if (!form || !loss) {
            return make_error(path + ": " + (!form ? form.error().message : loss.error().message));
        }
        r.residual = *form;
        r.loss = *loss;
        const json& sv = j.at("solver");
        r.solver.iterations = sv.at("iterations").get<int>();
        r.solver.termination = sv.at("termination").get<std::string>();
        r.solver.message = sv.at("message").get<std::string>();
        r.solver.usable = sv.at("usable").get<bool>();
        r.solver.converged = sv.value("converged", r.solver.usable);
        if (sv.contains("stages") && sv["stages"].is_array()) {
            for (const json& st : sv["stages"]) {
                StageInfo si;
                si.name = st.at("name").get<std::string>();
                si.samples = st.at("samples").get<std::size_t>();
                si.iterations = st.at("iterations").get<int>();
                si.termination = st.at("termination").get<std::string>();
                si.time_s = st.at("time_s").get<double>();
                if (st.contains("final_cost") && st["final_cost"].is_number()) {
                    si.final_cost = st["final_cost"].get<double>();
                }
                r.solver.stages.push_back(si);
            }
        }
        r.solver.wall_time_s = sv.at("wall_time_s").get<double>();
        if (sv.contains("initial_cost") && sv["initial_cost"].is_number()) {
            r.solver.initial_cost = sv["initial_cost"].get<double>();
        }
        if (sv.contains("final_cost") && sv["final_cost"].is_number()) {
            r.solver.final_cost = sv["final_cost"].get<double>();
        }
        r.solver.starts = sv.value("starts", 0);
        r.solver.solve_time_s = sv.value("solve_time_s", 0.0);
        r.data = j.value("data", std::string());
    } catch (const json::exception& e) {
        return make_error(path + ": malformed fit report: " + gonio::json_error_text(e.what()));
    }
    return r;
}

std::string format_summary(const FitResult& r) {
    std::ostringstream o;
    char buf[512];
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
    if (!r.solver.converged) {
        o << "FIT DID NOT CONVERGE: " << r.solver.message << "\n"
          << "its parameters are not a result and are not shown\n";
        return o.str();
    }
    // Goodness of fit first: whether the parameters below mean anything.
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
    if (!r.metrics.bands.empty()) {
        o << "  log residual by theta_h band (mean, rmse; r g b):\n";
        for (const BandResidual& b : r.metrics.bands) {
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
    for (const std::string& w : r.goodness.warnings) {
        o << "warning: " << w << "\n";
    }
    if (!r.goodness.represents) {
        o << "MISFIT: the model does not represent these data (the parameters are its best fit, "
             "not a description of the material)";
        if (!r.goodness.suggestion.empty()) {
            o << "; " << r.goodness.suggestion;
        }
        o << "\n";
    } else if (!r.goodness.suggestion.empty()) {
        o << "suggestion: " << r.goodness.suggestion << "\n";
    }
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
            o << "  AT " << p.at_bound << " BOUND";
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
    return o.str();
}

}  // namespace gonio::fitting
