// The batches of a fit-driven point campaign from its journal (fit_pass.h).

#include "gonio/acquisition/point/fit_pass.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include "gonio/acquisition/point/stated_uncertainty.h"

namespace gonio::acquisition {

namespace {

double luminance(const brdf::Rgbd& v) {
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

double median(std::vector<double> v) {
    if (v.empty()) {
        return 0;
    }
    const std::size_t m = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
    return v[m];
}

/// The measurements of the passes before `pass`, in (pass, index) order.
std::vector<JournalRecord> measured_before(const std::vector<JournalRecord>& records, int pass) {
    std::vector<JournalRecord> out;
    for (const JournalRecord& r : records) {
        if (r.type == RecordType::kMeasurement && r.pass < pass) {
            out.push_back(r);
        }
    }
    std::sort(out.begin(), out.end(), [](const JournalRecord& a, const JournalRecord& b) {
        return std::make_pair(a.pass, a.index) < std::make_pair(b.pass, b.index);
    });
    return out;
}

}  // namespace

brdf::Sample sample_of_record(const JournalRecord& r) {
    brdf::Sample s;
    const auto si = brdf::cartesian_to_spherical(r.wi);
    const auto so = brdf::cartesian_to_spherical(r.wo);
    s.theta_i = si.theta;
    s.phi_i = si.phi;
    s.theta_o = so.theta;
    s.phi_o = so.phi;
    s.value = r.value;
    s.sigma = r.sigma;
    s.weight = r.weight;
    s.flags = r.flags;
    return s;
}

namespace {

/// The records as samples with the stated uncertainty (the error budget at zero rig hours: a
/// function of the journal alone).
std::vector<brdf::Sample> samples_of(const std::vector<JournalRecord>& records,
                                     const RigConfig& rig,
                                     bool isotropic) {
    std::vector<brdf::Sample> samples;
    for (const JournalRecord& r : records) {
        samples.push_back(sample_of_record(r));
    }
    add_error_budget(rig.error_budget, 0, isotropic, &samples);
    return samples;
}

/// The chooser's view of the measurements (residuals against the fit when there is one).
std::vector<MeasuredForPlan> measured_for_plan(const std::vector<JournalRecord>& records,
                                               const std::vector<brdf::Sample>& samples,
                                               const PlanFit* fit,
                                               bool isotropic) {
    std::vector<MeasuredForPlan> out;
    for (std::size_t k = 0; k < records.size(); ++k) {
        PlannedConfig c;
        c.wi = records[k].wi;
        c.wo = records[k].wo;
        c.isotropic = isotropic;
        MeasuredForPlan m;
        m.where = plan_features(c);
        const double v = luminance(samples[k].value);
        const double s = luminance(samples[k].sigma);
        m.rel_sigma = v > 0 ? s / v : 1;
        if (fit && k < fit->at_measured.size() && v > 0 && fit->at_measured[k] > 0) {
            m.log_residual = std::log(v / fit->at_measured[k]);
        }
        out.push_back(m);
    }
    return out;
}

/// Candidates of the pool not yet measured or chosen, with their rig seconds.
std::vector<CandidateForPlan> candidates_of(const Plan& pool,
                                            const std::vector<JournalRecord>& measured,
                                            const RigConfig& rig,
                                            const std::vector<double>* predicted) {
    std::set<std::uint32_t> done;
    for (const JournalRecord& r : measured) {
        done.insert(r.index);
    }
    std::vector<CandidateForPlan> out;
    for (std::size_t k = 0; k < pool.configs.size(); ++k) {
        const PlannedConfig& c = pool.configs[k];
        CandidateForPlan cand;
        cand.where = plan_features(c);
        cand.available = !done.count(c.index);
        const double f = predicted && k < predicted->size() ? (*predicted)[k] : 0;
        cand.cost_s = candidate_cost_s(measured, rig, f, c.wi.z());
        out.push_back(cand);
    }
    return out;
}

std::string describe_choice(const BatchChoice& b, FitBatch* out) {
    for (ChoiceReason r : b.reasons) {
        (r == ChoiceReason::kVariance ? out->by_variance
         : r == ChoiceReason::kMisfit ? out->by_misfit
                                      : out->by_space)++;
    }
    return std::to_string(out->by_variance) + " where the prediction is least certain, " +
           std::to_string(out->by_misfit) + " where the model misfits, " +
           std::to_string(out->by_space) + " to fill space";
}

}  // namespace

Expected<Plan> fit_pool_for_rig(const FitPlanSpec& spec,
                                const std::string& scene,
                                const RigLimits& limits) {
    auto pool = fit_plan_pool(spec);
    if (!pool) {
        return pool;
    }
    if (!scene.empty()) {
        auto s = read_scene(scene);
        if (!s) {
            return tl::unexpected(s.error());
        }
        apply_roi(*s, &*pool);
    }
    remove_unreachable(limits, &*pool);
    return pool;
}

Plan fit_first_batch(const Plan& pool, const FitPlanSpec& spec) {
    std::vector<CandidateForPlan> cands;
    for (const PlannedConfig& c : pool.configs) {
        CandidateForPlan k;
        k.where = plan_features(c);
        cands.push_back(k);
    }
    Plan first;
    first.kind = "fit";
    first.naive_count = pool.naive_count;
    first.outside_roi = pool.outside_roi;
    first.unreachable = pool.unreachable;
    for (std::size_t k : space_filling(cands, {}, spec.first)) {
        first.configs.push_back(pool.configs[k]);
    }
    return first;
}

double candidate_cost_s(const std::vector<JournalRecord>& measured,
                        const RigConfig& rig,
                        double predicted,
                        double cos_i) {
    double settle = 0;
    for (const AxisDynamics& d : rig_dynamics(rig)) {
        settle = std::max(settle, d.settle_s);
    }
    const double fixed = settle + 3 * rig.camera_readout_ms / 1000.0;
    std::vector<double> k, t;
    for (const JournalRecord& r : measured) {
        const double f = luminance(r.value);
        if (r.exposure_us > 0) {
            t.push_back(r.exposure_us);
            if (f > 0) {
                k.push_back(r.exposure_us * f * std::max(r.wi.z(), 1e-3));
            }
        }
    }
    if (t.empty()) {
        return fixed + 1.0;  // no exposure seen yet: every candidate alike
    }
    double exposure_us = median(t);
    if (predicted > 0 && std::isfinite(predicted) && !k.empty()) {
        exposure_us = std::clamp(median(k) / (predicted * std::max(cos_i, 1e-3)),
                                 *std::min_element(t.begin(), t.end()),
                                 *std::max_element(t.begin(), t.end()));
    }
    return fixed + 2 * exposure_us * 1e-6;
}

FitBatchInputs fit_batch_inputs(const std::vector<JournalRecord>& records,
                                int pass,
                                const Plan& pool,
                                const FitPlanSpec& spec,
                                const RigConfig& rig,
                                const PlanFitFn& fit,
                                FitBatch* out) {
    FitBatchInputs in;
    out->plan.kind = "fit";
    in.measured = measured_before(records, pass);
    out->measured_before = in.measured.size();
    in.count = std::min<int>(spec.batch, spec.budget - static_cast<int>(in.measured.size()));
    if (in.count <= 0) {
        out->note = "the budget of " + std::to_string(spec.budget) + " configurations is measured";
        return in;
    }
    const bool isotropic = !spec.anisotropic;
    const std::vector<brdf::Sample> samples = samples_of(in.measured, rig, isotropic);
    if (!fit) {
        out->note = "no fit available: space-filling";
    } else {
        auto r = fit(samples, pool.configs, spec.anisotropic);
        if (!r) {
            out->note = "the fit failed (" + r.error().message + "): space-filling";
        } else if (r->view.parameters <= 0) {
            out->note = "the fit gave no covariance (" + r->summary + "): space-filling";
        } else {
            in.fit = std::move(*r);
        }
    }
    const PlanFit* pf = in.fit ? &*in.fit : nullptr;
    in.for_plan = measured_for_plan(in.measured, samples, pf, isotropic);
    in.candidates = candidates_of(pool, in.measured, rig, pf ? &pf->view.predicted : nullptr);
    std::vector<double> rel_var;
    for (const MeasuredForPlan& m : in.for_plan) {
        rel_var.push_back(m.rel_sigma * m.rel_sigma);
    }
    std::nth_element(rel_var.begin(),
                     rel_var.begin() + static_cast<std::ptrdiff_t>(rel_var.size() / 2),
                     rel_var.end());
    in.noise_rel_var = rel_var.empty() ? 1e-4 : rel_var[rel_var.size() / 2];
    return in;
}

void describe_batch(const FitBatchInputs& in, const BatchChoice& b, FitBatch* out) {
    out->fitted = in.fit.has_value();
    const std::string how = describe_choice(b, out);
    out->note = in.fit ? "fit of " + std::to_string(in.measured.size()) + " values (" +
                             in.fit->summary + "): " + how
                       : out->note + ": " + how;
}

FitBatch fit_next_batch(const std::vector<JournalRecord>& records,
                        int pass,
                        const Plan& pool,
                        const FitPlanSpec& spec,
                        const RigConfig& rig,
                        const PlanFitFn& fit) {
    FitBatch out;
    const FitBatchInputs in = fit_batch_inputs(records, pass, pool, spec, rig, fit, &out);
    if (in.count <= 0) {
        return out;
    }
    FitChoiceOptions o;
    o.count = in.count;
    o.space_share = spec.space_share;
    const BatchChoice b = choose_batch(
        in.candidates, in.for_plan, in.fit ? &in.fit->view : nullptr, in.noise_rel_var, o);
    for (std::size_t k : b.chosen) {
        out.plan.configs.push_back(pool.configs[k]);
    }
    describe_batch(in, b, &out);
    return out;
}

}  // namespace gonio::acquisition
