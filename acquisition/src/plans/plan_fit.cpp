// The fit-driven plan: its pool of candidates, distances between configurations, and the choice
// of each batch by expected information per second of rig time (plan_fit.h).

#include "gonio/acquisition/plans/plan_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

namespace gonio::acquisition {

namespace {

using brdf::kPi;
using brdf::Vec3d;

constexpr double kDeg = kPi / 180.0;

/// Rounded key of a configuration (its two directions), for duplicates in the pool.
std::tuple<long long, long long, long long, long long, long long, long long> key_of(
    const PlannedConfig& c) {
    const double q = 1e-6;
    auto r = [q](double v) { return std::llround(v / q); };
    return {r(c.wi.x()), r(c.wi.y()), r(c.wi.z()), r(c.wo.x()), r(c.wo.y()), r(c.wo.z())};
}

/// Appends the configurations of `from` that are not yet in `pool`.
void add_unique(
    const Plan& from,
    Plan* pool,
    std::map<std::tuple<long long, long long, long long, long long, long long, long long>, int>*
        seen) {
    for (const PlannedConfig& c : from.configs) {
        if (seen->emplace(key_of(c), 0).second) {
            pool->configs.push_back(c);
        }
    }
}

/// For every incident direction of `grid`, the view directions whose half vector lies at the
/// given angles from the normal, at 8 azimuths (the specular neighbourhood an anisotropic grid
/// samples too coarsely).
Plan near_specular(const Plan& grid, double theta_max) {
    Plan out;
    std::vector<Vec3d> incident;
    for (const PlannedConfig& c : grid.configs) {
        for (const Vec3d& w : {c.wi, c.wo}) {
            const bool known = std::any_of(incident.begin(), incident.end(), [&](const Vec3d& v) {
                return (v - w).norm() < 1e-9;
            });
            if (!known) {
                incident.push_back(w);
            }
        }
    }
    for (const Vec3d& wi : incident) {
        for (double th_deg : {0.0, 2.0, 5.0, 10.0}) {
            const int n_phi = th_deg == 0 ? 1 : 8;
            for (int k = 0; k < n_phi; ++k) {
                const Vec3d h = brdf::spherical_to_cartesian(th_deg * kDeg, 2 * kPi * k / n_phi);
                const Vec3d wo = 2 * wi.dot(h) * h - wi;
                if (wo.z() <= std::cos(theta_max) || wi.z() <= std::cos(theta_max)) {
                    continue;
                }
                PlannedConfig c;
                c.wi = wi;
                c.wo = wo.normalized();
                c.isotropic = false;
                out.configs.push_back(c);
            }
        }
    }
    return out;
}

std::array<double, 9> features_of(const Vec3d& wi, const Vec3d& wo) {
    const Vec3d h = (wi + wo).normalized();
    return {wi.x(), wi.y(), wi.z(), wo.x(), wo.y(), wo.z(), h.x(), h.y(), h.z()};
}

double squared_distance(const std::array<double, 9>& a, const std::array<double, 9>& b) {
    double s = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        s += (a[k] - b[k]) * (a[k] - b[k]);
    }
    return s;
}

/// The smallest distance from each candidate to the measured configurations.
std::vector<double> nearest_measured(const std::vector<CandidateForPlan>& candidates,
                                     const std::vector<MeasuredForPlan>& measured) {
    std::vector<double> d(candidates.size(), std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        for (const MeasuredForPlan& m : measured) {
            d[i] = std::min(d[i], feature_distance(candidates[i].where, m.where));
        }
    }
    return d;
}

/// Farthest-point choices into `out` (marking them taken), `count` at most; `nearest` holds each
/// candidate's distance to what is measured or already chosen. Ties go to the lower index.
void farthest_points(const std::vector<CandidateForPlan>& candidates,
                     std::vector<double>* nearest,
                     std::vector<bool>* taken,
                     int count,
                     std::vector<std::size_t>* out) {
    for (int n = 0; n < count; ++n) {
        std::size_t best = candidates.size();
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            if ((*taken)[i]) {
                continue;
            }
            if (best == candidates.size() || (*nearest)[i] > (*nearest)[best]) {
                best = i;
            }
        }
        if (best == candidates.size()) {
            return;
        }
        (*taken)[best] = true;
        out->push_back(best);
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            (*nearest)[i] = std::min((*nearest)[i],
                                     feature_distance(candidates[i].where, candidates[best].where));
        }
    }
}

/// The information picks of a batch: greedy on expected information per rig second.
void information_picks(const std::vector<CandidateForPlan>& candidates,
                       const FitView& fit,
                       std::vector<double> misfit,
                       double s2,
                       int count,
                       double length_scale,
                       std::vector<bool>* taken,
                       BatchChoice* out) {
    const int p = fit.parameters;
    std::vector<double> cov = fit.covariance;
    for (int n = 0; n < count; ++n) {
        std::size_t best = candidates.size();
        double best_score = 0, best_var = 0;
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            if ((*taken)[i]) {
                continue;
            }
            const double var = predictive_variance(cov, &fit.jacobian[i * p], p);
            const double gain = 0.5 * std::log1p((var + misfit[i]) / s2);
            const double score = gain / std::max(candidates[i].cost_s, 1e-3);
            if (std::isfinite(score) && score > best_score) {
                best = i;
                best_score = score;
                best_var = var;
            }
        }
        if (best == candidates.size()) {
            return;  // nothing left that the fit expects to teach
        }
        (*taken)[best] = true;
        out->chosen.push_back(best);
        out->reasons.push_back(best_var >= misfit[best] ? ChoiceReason::kVariance
                                                        : ChoiceReason::kMisfit);
        out->predictive_var.push_back(best_var);
        out->misfit.push_back(misfit[best]);
        measured_update(&cov, &fit.jacobian[best * p], p, s2);
        // The misfit around the chosen configuration counts as explained by it.
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            const double d = feature_distance(candidates[i].where, candidates[best].where);
            misfit[i] *= 1 - std::exp(-d * d / (2 * length_scale * length_scale));
        }
    }
}

}  // namespace

/// var ln f = j^T C j at candidate i.
double predictive_variance(const std::vector<double>& cov, const double* j, int p) {
    double v = 0;
    for (int a = 0; a < p; ++a) {
        double row = 0;
        for (int b = 0; b < p; ++b) {
            row += cov[static_cast<std::size_t>(a) * p + b] * j[b];
        }
        v += j[a] * row;
    }
    return std::max(0.0, v);
}

/// The covariance after one more measurement of relative variance s2 with Jacobian j:
/// C - (C j)(C j)^T / (s2 + j^T C j) (the Kalman, or Sherman-Morrison, update).
void measured_update(std::vector<double>* cov, const double* j, int p, double s2) {
    std::vector<double> cj(p, 0.0);
    for (int a = 0; a < p; ++a) {
        for (int b = 0; b < p; ++b) {
            cj[a] += (*cov)[static_cast<std::size_t>(a) * p + b] * j[b];
        }
    }
    double v = 0;
    for (int a = 0; a < p; ++a) {
        v += j[a] * cj[a];
    }
    const double denom = s2 + std::max(0.0, v);
    if (!(denom > 0)) {
        return;
    }
    for (int a = 0; a < p; ++a) {
        for (int b = 0; b < p; ++b) {
            (*cov)[static_cast<std::size_t>(a) * p + b] -= cj[a] * cj[b] / denom;
        }
    }
}

bool fit_is_usable(const FitView* fit, std::size_t candidates) {
    if (!fit || fit->parameters <= 0) {
        return false;
    }
    const std::size_t p = static_cast<std::size_t>(fit->parameters);
    return fit->covariance.size() == p * p && fit->jacobian.size() == candidates * p;
}

Expected<void> check_fit_plan_spec(const FitPlanSpec& s) {
    if (s.first < 1 || s.batch < 1 || s.budget < s.first || s.budget > kMaxPlanConfigs) {
        return make_error(
            "fit plan: first = " + std::to_string(s.first) +
            ", batch = " + std::to_string(s.batch) + ", budget = " + std::to_string(s.budget) +
            " (first and batch >= 1, first <= budget <= " + std::to_string(kMaxPlanConfigs) + ")");
    }
    if (!(s.space_share >= 0 && s.space_share <= 1)) {
        return make_error("fit plan: space_share must lie in [0, 1]");
    }
    if (!(s.theta_max > 0 && s.theta_max < kPi / 2)) {
        return make_error("fit plan: theta_max outside (0, 90) deg");
    }
    return {};
}

Expected<Plan> fit_plan_pool(const FitPlanSpec& spec) {
    if (auto ok = check_fit_plan_spec(spec); !ok) {
        return tl::unexpected(ok.error());
    }
    Plan pool;
    pool.kind = "fit";
    std::map<std::tuple<long long, long long, long long, long long, long long, long long>, int>
        seen;
    if (spec.anisotropic) {
        AnisotropicGridSpec a;
        a.n_theta = 8;
        a.n_dphi = 7;
        a.theta_max = spec.theta_max;
        a.symmetry = spec.symmetry;
        auto grid = plan_anisotropic(a);
        if (!grid) {
            return grid;
        }
        pool.naive_count = grid->naive_count;
        add_unique(*grid, &pool, &seen);
        add_unique(near_specular(*grid, spec.theta_max), &pool, &seen);
    } else {
        UniformGridSpec u;
        u.n_theta = 16;
        u.n_dphi = 12;
        u.theta_max = spec.theta_max;
        HalfDiffSpec h;
        h.n_theta_h = 16;
        h.n_theta_d = 12;
        h.n_phi_d = 8;
        h.theta_max = spec.theta_max;
        auto grid = plan_uniform(u);
        auto hd = plan_half_diff(h);
        if (!grid || !hd) {
            return tl::unexpected(!grid ? grid.error() : hd.error());
        }
        pool.naive_count = grid->naive_count;
        add_unique(*grid, &pool, &seen);
        add_unique(*hd, &pool, &seen);
    }
    for (std::size_t k = 0; k < pool.configs.size(); ++k) {
        pool.configs[k].index = static_cast<std::uint32_t>(k);
    }
    return pool;
}

PlanFeatures plan_features(const PlannedConfig& c) {
    PlanFeatures f;
    if (!c.isotropic) {
        f.direct = features_of(c.wi, c.wo);
        f.swapped = features_of(c.wo, c.wi);
        return f;
    }
    const brdf::Canonical<double> k = brdf::to_canonical(c.wi, c.wo, false);
    const double dphi = std::abs(k.delta_phi);
    f.direct = features_of(brdf::spherical_to_cartesian(k.theta_i, 0.0),
                           brdf::spherical_to_cartesian(k.theta_r, dphi));
    f.swapped = features_of(brdf::spherical_to_cartesian(k.theta_r, 0.0),
                            brdf::spherical_to_cartesian(k.theta_i, dphi));
    return f;
}

double feature_distance(const PlanFeatures& a, const PlanFeatures& b) {
    return std::sqrt(
        std::min(squared_distance(a.direct, b.direct), squared_distance(a.direct, b.swapped)));
}

const char* to_string(ChoiceReason r) {
    switch (r) {
        case ChoiceReason::kVariance:
            return "variance";
        case ChoiceReason::kMisfit:
            return "misfit";
        case ChoiceReason::kSpace:
            return "space";
    }
    return "?";
}

std::vector<double> misfit_variance(const std::vector<CandidateForPlan>& candidates,
                                    const std::vector<MeasuredForPlan>& measured,
                                    double length_scale) {
    std::vector<double> m(candidates.size(), 0.0);
    const double inv2l2 = 1 / (2 * length_scale * length_scale);
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        double sw = 1, swe = 0;  // one pseudo-measurement of no misfit
        for (const MeasuredForPlan& s : measured) {
            const double d = feature_distance(candidates[i].where, s.where);
            const double w = std::exp(-d * d * inv2l2);
            const double excess = s.log_residual * s.log_residual - s.rel_sigma * s.rel_sigma;
            if (std::isfinite(excess)) {
                sw += w;
                swe += w * std::max(0.0, excess);
            }
        }
        m[i] = swe / sw;
    }
    return m;
}

std::vector<std::size_t> space_filling(const std::vector<CandidateForPlan>& candidates,
                                       const std::vector<MeasuredForPlan>& measured,
                                       int count) {
    std::vector<bool> taken(candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        taken[i] = !candidates[i].available;
    }
    std::vector<std::size_t> out;
    std::vector<double> nearest = nearest_measured(candidates, measured);
    if (measured.empty()) {
        // Nothing measured: start from the pool's first available candidate.
        auto first = std::find(taken.begin(), taken.end(), false);
        if (first == taken.end() || count <= 0) {
            return out;
        }
        const std::size_t f = static_cast<std::size_t>(first - taken.begin());
        taken[f] = true;
        out.push_back(f);
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            nearest[i] = feature_distance(candidates[i].where, candidates[f].where);
        }
        --count;
    }
    farthest_points(candidates, &nearest, &taken, count, &out);
    return out;
}

BatchChoice choose_batch(const std::vector<CandidateForPlan>& candidates,
                         const std::vector<MeasuredForPlan>& measured,
                         const FitView* fit,
                         double noise_rel_var,
                         const FitChoiceOptions& o) {
    BatchChoice out;
    std::vector<bool> taken(candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        taken[i] = !candidates[i].available;
    }
    const bool informed = fit_is_usable(fit, candidates.size());
    int n_space = o.count;
    if (informed) {
        n_space = std::min(o.count,
                           std::max(o.count >= 2 && o.space_share > 0 ? 1 : 0,
                                    static_cast<int>(std::lround(o.space_share * o.count))));
        const double s2 = std::max(noise_rel_var, 1e-12);
        information_picks(candidates,
                          *fit,
                          misfit_variance(candidates, measured, o.length_scale),
                          s2,
                          o.count - n_space,
                          o.length_scale,
                          &taken,
                          &out);
        // What the fit expected nothing from goes to filling space.
        n_space = o.count - static_cast<int>(out.chosen.size());
    }
    std::vector<double> nearest = nearest_measured(candidates, measured);
    for (std::size_t c : out.chosen) {
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            nearest[i] =
                std::min(nearest[i], feature_distance(candidates[i].where, candidates[c].where));
        }
    }
    std::vector<std::size_t> space;
    farthest_points(candidates, &nearest, &taken, n_space, &space);
    for (std::size_t c : space) {
        out.chosen.push_back(c);
        out.reasons.push_back(ChoiceReason::kSpace);
        out.predictive_var.push_back(0);
        out.misfit.push_back(0);
    }
    return out;
}

}  // namespace gonio::acquisition
