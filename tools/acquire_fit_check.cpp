#include "acquire_fit_check.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "gonio/batch/fit_request.h"
#include "gonio/brdf/analytic_brdf.h"

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

}  // namespace

acquisition::FitCheckFn default_fit_check() {
    return [](const std::vector<brdf::Sample>& fit,
              const std::vector<brdf::Sample>& holdout,
              double common_rel_sigma) -> Expected<acquisition::FitCheck> {
        brdf::Dataset ds;
        ds.source = "the campaign's values so far";
        ds.has_sigma = ds.has_weight = ds.has_flags = true;
        ds.samples = fit;
        batch::FitRequest request;
        request.threads = 1;  // the campaign thread waits for it; one core leaves the rig its own
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
