#include "gonio/batch/fit_policy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gonio/brdf/resample.h"

namespace gonio::batch {

int exit_status(const fitting::FitResult& result, bool strict) {
    if (!result.solver.converged) {
        return 1;
    }
    return strict && result.goodness.verdict == fitting::Verdict::kDoesNotRepresent ? 1 : 0;
}

std::string misfit_message(const fitting::FitResult& result) {
    if (result.goodness.verdict == fitting::Verdict::kRepresents) {
        return {};
    }
    std::string m = result.goodness.headline;
    if (!result.goodness.suggestion.empty()) {
        m += "; " + result.goodness.suggestion;
    }
    return m;
}

Expected<Comparison> compare_fits(const brdf::Dataset& data,
                                  const std::vector<FitRequest>& requests) {
    Comparison c;
    for (const FitRequest& request : requests) {
        auto run = run_fit(data, request);
        if (!run) {
            return make_error(request.model + ": " + run.error().message);
        }
        const fitting::FitResult& r = run->result;
        if (!r.solver.converged) {
            c.not_converged.push_back(request.model + ": " + r.solver.termination + " (" +
                                      r.solver.message + ")");
            continue;
        }
        c.ranked.push_back({request.model, std::move(run->result)});
    }
    std::stable_sort(
        c.ranked.begin(), c.ranked.end(), [](const ComparedFit& a, const ComparedFit& b) {
            return a.result.metrics.log_rmse.mean() < b.result.metrics.log_rmse.mean();
        });
    return c;
}

int exit_status(const Comparison& comparison, bool strict) {
    if (!comparison.not_converged.empty()) {
        return 1;
    }
    for (const ComparedFit& f : comparison.ranked) {
        if (exit_status(f.result, strict) != 0) {
            return 1;
        }
    }
    return 0;
}

namespace {

/// Channel-mean log RMSE of a table against the samples it was made from (the samples whose
/// table value is defined; NaN when none is).
double table_log_rmse(const brdf::TabulatedBrdf& table, const brdf::Dataset& data) {
    double sum = 0;
    std::size_t n = 0;
    for (const brdf::Sample& s : data.samples) {
        const brdf::Vec3d wi = s.wi();
        const brdf::Vec3d wo = s.wo();
        const brdf::TableLookup t = table.lookup(wi, wo);
        if (!t.valid || !s.value.allFinite()) {
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            const double r =
                std::log1p(t.value[c] * wi.z()) - std::log1p(std::max(s.value[c], 0.0) * wi.z());
            sum += r * r;
        }
        n += 3;
    }
    return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : std::nan("");
}

}  // namespace

std::string table_alternative(const brdf::Dataset& data, const std::string& data_name) {
    brdf::ResampleOptions o;
    o.grid = brdf::TableGrid{32, 16, 8};
    o.scale = {1, 1, 1};
    brdf::Dataset kept = data;
    // Values below zero within their noise are the zero they measure in a table.
    for (brdf::Sample& s : kept.samples) {
        s.value = s.value.max(0.0);
    }
    std::string how =
        "no analytic family represents these data: render the measurement itself "
        "as a table, `gonio convert " +
        data_name + " table.gtab --grid 32x16x8` (or table.binary, MERL)";
    auto table = brdf::resample_dataset(kept, o);
    if (!table) {
        return how;
    }
    const double err = table_log_rmse(*table, data);
    if (!std::isfinite(err)) {
        return how;
    }
    char buf[96];
    std::snprintf(buf, sizeof buf, "; that table's own log RMSE against these data is %.3g", err);
    return how + buf;
}

}  // namespace gonio::batch
