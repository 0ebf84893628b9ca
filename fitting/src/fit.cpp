// The fit: validation, reduction, initialisation, bounded solve, uncertainties and metrics.

#include "gonio/fitting/fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <thread>

#include "gonio/brdf/model_eval.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/prepared_samples.h"
#include "gonio/fitting/reduction.h"

namespace gonio::fitting {

namespace {

using brdf::ModelD;
using brdf::Rgbd;
using brdf::Sample;

constexpr std::size_t kBatch = 256;           // samples per residual block (without robust loss)
constexpr std::size_t kScoreSamples = 4000;   // samples used to score multi-start candidates
constexpr std::size_t kScreenSamples = 1500;  // short solves that rank the best starts
constexpr std::size_t kScreenStarts = 4;      // starts screened by a short solve
constexpr int kScreenIterations = 15;         // iterations of a screening solve
constexpr std::size_t kMaxRejectedLines = 100;
constexpr double kVanishedShare = 1e-3;  // a lobe below this share of the reflectance vanished
// Goodness of fit: thresholds of a misfit far beyond measurement noise (docs/fitting-guide.md).
constexpr double kLogRmseUnusable = 0.3;
constexpr double kLogRmseWarn = 0.15;
constexpr double kBandBiasUnusable = 0.3;
constexpr double kBandBiasWarn = 0.15;
// Median relative error |m - d| / d of a channel: 2 % multiplicative noise alone gives 1.35 %
// (0.674 sigma), so 5 % is a misfit well beyond such noise and 15 % one that changes the colour.
constexpr double kMedianRelWarn = 0.05;
constexpr double kMedianRelUnusable = 0.15;
constexpr double kChi2Unusable = 10;
constexpr double kChi2Warn = 2;
// A chi-square far above 1 makes a fit unusable only when the misfit is also of a size that matters
// (log RMSE above 2 %): below it the stated sigmas (photon noise of a region mean, often 1e-5
// relative) are simply smaller than the rig's systematic errors, which is a warning, not a failure.
constexpr double kLogRmsePractical = 0.02;
constexpr double kBandEdgesDeg[] = {0, 2, 5, 10, 20, 40, 90};

int thread_count(int requested) {
    if (requested > 0) {
        return requested;
    }
    const unsigned hw = std::thread::hardware_concurrency();
    return hw == 0 ? 1 : static_cast<int>(hw);
}

/// Runs body(thread_index, begin, end) over [0, n) split across `threads` threads.
template <class Body>
void parallel_for(std::size_t n, int threads, Body body) {
    if (threads <= 1 || n < 4096) {
        body(0, std::size_t{0}, n);
        return;
    }
    std::vector<std::thread> pool;
    const std::size_t chunk = (n + threads - 1) / threads;
    for (int t = 0; t < threads; ++t) {
        const std::size_t b = t * chunk;
        const std::size_t e = std::min(n, b + chunk);
        if (b < e) {
            pool.emplace_back(body, t, b, e);
        }
    }
    for (std::thread& th : pool) {
        th.join();
    }
}

/// Objective value (1/2 sum of squared residuals, as Ceres reports it) of a model on prepared
/// samples; infinity when a residual is not finite.
double objective(const PreparedSamples& ps, const std::vector<double>& x, int threads) {
    double s = 0;
    if (!ps.sum_of_squares(x.data(), &s, threads)) {
        return std::numeric_limits<double>::infinity();
    }
    return 0.5 * s;
}
// ---------------------------------------------------------------------------------------------
// Initialisation

/// Percentile (0..1) of a vector (copied).
double percentile(std::vector<double> v, double q) {
    if (v.empty()) {
        return 0;
    }
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
    return v[k];
}

/// Alpha estimated from the width of the specular peak above the diffuse floor: the largest
/// tan(theta_h) whose excess is at least half the peak's, divided by the half-maximum point of
/// the distribution in units of alpha (GGX: (1 + t^2/a^2)^-2 = 1/2 at t = a sqrt(sqrt 2 - 1);
/// Beckmann: exp(-t^2/a^2) = 1/2 at t = a sqrt(ln 2)). Returns 0 when there is no peak.
double estimate_alpha(const std::vector<Sample>& samples, const Rgbd& floor, brdf::Distribution d) {
    std::vector<double> excess(samples.size());
    std::vector<double> tan_h(samples.size());
    double peak = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const brdf::Vec3d wi = samples[i].wi();
        const brdf::Vec3d wo = samples[i].wo();
        brdf::Vec3d h = wi + wo;
        const double norm = h.norm();
        if (norm == 0) {
            // Opposite directions: no half vector, no information on the lobe.
            tan_h[i] = 1e9;
            excess[i] = 0;
            continue;
        }
        h /= norm;
        const double cos_h = std::max(h.z(), 1e-9);
        tan_h[i] = std::sqrt(std::max(0.0, 1 - cos_h * cos_h)) / cos_h;
        // Projected-area form: D times 4 cos_i cos_o removes the 1/(cos cos) foreshortening.
        excess[i] = ((samples[i].value - floor * brdf::kInvPi).sum() / 3) * wi.z() * wo.z();
        peak = std::max(peak, excess[i]);
    }
    if (!(peak > 0)) {
        return 0;
    }
    double t_half = 0;
    double t_min = 1e9;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        if (excess[i] >= 0.5 * peak) {
            t_half = std::max(t_half, tan_h[i]);
        }
        if (tan_h[i] > 0) {
            t_min = std::min(t_min, tan_h[i]);
        }
    }
    if (t_half <= 0) {
        // Only the exact mirror sample is above half: the peak is narrower than the grid.
        t_half = 0.5 * t_min;
    }
    const double unit = d == brdf::Distribution::kBeckmann ? 0.8326 : 0.6436;
    return t_half / unit;
}

/// Sets the shape of lobe `i` from alpha (alpha_x = alpha_y = alpha or the Blinn-Phong exponent
/// 2 / alpha^2 - 2, the usual correspondence of the two lobes' widths), within the bounds.
void set_shape(ModelD& m, const ParameterMap& map, int lobe, double alpha) {
    for (const ScalarParam& s : map.scalars()) {
        if (s.lobe != lobe || !s.free) {
            continue;
        }
        double v;
        if (s.field == Field::kAlphaX || s.field == Field::kAlphaY) {
            v = alpha;
        } else if (s.field == Field::kExponent) {
            v = 2.0 / (alpha * alpha) - 2.0;
        } else {
            continue;
        }
        ParameterMap::set(m, s, std::clamp(v, s.lower, s.upper));
    }
}

const ScalarParam* find_free(const ParameterMap& map, Field f, int lobe, int channel) {
    for (const ScalarParam& s : map.scalars()) {
        if (s.free && s.field == f && s.lobe == lobe && (s.channel == channel || s.channel < 0)) {
            return &s;
        }
    }
    return nullptr;
}

/// Linear least squares of the terms that enter the model linearly, per channel, given the
/// shapes: the diffuse albedo and lobe 0's amplitude (its scale, or Schlick's f0 when the scale is
/// fixed: F = x^5 + f0 (1 - x^5) is linear in f0). Relative weights 1 / (d + floor)^2 so that the
/// peak does not decide alone. A negative solution puts that term at its lower bound and solves
/// for the other; results are brought inside the bounds (these are start values, not results).
void linear_init(ModelD& m,
                 const ParameterMap& map,
                 const std::vector<Sample>& samples,
                 double floor) {
    const ScalarParam* rho[3];
    const ScalarParam* amp[3];
    bool amp_is_f0 = false;
    for (int c = 0; c < 3; ++c) {
        rho[c] = find_free(map, Field::kDiffuse, -1, c);
        amp[c] = m.lobes.empty() ? nullptr : find_free(map, Field::kScale, 0, c);
        if (amp[c] == nullptr && !m.lobes.empty() &&
            m.lobes[0].fresnel.type == brdf::FresnelType::kSchlick) {
            amp[c] = find_free(map, Field::kF0, 0, c);
            amp_is_f0 = amp[c] != nullptr;
        }
    }
    // Basis values: the model without diffuse and with lobe 0's amplitude at 0 and at 1.
    ModelD m0 = m;
    m0.has_diffuse = false;
    ModelD m1 = m0;
    if (!m.lobes.empty()) {
        if (amp_is_f0) {
            m0.lobes[0].fresnel.f0 = Rgbd::Zero();
            m1.lobes[0].fresnel.f0 = Rgbd::Ones();
        } else {
            m0.lobes[0].scale = Rgbd::Zero();
            m1.lobes[0].scale = Rgbd::Ones();
        }
    }
    Eigen::Matrix2d a[3];
    Eigen::Vector2d b[3];
    for (int c = 0; c < 3; ++c) {
        a[c].setZero();
        b[c].setZero();
    }
    for (const Sample& s : samples) {
        const brdf::Vec3d wi = s.wi();
        const brdf::Vec3d wo = s.wo();
        const Rgbd f0 = brdf::eval_model(m0, wi, wo);
        const Rgbd f1 = brdf::eval_model(m1, wi, wo);
        for (int c = 0; c < 3; ++c) {
            const double w = s.weight / ((s.value[c] + floor) * (s.value[c] + floor));
            const Eigen::Vector2d basis(brdf::kInvPi, f1[c] - f0[c]);
            a[c] += w * basis * basis.transpose();
            b[c] += w * basis * (s.value[c] - f0[c]);
        }
    }
    double u_rho[3] = {0, 0, 0};
    double u_amp[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) {
        const bool use_rho = rho[c] != nullptr;
        const bool use_amp = amp[c] != nullptr;
        u_rho[c] = use_rho ? map.value_of(m, *rho[c]) : 0;
        u_amp[c] = use_amp ? map.value_of(m, *amp[c]) : 0;
        auto solve1 = [&](int k, double fixed_other) {
            const int o = 1 - k;
            const double rhs = b[c][k] - a[c](k, o) * fixed_other;
            return a[c](k, k) > 0 ? rhs / a[c](k, k) : 0.0;
        };
        if (use_rho && use_amp) {
            const double det = a[c].determinant();
            if (std::abs(det) > 1e-300) {
                const Eigen::Vector2d u = a[c].inverse() * b[c];
                u_rho[c] = u[0];
                u_amp[c] = u[1];
            }
            if (u_rho[c] < 0) {
                u_rho[c] = 0;
                u_amp[c] = solve1(1, 0);
            } else if (u_amp[c] < 0) {
                u_amp[c] = 0;
                u_rho[c] = solve1(0, 0);
            }
        } else if (use_rho) {
            // The lobe as it is (amplitude fixed) is part of the prediction.
            double fixed_amp = 0;
            if (!m.lobes.empty()) {
                fixed_amp = amp_is_f0 ? m.lobes[0].fresnel.f0[c] : m.lobes[0].scale[c];
            }
            u_rho[c] = solve1(0, fixed_amp);
        } else if (use_amp) {
            u_amp[c] = solve1(1, m.has_diffuse ? m.diffuse[c] : 0.0);
        }
    }
    // A shared parameter (one value for the three channels) starts at the channels' mean.
    auto store = [&](const ScalarParam* const* p, const double* u) {
        if (p[0] == nullptr) {
            return;
        }
        for (int c = 0; c < 3; ++c) {
            const double v = p[c]->channel < 0 ? (u[0] + u[1] + u[2]) / 3 : u[c];
            if (std::isfinite(v)) {
                ParameterMap::set(m, *p[c], std::clamp(v, p[c]->lower, p[c]->upper));
            }
        }
    };
    store(rho, u_rho);
    store(amp, u_amp);
}

/// Every free scalar brought inside its bounds (start values only).
std::vector<double> clamp_start(const ParameterMap& map, std::vector<double> x) {
    for (int k = 0; k < map.size(); ++k) {
        const ScalarParam& s = map.scalars()[map.free()[k]];
        x[k] = std::clamp(x[k], s.lower, s.upper);
    }
    return x;
}

struct Candidate {
    std::vector<double> x;
    double cost = 0;
};

/// Data-driven starts scored by the objective, best first.
std::vector<Candidate> initial_candidates(const std::shared_ptr<const ParameterMap>& map_ptr,
                                          const std::vector<Sample>& samples,
                                          const FitOptions& o,
                                          const CostOptions& co) {
    const ParameterMap& map = *map_ptr;
    const std::vector<Sample> score_set = stratified_reduce(samples, kScoreSamples, o.seed);
    const PreparedSamples scorer(map_ptr, score_set, co);
    const int threads = thread_count(o.num_threads);
    ModelD m = map.base();
    std::vector<Candidate> out;
    if (m.lobes.empty()) {
        linear_init(m, map, score_set, o.relative_floor);
        Candidate c{clamp_start(map, map.values_of(m)), 0};
        c.cost = objective(scorer, c.x, threads);
        out.push_back(c);
        return out;
    }
    // Off-specular floor: a low percentile of each channel among samples far from the mirror
    // direction (theta_h > 45 degrees), or of all samples when there are none.
    Rgbd floor = Rgbd::Zero();
    for (int c = 0; c < 3; ++c) {
        std::vector<double> far;
        std::vector<double> all;
        for (const Sample& s : score_set) {
            const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
            all.push_back(s.value[c]);
            if (hd.theta_h > brdf::kPi / 4) {
                far.push_back(s.value[c]);
            }
        }
        floor[c] = brdf::kPi * percentile(far.size() >= 10 ? far : all, 0.2);
    }
    double alpha = estimate_alpha(score_set, floor, m.lobes[0].distribution);
    if (!(alpha > 0) || !std::isfinite(alpha)) {
        alpha = 0.3;
    }
    alpha = std::clamp(alpha, 1e-3, 1.5);
    std::vector<double> alphas = {alpha, 0.5 * alpha, 2 * alpha};
    std::mt19937_64 rng(o.seed);
    std::uniform_real_distribution<double> log_alpha(std::log(1e-3), std::log(1.0));
    while (static_cast<int>(alphas.size()) < std::max(1, o.starts)) {
        alphas.push_back(std::exp(log_alpha(rng)));
    }
    alphas.resize(std::max(1, o.starts));
    if (o.starts > 1) {
        // A fixed log-spaced ladder over the range of real lobes as well: the width estimate
        // fails when the peak is narrower than the angular grid (only exact mirror samples see
        // it), and scoring a start costs one pass over the small scoring set.
        for (double a = 2e-3; a < 1.2; a *= 2.5) {
            alphas.push_back(a);
        }
    }
    for (double a : alphas) {
        ModelD mc = m;
        for (int i = 0; i < static_cast<int>(mc.lobes.size()); ++i) {
            // Further lobes start wider, by a factor of 3 each.
            set_shape(mc, map, i, a * std::pow(3.0, i));
        }
        linear_init(mc, map, score_set, o.relative_floor);
        Candidate c{clamp_start(map, map.values_of(mc)), 0};
        c.cost = objective(scorer, c.x, threads);
        out.push_back(c);
    }
    std::stable_sort(out.begin(), out.end(), [](const Candidate& a, const Candidate& b) {
        return a.cost < b.cost;  // NaN/Inf costs sort last
    });
    return out;
}

// ---------------------------------------------------------------------------------------------
// Solve

struct SolveOutcome {
    std::vector<double> x;
    ceres::Solver::Summary summary;
};

ceres::LossFunction* make_loss(const FitOptions& o) {
    if (o.loss == LossKind::kHuber) {
        return new ceres::HuberLoss(o.loss_scale);
    }
    if (o.loss == LossKind::kCauchy) {
        return new ceres::CauchyLoss(o.loss_scale);
    }
    return nullptr;
}

/// The samples prepared for a solve, with the robust loss of the options.
std::shared_ptr<PreparedSamples> prepare(const std::shared_ptr<const ParameterMap>& map,
                                         const std::vector<Sample>& samples,
                                         const FitOptions& o,
                                         const CostOptions& co) {
    auto ps = std::make_shared<PreparedSamples>(map, samples, co);
    ps->set_loss(std::shared_ptr<const ceres::LossFunction>(make_loss(o)));
    return ps;
}

void set_bounds(ceres::Problem& problem, const ParameterMap& map, double* x) {
    for (int k = 0; k < map.size(); ++k) {
        const ScalarParam& s = map.scalars()[map.free()[k]];
        problem.SetParameterLowerBound(x, k, s.lower);
        problem.SetParameterUpperBound(x, k, s.upper);
    }
}

ceres::Solver::Options solver_options(int max_iterations, double tolerance) {
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = max_iterations;
    // The cost function spreads each evaluation over the threads itself.
    so.num_threads = 1;
    so.function_tolerance = tolerance;
    so.gradient_tolerance = 1e-2 * tolerance;
    so.parameter_tolerance = tolerance;
    so.logging_type = ceres::SILENT;
    // A step that leaves the bounds is projected onto them and judged by its cost alone; Ceres'
    // projected line search would evaluate gradients at up to 20 trial points per iteration
    // (each a pass over all samples) when a parameter sits on its bound.
    so.max_num_line_search_step_size_iterations = 0;
    return so;
}

/// Levenberg-Marquardt (Ceres) on the normal-equation form of the prepared samples. With
/// hold_bounds, free parameters that start on a bound are held there (the polish after a reduced
/// solve: the reduction already put them there).
SolveOutcome solve(const std::shared_ptr<const PreparedSamples>& ps,
                   const FitOptions& o,
                   std::vector<double> x0,
                   int max_iterations,
                   double tolerance = 1e-12,
                   bool hold_bounds = false) {
    SolveOutcome out;
    out.x = std::move(x0);
    ceres::Problem problem;
    problem.AddResidualBlock(
        new NormalEquationCost(ps, thread_count(o.num_threads)), nullptr, out.x.data());
    set_bounds(problem, ps->map(), out.x.data());
    if (hold_bounds) {
        std::vector<int> held;
        for (int k = 0; k < ps->map().size(); ++k) {
            const ScalarParam& s = ps->map().scalars()[ps->map().free()[k]];
            const double tol = 1e-9 * std::max(s.upper - s.lower, 1e-300);
            if (out.x[k] <= s.lower + tol || out.x[k] >= s.upper - tol) {
                held.push_back(k);
            }
        }
        if (!held.empty() && static_cast<int>(held.size()) < ps->map().size()) {
            problem.SetManifold(out.x.data(), new ceres::SubsetManifold(ps->map().size(), held));
        }
    }
    ceres::Solve(solver_options(max_iterations, tolerance), &problem, &out.summary);
    return out;
}

/// The same problem as one residual block per sample (per-sample robust loss as Ceres applies
/// it), for Ceres' own gradient check (FitOptions::check_gradients): slow, for testing.
SolveOutcome solve_checked(const std::shared_ptr<const ParameterMap>& map,
                           const std::vector<Sample>& samples,
                           const FitOptions& o,
                           const CostOptions& co,
                           std::vector<double> x0) {
    SolveOutcome out;
    out.x = std::move(x0);
    ceres::Problem problem;
    for (const Sample& s : samples) {
        problem.AddResidualBlock(
            make_batch_cost(map, {s}, co).release(), make_loss(o), out.x.data());
    }
    set_bounds(problem, *map, out.x.data());
    ceres::Solver::Options so = solver_options(o.max_iterations, 1e-12);
    so.check_gradients = true;
    ceres::Solve(so, &problem, &out.summary);
    return out;
}

std::string termination_name(ceres::TerminationType t) {
    return ceres::TerminationTypeToString(t);
}

bool all_finite(const std::vector<double>& x) {
    for (double v : x) {
        if (!std::isfinite(v)) {
            return false;
        }
    }
    return true;
}

int iterations_of(const ceres::Solver::Summary& s) {
    return std::max(0, static_cast<int>(s.iterations.size()) - 1);
}

// ---------------------------------------------------------------------------------------------
// Uncertainties

/// The inverse of a symmetric positive definite matrix by its eigen decomposition; false when it
/// is not well conditioned (smallest eigenvalue below 1e-12 of the largest).
bool spd_inverse(const Eigen::MatrixXd& a, Eigen::MatrixXd& inv) {
    if (a.rows() == 0) {
        inv.resize(0, 0);
        return true;
    }
    // Scale to unit diagonal first: parameters of very different magnitudes.
    Eigen::VectorXd d = a.diagonal().cwiseSqrt().cwiseInverse();
    if (!d.allFinite()) {
        return false;
    }
    const Eigen::MatrixXd scaled = d.asDiagonal() * a * d.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(scaled);
    if (!(es.eigenvalues().minCoeff() > 1e-12 * es.eigenvalues().maxCoeff())) {
        return false;
    }
    inv = d.asDiagonal() *
          (es.eigenvectors() * es.eigenvalues().cwiseInverse().asDiagonal() *
           es.eigenvectors().transpose()) *
          d.asDiagonal();
    return inv.allFinite();
}

/// Fills sigma / identifiable of the free parameters at the solution x of the prepared samples.
/// Not identifiable: (1) a parameter whose effect on the residuals over a step of its own size,
/// |J_k| max(|x_k|, 1e-3 (upper - lower)), is below 1e-8 of the largest such effect (for example
/// alpha of a lobe whose scale went to 0); (2) among the others, every parameter with a component
/// above 0.1 in an eigenvector of the column-scaled normal matrix D J^T J D (unit diagonal) whose
/// eigenvalue is below 1e-10 of the largest (a combination the data do not constrain).
/// Parameters on a bound get no sigma (the estimate is the bound's value) and are held there.
/// Covariance of the others:
///   without sigmas: the sandwich H^-1 M H^-1, H = J^T J, M = sum over samples of g_i g_i^T with
///     g_i = J_i^T r_i (White 1980, HC0): consistent when the noise differs from sample to
///     sample (the log residual of multiplicative noise does) and when the model is not exact;
///   with sigmas (residuals normalised by them): H^-1 max(1, chi2 / dof).
void uncertainties(const PreparedSamples& ps,
                   const FitOptions& o,
                   const std::vector<double>& x,
                   bool with_sigma,
                   const std::vector<bool>& at_bound,
                   std::vector<FittedParameter>& params,
                   std::vector<std::string>& not_identifiable,
                   std::optional<double>* reduced_chi2) {
    const ParameterMap& map = ps.map();
    const int n = map.size();
    const int threads = thread_count(o.num_threads);
    NormalEquations ne;
    const bool evaluated = ps.normal_equations(x.data(), ne, threads);
    const double dof = 3.0 * static_cast<double>(ps.size()) - n;
    if (evaluated && with_sigma && dof > 0) {
        *reduced_chi2 = ne.cost_sum / dof;
    }
    const Eigen::MatrixXd& jtj = ne.jtj;
    std::vector<bool> ident(n, true);
    std::vector<double> sigma(n, -1);
    if (!evaluated) {
        ident.assign(n, false);
    } else {
        // (1) Effect of each parameter over a step of its own size.
        std::vector<double> effect(n);
        double max_effect = 0;
        for (int k = 0; k < n; ++k) {
            const ScalarParam& s = map.scalars()[map.free()[k]];
            const double step = std::max(std::abs(x[k]), 1e-3 * (s.upper - s.lower));
            effect[k] = std::sqrt(std::max(0.0, jtj(k, k))) * step;
            if (!std::isfinite(effect[k])) {
                effect[k] = 0;
            }
            max_effect = std::max(max_effect, effect[k]);
        }
        std::vector<int> kept;
        for (int k = 0; k < n; ++k) {
            if (!(effect[k] > 1e-8 * max_effect)) {
                // No visible effect on the fit: the data say nothing about this parameter.
                ident[k] = false;
            } else {
                kept.push_back(k);
            }
        }
        // (2) Unconstrained combinations among the kept ones.
        const int m = static_cast<int>(kept.size());
        if (m > 0) {
            Eigen::MatrixXd sub(m, m);
            Eigen::VectorXd scale(m);
            for (int a = 0; a < m; ++a) {
                scale[a] = 1 / std::sqrt(jtj(kept[a], kept[a]));
                for (int b = 0; b < m; ++b) {
                    sub(a, b) = jtj(kept[a], kept[b]);
                }
            }
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scale.asDiagonal() * sub *
                                                               scale.asDiagonal());
            const double lmax = eig.eigenvalues().maxCoeff();
            for (int e = 0; e < m; ++e) {
                if (eig.eigenvalues()[e] < 1e-10 * lmax) {
                    for (int a = 0; a < m; ++a) {
                        if (std::abs(eig.eigenvectors()(a, e)) > 0.1) {
                            ident[kept[a]] = false;
                        }
                    }
                }
            }
        }
        // Covariance of the identifiable parameters off their bounds, the others held.
        std::vector<int> good;
        for (int k = 0; k < n; ++k) {
            if (ident[k] && !at_bound[k]) {
                good.push_back(k);
            }
        }
        const int g = static_cast<int>(good.size());
        Eigen::MatrixXd h(g, g);
        for (int a = 0; a < g; ++a) {
            for (int b = 0; b < g; ++b) {
                h(a, b) = jtj(good[a], good[b]);
            }
        }
        Eigen::MatrixXd h_inv;
        if (g > 0 && spd_inverse(h, h_inv)) {
            Eigen::MatrixXd cov;
            if (with_sigma) {
                const double s2 = reduced_chi2->has_value() ? std::max(1.0, **reduced_chi2) : 1.0;
                cov = h_inv * s2;
            } else {
                Eigen::MatrixXd meat_full;
                if (ps.score_outer_products(x.data(), meat_full, threads)) {
                    Eigen::MatrixXd meat(g, g);
                    for (int a = 0; a < g; ++a) {
                        for (int b = 0; b < g; ++b) {
                            meat(a, b) = meat_full(good[a], good[b]);
                        }
                    }
                    cov = h_inv * meat * h_inv;
                }
            }
            for (int a = 0; a < g && cov.rows() == g; ++a) {
                sigma[good[a]] = std::sqrt(std::max(0.0, cov(a, a)));
            }
        }
    }
    for (int k = 0; k < n; ++k) {
        const std::string& name = map.scalars()[map.free()[k]].name;
        for (FittedParameter& p : params) {
            if (p.name != name) {
                continue;
            }
            p.identifiable = ident[k];
            if (ident[k] && sigma[k] >= 0 && std::isfinite(sigma[k])) {
                p.sigma = sigma[k];
            }
        }
        if (!ident[k]) {
            not_identifiable.push_back(name);
        }
    }
}

/// Each lobe's share of the model's reflectance summed (weighted, channel mean) over `samples`:
/// sum_i w_i mean_c lobe_l(i) / sum_i w_i mean_c model(i). All zero when the model is zero on
/// every sample (nothing to share).
std::vector<double> lobe_shares(const ModelD& model, const std::vector<Sample>& samples) {
    std::vector<double> lobe_sum(model.lobes.size(), 0.0);
    double total = 0;
    for (const Sample& s : samples) {
        const brdf::Vec3d wi = s.wi();
        const brdf::Vec3d wo = s.wo();
        total += s.weight * brdf::eval_model(model, wi, wo).mean();
        for (std::size_t l = 0; l < model.lobes.size(); ++l) {
            lobe_sum[l] += s.weight * brdf::eval_lobe(model.lobes[l], wi, wo).mean();
        }
    }
    for (double& v : lobe_sum) {
        // A zero model (all-zero data): every lobe has vanished.
        v = total > 0 ? v / total : 0.0;
    }
    return lobe_sum;
}

/// Goodness of fit from the metrics (and the reduced chi-square when the data carry sigmas).
/// What to try when the model `fitted` misfits: the families that could fix it and are not the
/// one fitted.
std::string suggest(const ModelD& fitted) {
    std::string dist = "ggx";
    if (!fitted.lobes.empty()) {
        dist = brdf::to_string(fitted.lobes[0].distribution);
    }
    std::string s =
        "try `--model auto` (ranks ggx, beckmann, student-t, blinn-phong and two lobes by BIC)";
    if (fitted.lobes.size() < 2) {
        s += ", a second lobe (`--lobes 2`)";
    }
    if (dist != "student-t") {
        s += ", a distribution with a tail parameter (`--model student-t`)";
    }
    if (dist != "beckmann") {
        s += ", `--model beckmann`";
    }
    s += " or `--fresnel schlick-rgb`";
    return s;
}

GoodnessOfFit judge(const Metrics& m,
                    std::optional<double> chi2,
                    std::size_t valid,
                    const ModelD& fitted) {
    GoodnessOfFit g;
    g.reduced_chi_square = chi2;
    char buf[256];
    const char* names[3] = {"r", "g", "b"};
    for (int c = 0; c < 3; ++c) {
        const double v = m.log_rmse[c];
        if (!std::isfinite(v) || v > kLogRmseUnusable) {
            g.represents = false;
            std::snprintf(buf,
                          sizeof buf,
                          "log RMSE of channel %s = %.3g above %.2g: the model does not represent "
                          "these data",
                          names[c],
                          v,
                          kLogRmseUnusable);
            g.warnings.push_back(buf);
        } else if (v > kLogRmseWarn) {
            std::snprintf(buf,
                          sizeof buf,
                          "log RMSE of channel %s = %.3g above %.2g: a visible misfit",
                          names[c],
                          v,
                          kLogRmseWarn);
            g.warnings.push_back(buf);
        }
    }
    for (int c = 0; c < 3; ++c) {
        // The relative error of f itself: sees a dark channel that log(1 + f cos) cannot.
        const double v = m.median_rel[c];
        const bool bad = !std::isfinite(v) || v > kMedianRelUnusable;
        if (bad || v > kMedianRelWarn) {
            if (bad) {
                g.represents = false;
            }
            std::snprintf(buf,
                          sizeof buf,
                          "median relative error |m - d| / d of channel %s = %.3g above %.2g: %s",
                          names[c],
                          v,
                          bad ? kMedianRelUnusable : kMedianRelWarn,
                          bad ? "the model does not represent this channel"
                              : "a visible misfit in this channel");
            g.warnings.push_back(buf);
        }
    }
    for (const BandResidual& b : m.bands) {
        // Bands with under 1 % of the samples do not decide.
        if (b.count * 100 < valid) {
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            const double bias = b.mean_log[c];
            const bool bad = !std::isfinite(bias) || std::abs(bias) > kBandBiasUnusable;
            if (bad || std::abs(bias) > kBandBiasWarn) {
                if (bad) {
                    g.represents = false;
                }
                std::snprintf(buf,
                              sizeof buf,
                              "theta_h in [%g, %g) deg: mean log residual of channel %s = %+.3g "
                              "(the model is %s there; limit +-%.2g)",
                              b.theta_h_lo_deg,
                              b.theta_h_hi_deg,
                              names[c],
                              bias,
                              bias > 0 ? "too bright" : "too dark",
                              bad ? kBandBiasUnusable : kBandBiasWarn);
                g.warnings.push_back(buf);
            }
        }
    }
    const double worst_log_rmse = m.log_rmse.maxCoeff();
    if (chi2) {
        if (std::isfinite(*chi2) && *chi2 > kChi2Unusable && worst_log_rmse <= kLogRmsePractical) {
            std::snprintf(buf,
                          sizeof buf,
                          "reduced chi-square = %.3g above %g, but the worst log RMSE is only "
                          "%.3g (limit %.2g): the stated sigmas are far smaller than the "
                          "systematic errors of the data or the model",
                          *chi2,
                          kChi2Unusable,
                          worst_log_rmse,
                          kLogRmsePractical);
            g.warnings.push_back(buf);
        } else if (!std::isfinite(*chi2) || *chi2 > kChi2Unusable) {
            g.represents = false;
            std::snprintf(buf,
                          sizeof buf,
                          "reduced chi-square = %.3g above %g: the misfit is far beyond the "
                          "stated sigmas",
                          *chi2,
                          kChi2Unusable);
            g.warnings.push_back(buf);
        } else if (*chi2 > kChi2Warn) {
            std::snprintf(buf,
                          sizeof buf,
                          "reduced chi-square = %.3g above %g: misfit beyond the stated sigmas "
                          "(or sigmas too small)",
                          *chi2,
                          kChi2Warn);
            g.warnings.push_back(buf);
        }
    }
    if (!g.warnings.empty()) {
        g.suggestion = suggest(fitted);
    }
    return g;
}

}  // namespace

Metrics evaluate_metrics(const ModelD& model,
                         const std::vector<Sample>& samples,
                         double relative_floor) {
    Metrics m;
    if (samples.empty()) {
        return m;
    }
    constexpr int kBands = static_cast<int>(sizeof kBandEdgesDeg / sizeof kBandEdgesDeg[0]) - 1;
    const int threads = thread_count(0);
    struct Acc {
        Eigen::Array<double, 3, 3> sq = Eigen::Array<double, 3, 3>::Zero();
        Eigen::Array<double, kBands, 3> band_sum = Eigen::Array<double, kBands, 3>::Zero();
        Eigen::Array<double, kBands, 3> band_sq = Eigen::Array<double, kBands, 3>::Zero();
        std::array<std::size_t, kBands> band_n{};
    };
    std::vector<Acc> partial(std::max(1, threads));
    // |m - d| / d per sample and channel (NaN where d <= 0: no relative error), for the medians.
    std::vector<double> rel[3];
    for (int c = 0; c < 3; ++c) {
        rel[c].assign(samples.size(), std::numeric_limits<double>::quiet_NaN());
    }
    double band_cos[kBands + 1];
    for (int b = 0; b <= kBands; ++b) {
        band_cos[b] = std::cos(kBandEdgesDeg[b] * brdf::kPi / 180);
    }
    auto body = [&](int t, std::size_t b, std::size_t e) {
        Acc acc;
        for (std::size_t i = b; i < e; ++i) {
            const brdf::Vec3d wi = samples[i].wi();
            const brdf::Vec3d wo = samples[i].wo();
            const Rgbd f = brdf::eval_model(model, wi, wo);
            const double cos_h = (wi.z() + wo.z()) / (wi + wo).norm();
            int band = kBands - 1;
            for (int k = 0; k < kBands; ++k) {
                if (cos_h > band_cos[k + 1]) {
                    band = k;
                    break;
                }
            }
            ++acc.band_n[band];
            for (int c = 0; c < 3; ++c) {
                const double d = samples[i].value[c];
                const double abs_r = f[c] - d;
                const double rel_r =
                    channel_residual(ResidualForm::kRelative, f[c], d, wi.z(), relative_floor);
                const double log_r = channel_residual(ResidualForm::kLog, f[c], d, wi.z(), 0);
                if (d > 0) {
                    rel[c][i] = std::abs(abs_r) / d;
                }
                acc.sq(0, c) += abs_r * abs_r;
                acc.sq(1, c) += rel_r * rel_r;
                acc.sq(2, c) += log_r * log_r;
                acc.band_sum(band, c) += log_r;
                acc.band_sq(band, c) += log_r * log_r;
            }
        }
        partial[t] = acc;
    };
    parallel_for(samples.size(), threads, body);
    Acc total;
    for (const Acc& p : partial) {
        total.sq += p.sq;
        total.band_sum += p.band_sum;
        total.band_sq += p.band_sq;
        for (int k = 0; k < kBands; ++k) {
            total.band_n[k] += p.band_n[k];
        }
    }
    const double n = static_cast<double>(samples.size());
    for (int c = 0; c < 3; ++c) {
        m.rmse[c] = std::sqrt(total.sq(0, c) / n);
        m.rel_rmse[c] = std::sqrt(total.sq(1, c) / n);
        m.log_rmse[c] = std::sqrt(total.sq(2, c) / n);
        std::vector<double>& v = rel[c];
        v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }),
                v.end());
        m.median_rel[c] = v.empty() ? 0.0 : percentile(std::move(v), 0.5);
    }
    for (int k = 0; k < kBands; ++k) {
        if (total.band_n[k] == 0) {
            continue;
        }
        BandResidual b;
        b.theta_h_lo_deg = kBandEdgesDeg[k];
        b.theta_h_hi_deg = kBandEdgesDeg[k + 1];
        b.count = total.band_n[k];
        const double bn = static_cast<double>(b.count);
        for (int c = 0; c < 3; ++c) {
            b.mean_log[c] = total.band_sum(k, c) / bn;
            b.log_rmse[c] = std::sqrt(total.band_sq(k, c) / bn);
        }
        m.bands.push_back(b);
    }
    return m;
}

std::vector<std::string> parameter_names(const FitSpec& spec) {
    std::vector<std::string> out;
    Expected<ParameterMap> map = ParameterMap::make(spec);
    if (map) {
        for (const ScalarParam& s : map->scalars()) {
            out.push_back(s.name);
        }
    }
    return out;
}

Expected<FitResult> fit(const brdf::Dataset& data, const FitSpec& spec) {
    const auto t0 = std::chrono::steady_clock::now();
    const FitOptions& o = spec.options;
    Expected<ParameterMap> map_or = ParameterMap::make(spec);
    if (!map_or) {
        return make_error(map_or.error().message);
    }
    if (o.starts < 1 || o.max_iterations < 1 || !(o.relative_floor > 0) || !(o.loss_scale > 0) ||
        o.polish_iterations < 0 || o.reweight_rounds < 0) {
        return make_error(
            "fit options: starts >= 1, max_iterations >= 1, relative_floor > 0, loss_scale > 0, "
            "polish_iterations >= 0 and reweight_rounds >= 0 are required");
    }
    const int threads = thread_count(o.num_threads);
    FitResult result;
    result.data = data.source;
    result.residual = o.residual;
    result.loss = o.loss;

    // Validity: rows rejected while reading plus samples that break the rules now (a dataset
    // built in memory has not been through the reader). Reference re-measurements are counted
    // apart (they are not BRDF samples); saturated samples are left out (their value is only a
    // lower bound).
    std::vector<Sample> valid;
    valid.reserve(data.samples.size());
    std::vector<std::size_t> rejected_lines;
    for (const brdf::RejectedRow& r : data.rejected) {
        rejected_lines.push_back(r.line);
    }
    std::size_t rejected_here = 0;
    // 0 valid, 1 invalid, 2 reference, 3 saturated. (wi.z = cos theta_i.)
    std::vector<char> kind(data.samples.size(), 0);
    parallel_for(data.samples.size(), threads, [&](int, std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            const Sample& s = data.samples[i];
            if (!brdf::validate_sample(s).empty() || !(std::cos(s.theta_i) > 0) ||
                !(std::cos(s.theta_o) > 0) || !(s.value.maxCoeff() <= brdf::kMaxSampleValue) ||
                !(s.sigma.maxCoeff() <= brdf::kMaxSampleValue)) {
                kind[i] = 1;
            } else if ((s.flags & brdf::kFlagReference) != 0) {
                kind[i] = 2;
            } else if ((s.flags & brdf::kFlagSaturated) != 0) {
                kind[i] = 3;
            }
        }
    });
    for (std::size_t i = 0; i < data.samples.size(); ++i) {
        const Sample& s = data.samples[i];
        if (kind[i] == 1) {
            ++rejected_here;
            rejected_lines.push_back(s.line != 0 ? s.line : i + 1);
            continue;
        }
        if (kind[i] == 2) {
            ++result.samples.reference;
            continue;
        }
        if (kind[i] == 3) {
            ++result.samples.saturated;
            continue;
        }
        valid.push_back(s);
        if (!o.use_sigma || !data.has_sigma) {
            valid.back().sigma = Rgbd::Zero();
        }
    }
    std::sort(rejected_lines.begin(), rejected_lines.end());
    result.samples.input = data.samples.size() + data.rejected.size();
    result.samples.valid = valid.size();
    result.samples.rejected = data.rejected.size() + rejected_here;
    rejected_lines.resize(std::min(rejected_lines.size(), kMaxRejectedLines));
    result.samples.rejected_lines = rejected_lines;
    if (valid.empty()) {
        return make_error(data.source + ": no valid sample to fit (" +
                          std::to_string(result.samples.rejected) + " rejected, " +
                          std::to_string(result.samples.reference) + " reference, " +
                          std::to_string(result.samples.saturated) + " saturated)");
    }
    // Without a reduction the solve works on `valid` itself (no copy of a million samples).
    std::vector<Sample> reduced;
    const bool reduce = o.max_samples > 0 && o.max_samples < valid.size();
    if (reduce) {
        reduced = stratified_reduce(valid, o.max_samples, o.seed);
    }
    const std::vector<Sample>& used = reduce ? reduced : valid;
    result.samples.used = used.size();

    auto map = std::make_shared<const ParameterMap>(*map_or);
    CostOptions co;
    co.residual = o.residual;
    co.relative_floor = o.relative_floor;
    co.use_sigma = o.use_sigma && data.has_sigma;

    // Coarse to fine: on a large input the starts and the main solve work on a stratified
    // reduction (weights keep each stratum's sum), and the result is polished on all samples for
    // a bounded number of iterations.
    const std::vector<Sample> coarse = o.coarse_samples > 0 && used.size() > 2 * o.coarse_samples
                                           ? stratified_reduce(used, o.coarse_samples, o.seed + 1)
                                           : std::vector<Sample>{};
    const std::vector<Sample>& work = coarse.empty() ? used : coarse;
    std::vector<Candidate> candidates;
    if (o.auto_init) {
        candidates = initial_candidates(map, work, o, co);
    } else {
        candidates.push_back({map->values_of(spec.model), 0});
        for (int k = 0; k < map->size(); ++k) {
            const ScalarParam& s = map->scalars()[map->free()[k]];
            if (candidates[0].x[k] < s.lower || candidates[0].x[k] > s.upper) {
                return make_error("start value of " + s.name + " = " +
                                  std::to_string(candidates[0].x[k]) + " outside its bounds [" +
                                  std::to_string(s.lower) + ", " + std::to_string(s.upper) + "]");
            }
        }
    }
    result.solver.starts = static_cast<int>(candidates.size());
    auto add_stage = [&](const std::string& name,
                         std::size_t n,
                         const ceres::Solver::Summary& sum,
                         std::chrono::steady_clock::time_point since) {
        StageInfo st;
        st.name = name;
        st.samples = n;
        st.iterations = iterations_of(sum);
        st.termination = termination_name(sum.termination_type);
        st.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
        st.final_cost = sum.final_cost;
        result.solver.stages.push_back(st);
        result.solver.iterations += st.iterations;
    };
    const auto t_solve = std::chrono::steady_clock::now();

    // Screening: short, loose solves from the best-scored starts on a small stratified subset;
    // those starts are then ranked by the cost they reach and continue from where they stopped.
    // A start's raw cost misleads when its width is right but its amplitudes are not (for
    // example a narrow lobe under a grid that misses most of its peak), and a full solve from a
    // wrong start ends in a local minimum: the tails of a wide lobe standing in for the diffuse
    // term.
    if (o.auto_init && candidates.size() > 1 && !o.check_gradients) {
        const auto since = std::chrono::steady_clock::now();
        const std::vector<Sample> screen = stratified_reduce(work, kScreenSamples, o.seed + 2);
        const auto ps_screen = prepare(map, screen, o, co);
        const std::size_t k = std::min(candidates.size(), kScreenStarts);
        ceres::Solver::Summary total;
        int its = 0;
        for (std::size_t c = 0; c < k; ++c) {
            SolveOutcome s = solve(
                ps_screen, o, candidates[c].x, std::min(o.max_iterations, kScreenIterations), 1e-6);
            its += iterations_of(s.summary);
            total = s.summary;
            if (s.summary.IsSolutionUsable() && std::isfinite(s.summary.final_cost) &&
                all_finite(s.x)) {
                candidates[c].x = s.x;
                candidates[c].cost = s.summary.final_cost;
            } else {
                candidates[c].cost = std::numeric_limits<double>::infinity();
            }
        }
        std::stable_sort(candidates.begin(),
                         candidates.begin() + static_cast<long>(k),
                         [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
        add_stage("screen", screen.size(), total, since);
        result.solver.stages.back().iterations = its;
        result.solver.iterations += its - iterations_of(total);
    }

    // Main solve from the best start; when it does not converge, from the next ones (at most
    // three).
    SolveOutcome best;
    bool have = false;
    const auto ps_work = prepare(map, work, o, co);
    {
        const auto since = std::chrono::steady_clock::now();
        int its = 0;
        for (std::size_t c = 0; c < candidates.size() && c < 3; ++c) {
            SolveOutcome s = o.check_gradients
                                 ? solve_checked(map, work, o, co, candidates[c].x)
                                 : solve(ps_work, o, candidates[c].x, o.max_iterations);
            its += iterations_of(s.summary);
            const bool converged = s.summary.termination_type == ceres::CONVERGENCE;
            if (!have || (converged && best.summary.termination_type != ceres::CONVERGENCE) ||
                (converged && s.summary.final_cost < best.summary.final_cost)) {
                best = s;
                have = true;
            }
            if (converged) {
                break;
            }
        }
        add_stage(coarse.empty() ? "solve" : "reduced", work.size(), best.summary, since);
        result.solver.stages.back().iterations = its;
        result.solver.iterations += its - iterations_of(best.summary);
    }
    bool converged = best.summary.termination_type == ceres::CONVERGENCE;
    result.solver.initial_cost = best.summary.initial_cost;
    std::string termination = termination_name(best.summary.termination_type);
    std::string message = best.summary.message;

    // Polish on all samples (bounded), then relative-noise reweighting at the model.
    std::shared_ptr<PreparedSamples> ps_used = coarse.empty() ? ps_work : nullptr;
    auto polish = [&](const std::string& name, int max_iterations) {
        const auto since = std::chrono::steady_clock::now();
        if (!ps_used) {
            ps_used = prepare(map, used, o, co);
        }
        // Relative cost changes below 1e-9 no longer move the parameters by a visible amount.
        SolveOutcome s = solve(ps_used, o, best.x, max_iterations, 1e-9, true);
        add_stage(name, used.size(), s.summary, since);
        // A polish that stops at its iteration bound still improves on a converged start.
        if (s.summary.IsSolutionUsable() && all_finite(s.x)) {
            best.x = s.x;
            best.summary.final_cost = s.summary.final_cost;
        }
    };
    if (converged && !coarse.empty() && o.polish_iterations > 0) {
        polish("polish", o.polish_iterations);
    }
    if (converged && co.use_sigma) {
        for (int round = 1; round <= o.reweight_rounds; ++round) {
            if (!ps_used) {
                ps_used = prepare(map, used, o, co);
            }
            std::vector<Rgbd> values;
            ps_used->model_values(map->model<double>(best.x.data()), values, threads);
            ps_used->reweight_relative(used, values);
            polish("reweight " + std::to_string(round),
                   coarse.empty() ? o.max_iterations : std::max(1, o.polish_iterations));
        }
    }
    result.solver.solve_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_solve).count();
    result.solver.termination = termination;
    result.solver.message = message;
    result.solver.final_cost = best.summary.final_cost;
    const bool finite = all_finite(best.x);
    result.solver.converged = converged && finite;
    if (!finite) {
        result.solver.message += " (non-finite parameter values)";
    }

    result.model = map->model<double>(best.x.data());
    for (const ScalarParam& s : map->scalars()) {
        FittedParameter p;
        p.name = s.name;
        p.value = map->value_of(result.model, s);
        p.free = s.free;
        result.parameters.push_back(p);
    }
    // Parameters on a bound, and lobes the fit has dropped: the report names both.
    std::vector<bool> at_bound(map->size(), false);
    for (FittedParameter& p : result.parameters) {
        for (int k = 0; k < map->size(); ++k) {
            const ScalarParam& s = map->scalars()[map->free()[k]];
            if (s.name != p.name) {
                continue;
            }
            const double tol = 1e-9 * std::max(s.upper - s.lower, 1e-300);
            if (p.value <= s.lower + tol) {
                p.at_bound = "lower";
            } else if (p.value >= s.upper - tol) {
                p.at_bound = "upper";
            }
            if (!p.at_bound.empty()) {
                at_bound[k] = true;
                char buf[64];
                std::snprintf(buf, sizeof buf, "%.6g", p.at_bound == "lower" ? s.lower : s.upper);
                result.at_bounds.push_back(p.name + " (" + p.at_bound + " bound " + buf + ")");
            }
        }
    }
    if (!result.model.lobes.empty()) {
        const std::vector<double> share = lobe_shares(result.model, work);
        for (std::size_t l = 0; l < share.size(); ++l) {
            if (!(share[l] >= kVanishedShare)) {
                result.vanished_lobes.push_back("lobes[" + std::to_string(l) + "]");
            }
        }
    }
    std::optional<double> chi2;
    if (result.solver.converged && o.covariance) {
        if (!ps_used) {
            ps_used = prepare(map, used, o, co);
        }
        uncertainties(*ps_used,
                      o,
                      best.x,
                      co.use_sigma,
                      at_bound,
                      result.parameters,
                      result.not_identifiable,
                      &chi2);
        result.covariance_method =
            co.use_sigma ? "inverse J^T J of the residuals normalised by relative sigmas "
                           "reweighted at the model (IRLS), scaled by max(1, reduced chi-square)"
                         : "sandwich H^-1 M H^-1 (heteroscedasticity-consistent, HC0; no sigma "
                           "columns)";
    }
    result.metrics = evaluate_metrics(result.model, valid, o.relative_floor);
    result.goodness = judge(result.metrics, chi2, valid.size(), result.model);
    result.solver.usable = result.solver.converged && result.goodness.represents;
    result.solver.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return result;
}

std::vector<std::pair<std::string, FitSpec>> auto_candidates(const FitOptions& options) {
    std::vector<std::pair<std::string, FitSpec>> out;
    const std::pair<const char*, brdf::Distribution> families[] = {
        {"ggx", brdf::Distribution::kGgx},
        {"beckmann", brdf::Distribution::kBeckmann},
        {"blinn-phong", brdf::Distribution::kBlinnPhong},
        {"student-t", brdf::Distribution::kStudentT},
    };
    for (int lobes : {1, 2}) {
        for (const auto& [name, dist] : families) {
            if (lobes == 2 && dist != brdf::Distribution::kGgx &&
                dist != brdf::Distribution::kStudentT) {
                continue;
            }
            ModelOptions mo;
            mo.distribution = dist;
            mo.lobes = lobes;
            Expected<FitSpec> spec = make_fit_spec(mo);
            if (!spec) {
                continue;
            }
            spec->options = options;
            out.emplace_back(std::string(name) + (lobes == 2 ? " x2" : ""), *spec);
        }
    }
    return out;
}

Expected<AutoFitResult> fit_auto(const brdf::Dataset& data,
                                 const std::vector<std::pair<std::string, FitSpec>>& candidates) {
    AutoFitResult out;
    out.criterion =
        "BIC = n log(RSS/n) + p log(n) of the log residuals on the stratified reduction "
        "(n = 3 x samples, p = free parameters); lower is better";
    std::vector<std::pair<double, std::size_t>> order;
    std::string first_error;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        FitSpec spec = candidates[i].second;
        // Ranking on the reduction alone: no polish, no covariance.
        spec.options.polish_iterations = 0;
        spec.options.reweight_rounds = 0;
        spec.options.covariance = false;
        spec.options.residual = ResidualForm::kLog;
        Expected<FitResult> r = fit(data, spec);
        if (!r) {
            if (first_error.empty()) {
                first_error = candidates[i].first + ": " + r.error().message;
            }
            continue;
        }
        RankedModel rm;
        rm.name = candidates[i].first;
        rm.converged = r->solver.converged;
        int p = 0;
        for (const FittedParameter& fp : r->parameters) {
            p += fp.free ? 1 : 0;
        }
        rm.parameters = p;
        rm.log_rmse = r->metrics.log_rmse.mean();
        // RSS on the samples of the reduced solve: final_cost = RSS / 2 with the reduction's
        // weights (which sum to the number of samples it stands for): normalise to its size.
        std::size_t n_red =
            r->solver.stages.empty() ? r->samples.used : r->solver.stages.back().samples;
        const double n = 3.0 * static_cast<double>(n_red);
        const double total_weight = static_cast<double>(r->samples.used);
        const double rss = 2 * r->solver.final_cost * static_cast<double>(n_red) / total_weight;
        rm.criterion = rss > 0 ? n * std::log(rss / n) + p * std::log(n)
                               : -std::numeric_limits<double>::infinity();
        out.ranking.push_back(rm);
        if (rm.converged) {
            order.emplace_back(rm.criterion, i);
        }
    }
    std::sort(
        out.ranking.begin(), out.ranking.end(), [](const RankedModel& a, const RankedModel& b) {
            if (a.converged != b.converged) {
                return a.converged;
            }
            return a.criterion < b.criterion;
        });
    if (order.empty()) {
        return make_error("--model auto: no candidate converged" +
                          (first_error.empty() ? std::string() : " (" + first_error + ")"));
    }
    std::sort(order.begin(), order.end());
    const std::size_t win = order.front().second;
    out.chosen = candidates[win].first;
    Expected<FitResult> best = fit(data, candidates[win].second);
    if (!best) {
        return make_error(out.chosen + ": " + best.error().message);
    }
    out.best = *best;
    return out;
}

}  // namespace gonio::fitting
