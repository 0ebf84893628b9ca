#include "acquire_fit_check.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "gonio/batch/fit_request.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/fitting/cost.h"

namespace gonio::tools {

namespace {

/// RMS of (prediction - value) / sigma over the channels with a sigma.
double holdout_rms_z(const brdf::Brdf& model, const std::vector<brdf::Sample>& holdout) {
    double sum = 0;
    std::size_t n = 0;
    for (const brdf::Sample& s : holdout) {
        const brdf::Rgbd predicted = model.eval(s.wi(), s.wo());
        for (int c = 0; c < 3; ++c) {
            if (s.sigma[c] > 0 && std::isfinite(predicted[c])) {
                const double z = (predicted[c] - s.value[c]) / s.sigma[c];
                sum += z * z;
                ++n;
            }
        }
    }
    return n == 0 ? std::numeric_limits<double>::infinity() : std::sqrt(sum / n);
}

/// The parameters that scale the BRDF as a whole per channel ("diffuse[0]", "lobes[0].scale[1]").
bool is_amplitude(const std::string& name) {
    return name.rfind("diffuse", 0) == 0 || name.find(".scale") != std::string::npos;
}

double luminance(const brdf::Rgbd& v) {
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

/// The fitted model's luminance at every candidate.
std::vector<double> luminance_at(const brdf::ModelD& model,
                                 const std::vector<acquisition::PlannedConfig>& candidates) {
    const auto f = brdf::make_analytic_brdf(model);
    std::vector<double> out;
    out.reserve(candidates.size());
    for (const acquisition::PlannedConfig& c : candidates) {
        out.push_back(luminance(f->eval(c.wi, c.wo)));
    }
    return out;
}

/// d ln f / d p of every candidate for the parameters of the covariance (central differences
/// of a step 1e-4 of the parameter's size), row-major candidates x parameters; false when a
/// parameter is not among the fit's scalars.
bool log_jacobian(const fitting::FitResult& fit,
                  const fitting::ParameterMap& map,
                  const std::vector<acquisition::PlannedConfig>& candidates,
                  std::vector<double>* jacobian) {
    const std::size_t p = fit.covariance.names.size();
    jacobian->assign(candidates.size() * p, 0.0);
    for (std::size_t k = 0; k < p; ++k) {
        const fitting::ScalarParam* sp = nullptr;
        for (const fitting::ScalarParam& s : map.scalars()) {
            if (s.name == fit.covariance.names[k]) {
                sp = &s;
            }
        }
        if (!sp) {
            return false;
        }
        const double x = map.value_of(fit.model, *sp);
        const double h = 1e-4 * std::max(std::abs(x), 1e-3);
        brdf::ModelD lo = fit.model, hi = fit.model;
        fitting::ParameterMap::set(lo, *sp, x - h);
        fitting::ParameterMap::set(hi, *sp, x + h);
        const std::vector<double> fl = luminance_at(lo, candidates);
        const std::vector<double> fh = luminance_at(hi, candidates);
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            const double d =
                fl[i] > 0 && fh[i] > 0 ? (std::log(fh[i]) - std::log(fl[i])) / (2 * h) : 0.0;
            (*jacobian)[i * p + k] = std::isfinite(d) ? d : 0.0;
        }
    }
    return true;
}

/// "ggx: lobes[0].alpha_x 0.0502 +- 0.0011, ..." for the record.
std::string fit_summary(const fitting::FitResult& fit) {
    std::string s = fit.model.lobes.empty()
                        ? std::string("diffuse")
                        : std::string(brdf::to_string(fit.model.lobes[0].distribution));
    s += fit.solver.usable ? "" : " (" + fit.goodness.headline + ")";
    int n = 0;
    for (const fitting::FittedParameter& p : fit.parameters) {
        if (!p.free || p.name.find("alpha") == std::string::npos || n++ > 2) {
            continue;
        }
        char buf[96];
        std::snprintf(buf, sizeof buf, ", %s %.4g", p.name.c_str(), p.value);
        s += buf;
        if (p.sigma) {
            std::snprintf(buf, sizeof buf, " +- %.2g", *p.sigma);
            s += buf;
        }
    }
    return s;
}

}  // namespace

acquisition::PlanFitFn default_plan_fit() {
    return [](const std::vector<brdf::Sample>& measured,
              const std::vector<acquisition::PlannedConfig>& candidates,
              bool anisotropic) -> Expected<acquisition::PlanFit> {
        brdf::Dataset ds;
        ds.source = "the campaign's values so far";
        ds.has_sigma = ds.has_weight = ds.has_flags = true;
        ds.samples = measured;
        batch::FitRequest request;
        request.threads = 1;  // deterministic, and the rig's thread keeps a core
        request.anisotropic = anisotropic;
        auto run = batch::run_fit(ds, request);
        if (!run) {
            return tl::unexpected(run.error());
        }
        const fitting::FitResult& fit = run->result;
        acquisition::PlanFit out;
        out.summary = fit_summary(fit);
        // A converged fit that misfits is still the model's best: its residuals show where.
        if (!fit.solver.converged) {
            return make_error("the fit did not converge (" + fit.solver.termination + ")");
        }
        auto spec = batch::make_fit_spec(request);
        if (!spec) {
            return tl::unexpected(spec.error());
        }
        auto map = fitting::ParameterMap::make(*spec);
        if (!map) {
            return tl::unexpected(map.error());
        }
        out.view.predicted = luminance_at(fit.model, candidates);
        const auto f = brdf::make_analytic_brdf(fit.model);
        for (const brdf::Sample& s : measured) {
            out.at_measured.push_back(luminance(f->eval(s.wi(), s.wo())));
        }
        if (!fit.covariance.names.empty() &&
            log_jacobian(fit, *map, candidates, &out.view.jacobian)) {
            out.view.parameters = static_cast<int>(fit.covariance.names.size());
            out.view.covariance = fit.covariance.matrix;
        }
        return out;
    };
}

acquisition::FitCheckFn default_fit_check() {
    return [](const std::vector<brdf::Sample>& fit,
              const std::vector<brdf::Sample>& holdout,
              double common_rel_sigma,
              bool anisotropic) -> Expected<acquisition::FitCheck> {
        brdf::Dataset ds;
        ds.source = "the campaign's values so far";
        ds.has_sigma = ds.has_weight = ds.has_flags = true;
        ds.samples = fit;
        batch::FitRequest request;
        request.threads = 1;  // the campaign thread waits for it; one core leaves the rig its own
        request.anisotropic = anisotropic;
        auto run = batch::run_fit(ds, request);
        if (!run) {
            return tl::unexpected(run.error());
        }
        acquisition::FitCheck c;
        c.usable = run->result.usable();
        c.fitted = fit.size();
        c.held_out = holdout.size();
        for (const fitting::FittedParameter& p : run->result.parameters) {
            if (!p.free) {
                continue;
            }
            // A parameter without a sigma (not identifiable) is not known at all. An amplitude
            // carries the uncertainty every value shares on top of the fit's own.
            const double shared = is_amplitude(p.name) ? common_rel_sigma : 0.0;
            const double rel = p.sigma && p.value != 0 ? std::hypot(*p.sigma / p.value, shared)
                                                       : std::numeric_limits<double>::infinity();
            if (rel >= c.max_rel_sigma || c.worst.empty()) {
                c.max_rel_sigma = rel;
                c.worst = p.name;
            }
            char buf[160];
            std::snprintf(buf,
                          sizeof buf,
                          "%s%s %.6g +- %.2g",
                          c.parameters.empty() ? "" : "; ",
                          p.name.c_str(),
                          p.value,
                          std::abs(rel * p.value));
            c.parameters += buf;
        }
        const auto model = brdf::make_analytic_brdf(run->result.model);
        c.holdout_rms_z = holdout_rms_z(*model, holdout);
        return c;
    };
}

}  // namespace gonio::tools
