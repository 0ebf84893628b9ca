// gonio fit DATA [--out fit.json]                    candidates ranked by BIC, the winner polished
// gonio fit DATA --model ggx [--out fit.json]        fit one analytic model to measured samples
// gonio fit --compare ggx,beckmann,blinn-phong DATA  fit several models, table ranked by error

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "command.h"
#include "fit_manifest.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/strings.h"
#include "gonio/batch/fit_policy.h"
#include "gonio/batch/fit_request.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"
#include "gonio/fitting/spec.h"
#include "option_checks.h"

namespace {

namespace fitting = gonio::fitting;
namespace batch = gonio::batch;

struct FitCliOptions {
    std::string data;
    std::string model = gonio::batch::kAutoModel;
    std::string template_path;
    bool no_diffuse = false;
    std::string fresnel = gonio::batch::default_fresnel();
    std::string shadowing = gonio::batch::default_shadowing();
    bool anisotropic = false;
    int lobes = 1;
    std::string roughness = "shared";
    std::string residual = "log";
    std::string loss = "none";
    double loss_scale = 0.1;
    std::size_t max_samples = 0;
    int starts = 6;
    std::uint64_t seed = 1;
    int max_iterations = 200;
    int threads = 0;
    std::string out;
    std::string compare;
    std::string truth;
    std::string manifest;
    std::string shard;
    bool strict = false;
    bool verbose = false;
};

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        if (!item.empty()) {
            out.push_back(item);
        }
    }
    return out;
}

/// The request options the command line gave (only those: the rest keep the request's defaults),
/// as (request key, value text, option as typed).
struct GivenOption {
    const char* key;
    std::string value;
    const char* flag;
};

std::vector<GivenOption> given_options(const FitCliOptions& o, const CLI::App& cmd) {
    std::vector<GivenOption> out;
    auto add = [&](const char* flag, const char* key, std::string value) {
        if (cmd.count(flag) > 0) {
            out.push_back({key, std::move(value), flag});
        }
    };
    add("--no-diffuse", "diffuse", o.no_diffuse ? "false" : "true");
    add("--fresnel", "fresnel", o.fresnel);
    add("--shadowing", "shadowing", o.shadowing);
    add("--anisotropic", "anisotropic", o.anisotropic ? "true" : "false");
    add("--lobes", "lobes", std::to_string(o.lobes));
    add("--roughness", "roughness", o.roughness);
    add("--residual", "residual", o.residual);
    add("--loss", "loss", o.loss);
    std::ostringstream scale;
    scale.precision(17);
    scale << o.loss_scale;
    add("--loss-scale", "loss_scale", scale.str());
    add("--max-samples", "max_samples", std::to_string(o.max_samples));
    add("--starts", "starts", std::to_string(o.starts));
    add("--seed", "seed", std::to_string(o.seed));
    add("--max-iterations", "max_iterations", std::to_string(o.max_iterations));
    add("--threads", "threads", std::to_string(o.threads));
    return out;
}

/// The model of a fit that names none (no --model, no --template): auto, unless an option of the
/// model's structure is given (--lobes, --fresnel, ...), which describes one family: then the
/// fitting library's default distribution (ggx), with that structure.
std::string default_model(const std::vector<GivenOption>& given) {
    for (const GivenOption& g : given) {
        for (const char* key :
             {"fresnel", "shadowing", "diffuse", "anisotropic", "lobes", "roughness"}) {
            if (std::string(key) == g.key) {
                return gonio::batch::default_distribution();
            }
        }
    }
    return gonio::batch::kAutoModel;
}

/// The option as typed for a request key (for messages).
std::string flag_for(const std::vector<GivenOption>& given, const std::string& key) {
    for (const GivenOption& g : given) {
        if (key == g.key) {
            return g.flag;
        }
    }
    std::string flag = "--" + key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    return flag;
}

/// Applies the given options to a request; a bad value or a conflict is a usage error whose
/// message names the options as typed. `model_flag` names the option that set the model.
gonio::Expected<void> apply(gonio::batch::FitRequest& request,
                            const std::vector<GivenOption>& given,
                            const std::string& model_flag) {
    for (const GivenOption& g : given) {
        if (auto s = gonio::batch::set_option(request, g.key, g.value); !s) {
            return gonio::make_error(std::string(g.flag) + ": " + s.error().message);
        }
    }
    if (auto c = gonio::batch::find_conflict(request)) {
        return gonio::make_error(flag_for(given, c->option) + " cannot be combined with " +
                                 model_flag + ": " + c->rule);
    }
    return {};
}

int run_compare(const std::vector<gonio::batch::FitRequest>& requests,
                const gonio::brdf::Dataset& data,
                bool strict) {
    auto compared = gonio::batch::compare_fits(data, requests);
    if (!compared) {
        std::fprintf(stderr, "gonio fit: %s\n", compared.error().message.c_str());
        return 1;
    }
    const std::vector<gonio::batch::ComparedFit>& rows = compared->ranked;
    auto mean = [](const gonio::brdf::Rgbd& v) { return v.mean(); };
    std::printf("%-4s %-12s %12s %12s %12s %6s %9s\n",
                "rank",
                "model",
                "log_rmse",
                "rel_rmse",
                "rmse",
                "iters",
                "time_s");
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const fitting::FitResult& r = rows[i].result;
        std::printf("%-4zu %-12s %12.6g %12.6g %12.6g %6d %9.3f  %s\n",
                    i + 1,
                    rows[i].model.c_str(),
                    mean(r.metrics.log_rmse),
                    mean(r.metrics.rel_rmse),
                    mean(r.metrics.rmse),
                    r.solver.iterations,
                    r.solver.wall_time_s,
                    r.goodness.headline.c_str());
    }
    std::printf("(errors are channel means over all %zu valid samples; ranked by log_rmse)\n",
                rows.empty() ? std::size_t{0} : rows[0].result.samples.valid);
    for (const std::string& f : compared->not_converged) {
        std::printf("did not converge, not ranked: %s\n", f.c_str());
    }
    const int status = gonio::batch::exit_status(*compared, strict);
    if (status != 0 && strict && compared->not_converged.empty()) {
        std::fprintf(stderr,
                     "gonio fit: --strict: a compared model does not represent these data\n");
    }
    return status;
}

/// The options of `gonio fit`, each stored in `o`.
void add_fit_options(CLI::App* cmd, FitCliOptions& o_ref) {
    FitCliOptions* o = &o_ref;
    cmd->add_option("data",
                    o->data,
                    "samples: dataset CSV, table (MERL .binary, .gtab) or RGL material (.bsdf)")
        ->check(gonio::tools::readable_input());
    cmd->add_option(
           "--model",
           o->model,
           "lobe distribution: auto (the default: each candidate fitted on a reduction "
           "and ranked by BIC on all samples, the winner fitted on all samples and named), "
           "ggx, beckmann, blinn-phong, student-t, or tabulated (D extracted from the data "
           "by power iteration). Without --model, an option of the structure (--lobes, "
           "--fresnel, --shadowing, --no-diffuse, --anisotropic, --roughness) fits ggx "
           "with it")
        ->capture_default_str();
    cmd->add_option("--template",
                    o->template_path,
                    "JSON fit template (model + free/fixed/shared/bounds) instead of --model");
    cmd->add_flag("--no-diffuse", o->no_diffuse, "no Lambertian term");
    cmd->add_option("--fresnel", o->fresnel, "schlick, schlick-rgb, dielectric, conductor, none")
        ->capture_default_str();
    cmd->add_option(
           "--shadowing", o->shadowing, "smith-correlated, smith-separable, v-groove, none")
        ->capture_default_str();
    cmd->add_flag("--anisotropic",
                  o->anisotropic,
                  "fit alpha_x, alpha_y and the lobe's orientation_deg on the sample");
    cmd->add_option("--lobes", o->lobes, "number of specular lobes (0-4)")->capture_default_str();
    cmd->add_option("--roughness",
                    o->roughness,
                    "shared (one alpha for the three channels) or rgb (one alpha per channel; "
                    "isotropic ggx, beckmann, student-t)")
        ->capture_default_str();
    cmd->add_option("--residual", o->residual, "absolute, relative, log, cosine, cbrt")
        ->capture_default_str();
    cmd->add_option("--loss", o->loss, "robust loss: none, huber, cauchy")->capture_default_str();
    cmd->add_option("--loss-scale", o->loss_scale, "scale of the robust loss (residual units)")
        ->capture_default_str();
    cmd->add_option("--max-samples",
                    o->max_samples,
                    "stratified reduction to about N samples (0 = all); metrics use all")
        ->capture_default_str();
    cmd->add_option("--starts", o->starts, "multi-start candidates over alpha")
        ->capture_default_str();
    cmd->add_option("--seed", o->seed, "seed of the multi-start and the reduction")
        ->capture_default_str();
    cmd->add_option("--max-iterations", o->max_iterations, "solver iteration limit")
        ->capture_default_str();
    cmd->add_option("--threads", o->threads, "solver threads (0 = all cores)")
        ->capture_default_str();
    cmd->add_option("--out", o->out, "write the fitted model here and the report beside it");
    cmd->add_flag("--strict",
                  o->strict,
                  "exit 1 when the model does not represent the data (a misfit is otherwise "
                  "written, reported on stderr, and exits 0)");
    cmd->add_flag("--verbose", o->verbose, "print the request as run (every option, defaults too)");
    cmd->add_option("--truth", o->truth, "ground-truth model JSON, copied into the report")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--compare",
                    o->compare,
                    "comma-separated models to fit and rank, e.g. ggx,beckmann,blinn-phong");
    cmd->add_option("--manifest", o->manifest, "fit every entry of a manifest CSV into --out DIR")
        ->excludes("data")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--shard",
                    o->shard,
                    "with --manifest: only entries i with i mod N == K (--threads, if given, "
                    "applies to every entry)")
        ->needs("--manifest");
    cmd->get_option("--loss-scale")->check(gonio::tools::finite_above(0));
}

/// The run of `--manifest M`: each entry names its input and model; the other options apply to
/// every entry.
int run_manifest(const FitCliOptions& o,
                 const CLI::App& cmd,
                 const std::vector<GivenOption>& given) {
    for (const char* flag : {"--model", "--template", "--compare", "--truth"}) {
        if (cmd.count(flag) > 0) {
            return gonio::tools::usage_error("fit",
                                             std::string(flag) +
                                                 " cannot be combined with --manifest (each entry "
                                                 "names its input and model; the other options "
                                                 "apply to every entry)");
        }
    }
    std::vector<std::pair<std::string, std::string>> overrides;
    for (const GivenOption& g : given) {
        overrides.emplace_back(g.key, g.value);
    }
    return gonio::tools::run_fit_manifest(o.manifest, o.shard, o.out, overrides, o.strict);
}

/// The requests of `--compare a,b,...`, or the exit status of a usage error.
std::optional<int> compare_requests(const FitCliOptions& o,
                                    const CLI::App& cmd,
                                    const std::vector<GivenOption>& given,
                                    std::vector<batch::FitRequest>& requests) {
    using gonio::tools::usage_error;
    for (const char* flag : {"--model", "--template", "--out", "--truth"}) {
        if (cmd.count(flag) > 0) {
            return usage_error("fit",
                               std::string(flag) +
                                   " cannot be combined with --compare (it fits and ranks each "
                                   "listed model or *.json template; nothing is written)");
        }
    }
    for (const std::string& name : split(o.compare)) {
        batch::FitRequest request;
        if (name == batch::kAutoModel) {
            return usage_error(
                "fit",
                "--compare " + o.compare + ": auto is no model to compare; use --model auto");
        }
        if (auto s = batch::set_option(request, "model", name); !s) {
            return usage_error("fit", "--compare: " + s.error().message);
        }
        if (auto a = apply(request, given, "--compare " + name); !a) {
            return usage_error("fit", a.error().message);
        }
        requests.push_back(std::move(request));
    }
    if (requests.empty()) {
        return usage_error("fit", "--compare: no model named");
    }
    return std::nullopt;
}

/// The one request of a fit (--model, --template, or neither: default_model), or the exit status
/// of a usage error.
std::optional<int> single_request(FitCliOptions& o,
                                  const CLI::App& cmd,
                                  const std::vector<GivenOption>& given,
                                  std::vector<batch::FitRequest>& requests) {
    using gonio::tools::usage_error;
    const bool model_given = cmd.count("--model") > 0;
    const bool template_given = cmd.count("--template") > 0;
    batch::FitRequest request;
    if (model_given && template_given) {
        return usage_error("fit", "--model and --template: give one of them");
    }
    if (!model_given) {
        o.model = default_model(given);
    }
    const std::string model_flag = template_given ? "--template" : "--model " + o.model;
    if (auto s = batch::set_option(request, "model", template_given ? o.template_path : o.model);
        !s) {
        return usage_error(
            "fit",
            std::string(template_given ? "--template" : "--model") + ": " + s.error().message);
    }
    if (template_given && !gonio::ends_with(o.template_path, ".json")) {
        return usage_error("fit",
                           "--template " + o.template_path + ": expected a *.json fit template");
    }
    if (auto a = apply(request, given, model_flag); !a) {
        return usage_error("fit", a.error().message);
    }
    requests.push_back(std::move(request));
    return std::nullopt;
}

/// Everything named on the command line, built, read or checked before any work: each request's
/// spec (an option the structure cannot take is a usage error), the --truth model and the --out
/// paths. The exit status of a refusal, else empty (`truth` filled when given).
std::optional<int> check_before_work(const FitCliOptions& o,
                                     const std::vector<batch::FitRequest>& requests,
                                     std::optional<gonio::brdf::ModelD>& truth) {
    using gonio::tools::usage_error;
    for (const batch::FitRequest& request : requests) {
        if (auto spec = batch::make_fit_spec(request); !spec) {
            return usage_error("fit", spec.error().message);
        }
    }
    if (o.verbose) {
        // The request as run (every option, defaults included).
        for (const batch::FitRequest& request : requests) {
            std::printf("request: %s\n", batch::format_options(request).c_str());
        }
        std::fflush(stdout);
    }
    if (!o.truth.empty()) {
        auto t = gonio::brdf::load_model_json(o.truth);
        if (!t) {
            return usage_error("fit", "--truth: " + t.error().message);
        }
        truth = *t;
    }
    if (!o.out.empty()) {
        // Refused before the fit runs: an output that is a folder, a device, a missing folder.
        for (const std::string& p : {o.out, fitting::report_path_for(o.out)}) {
            if (auto ok = gonio::check_output_path(p); !ok) {
                std::fprintf(stderr, "gonio fit: %s\n", ok.error().message.c_str());
                return 1;
            }
        }
    }
    return std::nullopt;
}

/// The fit of one request: the ranking of an automatic choice, the summary, the files, the exit
/// status (batch::exit_status).
int run_single(const FitCliOptions& o,
               const batch::FitRequest& request,
               const gonio::brdf::Dataset& data,
               const std::optional<gonio::brdf::ModelD>& truth) {
    auto run = batch::run_fit(data, request);
    if (!run) {
        std::fprintf(stderr, "gonio fit: %s\n", run.error().message.c_str());
        return 1;
    }
    fitting::FitResult& result = run->result;
    if (result.automatic) {
        std::fputs(fitting::format_auto_choice(*result.automatic).c_str(), stdout);
    }
    result.ground_truth = truth;
    std::fputs(fitting::format_summary(result).c_str(), stdout);
    if (!o.out.empty()) {
        auto w = fitting::write_fit_report(o.out, result);
        if (!w) {
            std::fprintf(stderr, "gonio fit: %s\n", w.error().message.c_str());
            return 1;
        }
        std::printf("wrote %s and %s\n", o.out.c_str(), fitting::report_path_for(o.out).c_str());
    } else {
        std::printf(
            "nothing written: give --out FILE.json to write the model (with its "
            "verdict) and FILE.report.json\n");
    }
    if (!result.solver.converged) {
        std::fprintf(stderr,
                     "gonio fit: the fit did not converge (%s): %s\n",
                     result.solver.termination.c_str(),
                     result.solver.message.c_str());
    }
    const int status = batch::exit_status(result, o.strict);
    if (status != 0 && result.solver.converged) {
        // The verdict itself is in the summary above (printed once); --strict makes it fail.
        std::fprintf(stderr, "gonio fit: --strict: the model does not represent these data\n");
    }
    return status;
}

/// `gonio fit` as the command line asked: a manifest, a comparison or one fit.
int run_fit_command(FitCliOptions& o, const CLI::App& cmd) {
    const std::vector<GivenOption> given = given_options(o, cmd);
    if (!o.manifest.empty()) {
        return run_manifest(o, cmd, given);
    }
    if (o.data.empty()) {
        return gonio::tools::usage_error("fit", "give DATA (or --manifest M --out DIR)");
    }
    std::vector<batch::FitRequest> requests;
    if (std::optional<int> refused = o.compare.empty()
                                         ? single_request(o, cmd, given, requests)
                                         : compare_requests(o, cmd, given, requests)) {
        return *refused;
    }
    std::optional<gonio::brdf::ModelD> truth;
    if (std::optional<int> refused = check_before_work(o, requests, truth)) {
        return *refused;
    }
    auto data = gonio::brdf::load_samples(o.data);
    if (!data) {
        std::fprintf(stderr, "gonio fit: %s\n", data.error().message.c_str());
        return 1;
    }
    if (!o.compare.empty()) {
        return run_compare(requests, *data, o.strict);
    }
    return run_single(o, requests.front(), *data, truth);
}

}  // namespace

GONIO_COMMAND(fit) {
    auto* cmd = app.add_subcommand("fit", "fit an analytic BRDF model to measured samples (Ceres)");
    auto o = std::make_shared<FitCliOptions>();
    add_fit_options(cmd, *o);
    return [o, cmd]() -> int { return run_fit_command(*o, *cmd); };
}
