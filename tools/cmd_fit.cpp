// gonio fit DATA [--model ggx] [--out fit.json]      fit an analytic model to measured samples
// gonio fit --compare ggx,beckmann,blinn-phong DATA  fit several models, table ranked by error
// gonio fit --model auto DATA                        candidates ranked by BIC, the winner polished

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.h"
#include "fit_manifest.h"
#include "gonio/base/atomic_file.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"
#include "gonio/fitting/spec.h"

namespace {

namespace fitting = gonio::fitting;

struct FitCliOptions {
    std::string data;
    std::string model = "ggx";
    std::string template_path;
    bool no_diffuse = false;
    std::string fresnel = "schlick";
    std::string shadowing = "smith-correlated";
    bool anisotropic = false;
    int lobes = 1;
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

/// The spec from the command line (or the template) and the options; prints the error.
gonio::Expected<fitting::FitSpec> build_spec(const FitCliOptions& o, const std::string& model) {
    gonio::Expected<fitting::FitSpec> spec = gonio::make_error("");
    if (!o.template_path.empty()) {
        spec = fitting::load_fit_template(o.template_path);
    } else {
        fitting::ModelOptions mo;
        auto dist = fitting::parse_distribution(model);
        auto fres = fitting::parse_fresnel(o.fresnel);
        auto shad = fitting::parse_shadowing(o.shadowing);
        for (const gonio::Error* e : {dist ? nullptr : &dist.error(),
                                      fres ? nullptr : &fres.error(),
                                      shad ? nullptr : &shad.error()}) {
            if (e != nullptr) {
                return gonio::make_error(e->message);
            }
        }
        mo.distribution = *dist;
        mo.fresnel = fres->first;
        mo.fresnel_rgb = fres->second;
        mo.shadowing = *shad;
        mo.diffuse = !o.no_diffuse;
        mo.anisotropic = o.anisotropic;
        mo.lobes = o.lobes;
        spec = fitting::make_fit_spec(mo);
    }
    if (!spec) {
        return spec;
    }
    auto residual = fitting::parse_residual(o.residual);
    if (!residual) {
        return gonio::make_error(residual.error().message);
    }
    auto loss = fitting::parse_loss(o.loss);
    if (!loss) {
        return gonio::make_error(loss.error().message);
    }
    spec->options.residual = *residual;
    spec->options.loss = *loss;
    spec->options.loss_scale = o.loss_scale;
    spec->options.max_samples = o.max_samples;
    spec->options.starts = o.starts;
    spec->options.seed = o.seed;
    spec->options.max_iterations = o.max_iterations;
    spec->options.num_threads = o.threads;
    return spec;
}

int run_compare(const FitCliOptions& o, const gonio::brdf::Dataset& data) {
    struct Row {
        std::string model;
        fitting::FitResult result;
    };
    std::vector<Row> rows;
    std::vector<std::string> failed;
    std::vector<std::string> misfits;
    for (const std::string& name : split(o.compare)) {
        auto spec = build_spec(o, name);
        if (!spec) {
            std::fprintf(stderr, "gonio fit: %s\n", spec.error().message.c_str());
            return 2;
        }
        auto r = fitting::fit(data, *spec);
        if (!r) {
            std::fprintf(stderr, "gonio fit: %s: %s\n", name.c_str(), r.error().message.c_str());
            return 1;
        }
        if (!r->solver.converged) {
            failed.push_back(name + ": " + r->solver.termination + " (" + r->solver.message + ")");
            continue;
        }
        if (!r->usable()) {
            // A misfit is ranked with the others (its figures are what that model can do).
            misfits.push_back(name);
        }
        rows.push_back({name, *r});
    }
    auto mean = [](const gonio::brdf::Rgbd& v) { return v.mean(); };
    std::sort(rows.begin(), rows.end(), [&](const Row& a, const Row& b) {
        return mean(a.result.metrics.log_rmse) < mean(b.result.metrics.log_rmse);
    });
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
        std::printf("%-4zu %-12s %12.6g %12.6g %12.6g %6d %9.3f%s\n",
                    i + 1,
                    rows[i].model.c_str(),
                    mean(r.metrics.log_rmse),
                    mean(r.metrics.rel_rmse),
                    mean(r.metrics.rmse),
                    r.solver.iterations,
                    r.solver.wall_time_s,
                    r.usable() ? "" : "  (misfit: does not represent the data)");
    }
    std::printf("(errors are channel means over all %zu valid samples; ranked by log_rmse)\n",
                rows.empty() ? std::size_t{0} : rows[0].result.samples.valid);
    for (const std::string& f : failed) {
        std::printf("did not converge, not ranked: %s\n", f.c_str());
    }
    for (const std::string& m : misfits) {
        std::fprintf(stderr,
                     "gonio fit: %s: %s does not represent these data\n",
                     o.strict ? "error" : "warning",
                     m.c_str());
    }
    return failed.empty() && (misfits.empty() || !o.strict) ? 0 : 1;
}

}  // namespace

GONIO_COMMAND(fit) {
    auto* cmd = app.add_subcommand("fit", "fit an analytic BRDF model to measured samples (Ceres)");
    auto o = std::make_shared<FitCliOptions>();
    cmd->add_option("data",
                    o->data,
                    "samples: dataset CSV, table (MERL .binary, .gtab) or RGL material (.bsdf)");
    cmd->add_option("--model",
                    o->model,
                    "lobe distribution: ggx, beckmann, blinn-phong, student-t, or auto (candidates "
                    "ranked by "
                    "BIC on the reduction, the winner polished on all samples)")
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
    cmd->add_flag("--anisotropic", o->anisotropic, "fit alpha_x and alpha_y separately");
    cmd->add_option("--lobes", o->lobes, "number of specular lobes (0-4)")->capture_default_str();
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
    cmd->add_option("--truth", o->truth, "ground-truth model JSON, copied into the report");
    cmd->add_option("--compare",
                    o->compare,
                    "comma-separated models to fit and rank, e.g. ggx,beckmann,blinn-phong");
    cmd->add_option("--manifest", o->manifest, "fit every entry of a manifest CSV into --out DIR")
        ->excludes("data");
    cmd->add_option("--shard",
                    o->shard,
                    "with --manifest: only entries i with i mod N == K (--threads, if given, "
                    "applies to every entry)")
        ->needs("--manifest");
    return [o, cmd]() -> int {
        if (!o->manifest.empty()) {
            const int threads = cmd->count("--threads") > 0 ? o->threads : -1;
            return gonio::tools::run_fit_manifest(
                o->manifest, o->shard, o->out, threads, o->strict);
        }
        if (o->data.empty()) {
            std::fprintf(stderr, "gonio fit: give DATA (or --manifest M --out DIR)\n");
            return 2;
        }
        if (!o->out.empty()) {
            // Refused before the fit runs: an output that is a folder, a device, a missing folder.
            for (const std::string& p : {o->out, fitting::report_path_for(o->out)}) {
                if (auto ok = gonio::check_output_path(p); !ok) {
                    std::fprintf(stderr, "gonio fit: %s\n", ok.error().message.c_str());
                    return 1;
                }
            }
        }
        auto data = gonio::brdf::load_samples(o->data);
        if (!data) {
            std::fprintf(stderr, "gonio fit: %s\n", data.error().message.c_str());
            return 1;
        }
        if (!o->compare.empty()) {
            return run_compare(*o, *data);
        }
        const bool automatic = o->model == "auto" && o->template_path.empty();
        auto spec = build_spec(*o, automatic ? std::string("ggx") : o->model);
        if (!spec) {
            std::fprintf(stderr, "gonio fit: %s\n", spec.error().message.c_str());
            return 2;
        }
        gonio::Expected<fitting::FitResult> result = gonio::make_error("");
        if (automatic) {
            auto chosen = fitting::fit_auto(*data, fitting::auto_candidates(spec->options));
            if (!chosen) {
                std::fprintf(stderr, "gonio fit: %s\n", chosen.error().message.c_str());
                return 1;
            }
            std::printf("model auto: %s\n", chosen->criterion.c_str());
            std::printf("%-4s %-12s %6s %12s %16s\n", "rank", "model", "params", "log_rmse", "BIC");
            for (std::size_t i = 0; i < chosen->ranking.size(); ++i) {
                const fitting::RankedModel& m = chosen->ranking[i];
                std::printf("%-4zu %-12s %6d %12.6g %16.8g%s\n",
                            i + 1,
                            m.name.c_str(),
                            m.parameters,
                            m.log_rmse,
                            m.criterion,
                            m.converged ? "" : "  (did not converge)");
            }
            std::printf("chosen: %s\n", chosen->chosen.c_str());
            result = chosen->best;
        } else {
            result = fitting::fit(*data, *spec);
        }
        if (!result) {
            std::fprintf(stderr, "gonio fit: %s\n", result.error().message.c_str());
            return 1;
        }
        if (!o->truth.empty()) {
            auto truth = gonio::brdf::load_model_json(o->truth);
            if (!truth) {
                std::fprintf(stderr, "gonio fit: %s\n", truth.error().message.c_str());
                return 2;
            }
            result->ground_truth = *truth;
        }
        std::fputs(fitting::format_summary(*result).c_str(), stdout);
        if (!o->out.empty()) {
            auto w = fitting::write_fit_report(o->out, *result);
            if (!w) {
                std::fprintf(stderr, "gonio fit: %s\n", w.error().message.c_str());
                return 1;
            }
            std::printf(
                "wrote %s and %s\n", o->out.c_str(), fitting::report_path_for(o->out).c_str());
        }
        if (!result->solver.converged) {
            std::fprintf(stderr,
                         "gonio fit: the fit did not converge (%s): %s\n",
                         result->solver.termination.c_str(),
                         result->solver.message.c_str());
            return 1;
        }
        if (!result->usable()) {
            // A converged misfit is a finding: the best fit of that model, written with its
            // verdict. Scripts that want it to fail ask for --strict.
            std::fprintf(stderr,
                         "gonio fit: %s: the model does not represent these data (%s); %s\n",
                         o->strict ? "error" : "warning",
                         result->goodness.warnings.empty()
                             ? "see the report"
                             : result->goodness.warnings.front().c_str(),
                         result->goodness.suggestion.c_str());
            return o->strict ? 1 : 0;
        }
        return 0;
    };
}
