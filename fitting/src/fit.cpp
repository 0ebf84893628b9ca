// The fit: validation, reduction, initialisation, bounded solve, uncertainties and metrics.

#include "gonio/fitting/fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <thread>

#include "gonio/brdf/model_eval.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/reduction.h"

namespace gonio::fitting {

namespace {

using brdf::ModelD;
using brdf::Rgbd;
using brdf::Sample;

constexpr std::size_t kBatch = 256;            // samples per residual block (without robust loss)
constexpr std::size_t kScoreSamples = 4000;    // samples used to score multi-start candidates
constexpr std::size_t kCoarseSamples = 20000;  // first solve of a large input
constexpr std::size_t kScreenSamples = 1500;   // short solves that rank the best starts
constexpr std::size_t kScreenStarts = 4;       // starts screened by a short solve
constexpr int kScreenIterations = 15;          // iterations of a screening solve
constexpr std::size_t kMaxRejectedLines = 100;
constexpr double kVanishedShare = 1e-3;  // a lobe below this share of the reflectance vanished
// Residuals above which ceres::Covariance (dense SVD of J) gives way to the eigen decomposition
// of the normal matrix accumulated over the threads.
constexpr std::size_t kCovarianceRows = 30000;

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

/// Objective value (1/2 sum of squared residuals, as Ceres reports it) of a model on samples.
double objective(const ParameterMap& map,
                 const std::vector<double>& x,
                 const std::vector<Sample>& samples,
                 const CostOptions& co) {
    auto map_ptr = std::make_shared<const ParameterMap>(map);
    auto cost = make_batch_cost(map_ptr, samples, co);
    std::vector<double> r(3 * samples.size());
    const double* params[] = {x.data()};
    if (!cost->Evaluate(params, r.data(), nullptr)) {
        return std::numeric_limits<double>::infinity();
    }
    double s = 0;
    for (double v : r) {
        s += v * v;
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
std::vector<Candidate> initial_candidates(const ParameterMap& map,
                                          const std::vector<Sample>& samples,
                                          const FitOptions& o,
                                          const CostOptions& co) {
    const std::vector<Sample> score_set = stratified_reduce(samples, kScoreSamples, o.seed);
    ModelD m = map.base();
    std::vector<Candidate> out;
    if (m.lobes.empty()) {
        linear_init(m, map, score_set, o.relative_floor);
        Candidate c{clamp_start(map, map.values_of(m)), 0};
        c.cost = objective(map, c.x, score_set, co);
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
        c.cost = objective(map, c.x, score_set, co);
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

std::unique_ptr<ceres::Problem> build_problem(std::shared_ptr<const ParameterMap> map,
                                              const std::vector<Sample>& samples,
                                              const FitOptions& o,
                                              const CostOptions& co,
                                              std::vector<double>& x) {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    auto problem = std::make_unique<ceres::Problem>(po);
    // A robust loss acts on each sample's own squared residual, so each sample is then its own
    // block; otherwise samples are batched to amortise the per-block overhead.
    const std::size_t batch = o.loss == LossKind::kNone ? kBatch : 1;
    for (std::size_t b = 0; b < samples.size(); b += batch) {
        const std::vector<Sample> part(
            samples.begin() + static_cast<long>(b),
            samples.begin() + static_cast<long>(std::min(samples.size(), b + batch)));
        ceres::LossFunction* loss = nullptr;
        if (o.loss == LossKind::kHuber) {
            loss = new ceres::HuberLoss(o.loss_scale);
        } else if (o.loss == LossKind::kCauchy) {
            loss = new ceres::CauchyLoss(o.loss_scale);
        }
        problem->AddResidualBlock(make_batch_cost(map, part, co).release(), loss, x.data());
    }
    for (int k = 0; k < map->size(); ++k) {
        const ScalarParam& s = map->scalars()[map->free()[k]];
        problem->SetParameterLowerBound(x.data(), k, s.lower);
        problem->SetParameterUpperBound(x.data(), k, s.upper);
    }
    return problem;
}

SolveOutcome solve(std::shared_ptr<const ParameterMap> map,
                   const std::vector<Sample>& samples,
                   const FitOptions& o,
                   const CostOptions& co,
                   std::vector<double> x0,
                   double tolerance = 1e-12) {
    SolveOutcome out;
    out.x = std::move(x0);
    auto problem = build_problem(map, samples, o, co, out.x);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
    so.max_num_iterations = o.max_iterations;
    so.num_threads = thread_count(o.num_threads);
    so.function_tolerance = tolerance;
    so.gradient_tolerance = 1e-2 * tolerance;
    so.parameter_tolerance = tolerance;
    so.check_gradients = o.check_gradients;
    so.logging_type = ceres::SILENT;
    ceres::Solve(so, problem.get(), &out.summary);
    return out;
}

std::string termination_name(ceres::TerminationType t) {
    return ceres::TerminationTypeToString(t);
}

// ---------------------------------------------------------------------------------------------
// Uncertainties

/// J^T J of the residuals of `samples` at x, accumulated per thread over batches of kBatch samples
/// (the Jacobian is never stored whole). False when a residual or derivative is not finite.
bool normal_matrix(const std::shared_ptr<const ParameterMap>& map,
                   const std::vector<Sample>& samples,
                   const CostOptions& co,
                   const std::vector<double>& x,
                   int threads,
                   Eigen::MatrixXd& jtj) {
    const int n = map->size();
    const std::size_t batches = (samples.size() + kBatch - 1) / kBatch;
    const int t_count = std::max(1, threads);
    std::vector<Eigen::MatrixXd> partial(t_count, Eigen::MatrixXd::Zero(n, n));
    std::vector<char> ok(t_count, 1);
    auto body = [&](int t, std::size_t b0, std::size_t b1) {
        using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
        RowMajor jac(3 * kBatch, n);
        std::vector<double> r(3 * kBatch);
        std::vector<Sample> part;
        for (std::size_t b = b0; b < b1 && ok[t]; ++b) {
            const std::size_t lo = b * kBatch;
            const std::size_t hi = std::min(samples.size(), lo + kBatch);
            part.assign(samples.begin() + static_cast<long>(lo),
                        samples.begin() + static_cast<long>(hi));
            auto cost = make_batch_cost(map, part, co);
            const double* params[] = {x.data()};
            double* jacs[] = {jac.data()};
            if (!cost->Evaluate(params, r.data(), jacs)) {
                ok[t] = 0;
                break;
            }
            const long m = static_cast<long>(3 * part.size());
            partial[t].noalias() += jac.topRows(m).transpose() * jac.topRows(m);
        }
    };
    if (t_count <= 1 || batches < 2) {
        body(0, 0, batches);
    } else {
        std::vector<std::thread> pool;
        const std::size_t chunk = (batches + t_count - 1) / t_count;
        for (int t = 0; t < t_count; ++t) {
            const std::size_t b = t * chunk;
            const std::size_t e = std::min(batches, b + chunk);
            if (b < e) {
                pool.emplace_back(body, t, b, e);
            }
        }
        for (std::thread& th : pool) {
            th.join();
        }
    }
    jtj.setZero();
    for (int t = 0; t < t_count; ++t) {
        if (!ok[t]) {
            return false;
        }
        jtj += partial[t];
    }
    return jtj.allFinite();
}

/// Fills sigma / identifiable of the free parameters from the Jacobian J at the solution.
/// Not identifiable: (1) a parameter whose effect on the residuals over a step of its own size,
/// |J_k| max(|x_k|, 1e-3 (upper - lower)), is below 1e-8 of the largest such effect (for example
/// alpha of a lobe whose scale went to 0); (2) among the others, every parameter with a component
/// above 0.1 in an eigenvector of the column-scaled normal matrix D J^T J D (unit diagonal) whose
/// eigenvalue is below 1e-10 of the largest (a combination the data do not constrain). When all
/// are identifiable the covariance (J^T J)^-1 comes from ceres::Covariance (dense SVD; above
/// kCovarianceRows residuals from the inverse of the normal matrix, already known to be well
/// conditioned); it is
/// scaled by the reduced chi-square when the data carry no sigma. When some are not, the others'
/// sigmas are those of the sub-problem with the non-identifiable ones held fixed.
void uncertainties(std::shared_ptr<const ParameterMap> map,
                   const std::vector<Sample>& samples,
                   const FitOptions& o,
                   const CostOptions& co,
                   std::vector<double> x,
                   double final_cost,
                   bool absolute_sigma,
                   std::vector<FittedParameter>& params,
                   std::vector<std::string>& not_identifiable) {
    const int n = map->size();
    const std::size_t rows = 3 * samples.size();
    // Above kCovarianceRows residuals (and without a robust loss, whose curvature correction
    // Ceres applies to the Jacobian) the normal matrix is accumulated here batch by batch over the
    // threads, without a Ceres problem or a stored Jacobian; ceres::Covariance is not used there.
    const bool direct = o.loss == LossKind::kNone && rows > kCovarianceRows;
    std::unique_ptr<ceres::Problem> problem;
    Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(n, n);
    bool evaluated = false;
    if (direct) {
        evaluated = normal_matrix(map, samples, co, x, thread_count(o.num_threads), jtj);
    } else {
        problem = build_problem(map, samples, o, co, x);
        ceres::CRSMatrix jac;
        ceres::Problem::EvaluateOptions eo;
        eo.num_threads = thread_count(o.num_threads);
        evaluated = problem->Evaluate(eo, nullptr, nullptr, nullptr, &jac);
        for (int r = 0; evaluated && r < jac.num_rows; ++r) {
            for (int a = jac.rows[r]; a < jac.rows[r + 1]; ++a) {
                for (int b = jac.rows[r]; b < jac.rows[r + 1]; ++b) {
                    jtj(jac.cols[a], jac.cols[b]) += jac.values[a] * jac.values[b];
                }
            }
        }
    }
    std::vector<bool> ident(n, true);
    std::vector<double> sigma(n, -1);
    if (!evaluated) {
        ident.assign(n, false);
    } else {
        // (1) Effect of each parameter over a step of its own size.
        std::vector<double> effect(n);
        double max_effect = 0;
        for (int k = 0; k < n; ++k) {
            const ScalarParam& s = map->scalars()[map->free()[k]];
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
        Eigen::MatrixXd sub(m, m);
        Eigen::VectorXd scale(m);
        for (int a = 0; a < m; ++a) {
            scale[a] = 1 / std::sqrt(jtj(kept[a], kept[a]));
            for (int b = 0; b < m; ++b) {
                sub(a, b) = jtj(kept[a], kept[b]);
            }
        }
        // (Eigen's solver is not defined on an empty matrix: every branch below checks m, g > 0.)
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;
        bool well_conditioned = m > 0;
        if (m > 0) {
            eig.compute(scale.asDiagonal() * sub * scale.asDiagonal());
            const double lmax = eig.eigenvalues().maxCoeff();
            for (int e = 0; e < m; ++e) {
                if (eig.eigenvalues()[e] < 1e-10 * lmax) {
                    well_conditioned = false;
                    for (int a = 0; a < m; ++a) {
                        if (std::abs(eig.eigenvectors()(a, e)) > 0.1) {
                            ident[kept[a]] = false;
                        }
                    }
                }
            }
        }
        const double dof = static_cast<double>(rows) - n;
        const double s2 = absolute_sigma || dof <= 0 ? 1.0 : 2 * final_cost / dof;
        if (well_conditioned && m == n) {
            ceres::Covariance::Options cov_o;
            cov_o.algorithm_type = ceres::DENSE_SVD;
            cov_o.num_threads = thread_count(o.num_threads);
            cov_o.min_reciprocal_condition_number = 1e-14;
            ceres::Covariance cov(cov_o);
            std::vector<std::pair<const double*, const double*>> blocks = {{x.data(), x.data()}};
            Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(n, n);
            bool ok = problem != nullptr && rows <= kCovarianceRows &&
                      cov.Compute(blocks, problem.get()) &&
                      cov.GetCovarianceBlock(x.data(), x.data(), c.data());
            if (!ok) {
                const Eigen::MatrixXd inv = eig.eigenvectors() *
                                            eig.eigenvalues().cwiseInverse().asDiagonal() *
                                            eig.eigenvectors().transpose();
                c = scale.asDiagonal() * inv * scale.asDiagonal();
            }
            for (int k = 0; k < n; ++k) {
                sigma[k] = std::sqrt(std::max(0.0, c(k, k) * s2));
            }
        } else if (m > 0) {
            // Sigmas of the identifiable ones with the others held at their values.
            std::vector<int> good;
            for (int a = 0; a < m; ++a) {
                if (ident[kept[a]]) {
                    good.push_back(a);
                }
            }
            const int g = static_cast<int>(good.size());
            Eigen::MatrixXd gg(g, g);
            for (int a = 0; a < g; ++a) {
                for (int b = 0; b < g; ++b) {
                    gg(a, b) = sub(good[a], good[b]);
                }
            }
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ge;
            if (g > 0) {
                ge.compute(gg);
            }
            if (g > 0 && ge.eigenvalues().minCoeff() > 1e-12 * ge.eigenvalues().maxCoeff()) {
                const Eigen::MatrixXd inv = ge.eigenvectors() *
                                            ge.eigenvalues().cwiseInverse().asDiagonal() *
                                            ge.eigenvectors().transpose();
                for (int a = 0; a < g; ++a) {
                    sigma[kept[good[a]]] = std::sqrt(std::max(0.0, inv(a, a) * s2));
                }
            }
        }
    }
    for (int k = 0; k < n; ++k) {
        const std::string& name = map->scalars()[map->free()[k]].name;
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

}  // namespace

Metrics evaluate_metrics(const ModelD& model,
                         const std::vector<Sample>& samples,
                         double relative_floor) {
    Metrics m;
    if (samples.empty()) {
        return m;
    }
    const int threads = thread_count(0);
    std::vector<Eigen::Array<double, 3, 3>> partial(std::max(1, threads),
                                                    Eigen::Array<double, 3, 3>::Zero());
    auto body = [&](int t, std::size_t b, std::size_t e) {
        Eigen::Array<double, 3, 3> acc = Eigen::Array<double, 3, 3>::Zero();
        for (std::size_t i = b; i < e; ++i) {
            const brdf::Vec3d wi = samples[i].wi();
            const brdf::Vec3d wo = samples[i].wo();
            const Rgbd f = brdf::eval_model(model, wi, wo);
            for (int c = 0; c < 3; ++c) {
                const double d = samples[i].value[c];
                const double abs_r = f[c] - d;
                const double rel_r =
                    channel_residual(ResidualForm::kRelative, f[c], d, wi.z(), relative_floor);
                const double log_r = channel_residual(ResidualForm::kLog, f[c], d, wi.z(), 0);
                acc(0, c) += abs_r * abs_r;
                acc(1, c) += rel_r * rel_r;
                acc(2, c) += log_r * log_r;
            }
        }
        partial[t] += acc;
    };
    parallel_for(samples.size(), threads, body);
    Eigen::Array<double, 3, 3> total = Eigen::Array<double, 3, 3>::Zero();
    for (const auto& p : partial) {
        total += p;
    }
    const double n = static_cast<double>(samples.size());
    for (int c = 0; c < 3; ++c) {
        m.rmse[c] = std::sqrt(total(0, c) / n);
        m.rel_rmse[c] = std::sqrt(total(1, c) / n);
        m.log_rmse[c] = std::sqrt(total(2, c) / n);
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
    if (o.starts < 1 || o.max_iterations < 1 || !(o.relative_floor > 0) || !(o.loss_scale > 0)) {
        return make_error(
            "fit options: starts >= 1, max_iterations >= 1, relative_floor > 0 and loss_scale > 0 "
            "are required");
    }
    FitResult result;
    result.data = data.source;
    result.residual = o.residual;
    result.loss = o.loss;

    // Validity: rows rejected while reading plus samples that break the rules now (a dataset
    // built in memory has not been through the reader), reference re-measurements and saturated
    // samples (their value is only a lower bound).
    std::vector<Sample> valid;
    valid.reserve(data.samples.size());
    std::vector<std::size_t> rejected_lines;
    for (const brdf::RejectedRow& r : data.rejected) {
        rejected_lines.push_back(r.line);
    }
    std::size_t rejected_here = 0;
    // The checks run over the threads; the copy keeps the input order. (wi.z = cos theta_i.)
    std::vector<char> bad_flag(data.samples.size(), 0);
    parallel_for(
        data.samples.size(), thread_count(o.num_threads), [&](int, std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) {
                const Sample& s = data.samples[i];
                bad_flag[i] = !brdf::validate_sample(s).empty() ||
                              (s.flags & (brdf::kFlagReference | brdf::kFlagSaturated)) != 0 ||
                              !(std::cos(s.theta_i) > 0) || !(std::cos(s.theta_o) > 0);
            }
        });
    for (std::size_t i = 0; i < data.samples.size(); ++i) {
        const Sample& s = data.samples[i];
        if (bad_flag[i]) {
            ++rejected_here;
            rejected_lines.push_back(s.line != 0 ? s.line : i + 1);
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
                          std::to_string(result.samples.rejected) + " rejected)");
    }
    // Without a reduction the solve works on `valid` itself (no copy of a million samples).
    std::vector<Sample> reduced;
    const bool reduce = o.max_samples > 0 && o.max_samples < valid.size();
    if (reduce) {
        reduced = stratified_reduce(valid, o.max_samples, o.seed);
    }
    const std::vector<Sample>& used = reduce ? reduced : valid;
    result.samples.used = used.size();

    auto map = std::make_shared<ParameterMap>(*map_or);
    CostOptions co;
    co.residual = o.residual;
    co.relative_floor = o.relative_floor;
    co.use_sigma = o.use_sigma && data.has_sigma;

    // Coarse to fine: on a large input each candidate is first solved on a stratified subset of
    // kCoarseSamples, and the full solve starts from there (a few iterations instead of tens). The
    // starts are scored on a stratified subset of that subset (the product of the two reductions'
    // weights still preserves each stratum's sum), so that only one pass goes over all samples.
    const std::vector<Sample> coarse = used.size() > 2 * kCoarseSamples
                                           ? stratified_reduce(used, kCoarseSamples, o.seed + 1)
                                           : std::vector<Sample>{};
    std::vector<Candidate> candidates;
    if (o.auto_init) {
        candidates = initial_candidates(*map, coarse.empty() ? used : coarse, o, co);
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

    // Screening: short, loose solves from the best-scored starts on a small stratified subset;
    // those starts are then ranked by the cost they reach and continue from where they stopped.
    // A start's raw cost misleads when its width is right but its amplitudes are not (for
    // example a narrow lobe under a grid that misses most of its peak), and a full solve from a
    // wrong start ends in a local minimum: the tails of a wide lobe standing in for the diffuse
    // term.
    if (o.auto_init && candidates.size() > 1) {
        const std::vector<Sample> screen =
            stratified_reduce(coarse.empty() ? used : coarse, kScreenSamples, o.seed + 2);
        FitOptions short_o = o;
        short_o.max_iterations = std::min(o.max_iterations, kScreenIterations);
        const std::size_t k = std::min(candidates.size(), kScreenStarts);
        for (std::size_t c = 0; c < k; ++c) {
            SolveOutcome s = solve(map, screen, short_o, co, candidates[c].x, 1e-6);
            bool finite = s.summary.IsSolutionUsable() && std::isfinite(s.summary.final_cost);
            for (double v : s.x) {
                finite = finite && std::isfinite(v);
            }
            if (finite) {
                candidates[c].x = s.x;
                candidates[c].cost = s.summary.final_cost;
            } else {
                candidates[c].cost = std::numeric_limits<double>::infinity();
            }
        }
        std::stable_sort(candidates.begin(),
                         candidates.begin() + static_cast<long>(k),
                         [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
    }

    // Solve from the best start; when it does not converge, from the next ones (at most three).
    const auto t_solve = std::chrono::steady_clock::now();
    SolveOutcome best;
    bool have = false;
    for (std::size_t c = 0; c < candidates.size() && c < 3; ++c) {
        std::vector<double> start = candidates[c].x;
        if (!coarse.empty()) {
            SolveOutcome pre = solve(map, coarse, o, co, start);
            if (pre.summary.IsSolutionUsable()) {
                start = pre.x;
            }
        }
        SolveOutcome s = solve(map, used, o, co, start);
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
    result.solver.solve_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_solve).count();
    const ceres::Solver::Summary& sum = best.summary;
    result.solver.iterations = static_cast<int>(sum.iterations.size()) - 1;
    result.solver.termination = termination_name(sum.termination_type);
    result.solver.message = sum.message;
    result.solver.initial_cost = sum.initial_cost;
    result.solver.final_cost = sum.final_cost;
    bool finite = true;
    for (double v : best.x) {
        finite = finite && std::isfinite(v);
    }
    result.solver.usable = sum.termination_type == ceres::CONVERGENCE && finite;
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
    for (FittedParameter& p : result.parameters) {
        for (const ScalarParam& s : map->scalars()) {
            if (!s.free || s.name != p.name) {
                continue;
            }
            const double tol = 1e-9 * std::max(s.upper - s.lower, 1e-300);
            if (p.value <= s.lower + tol) {
                p.at_bound = "lower";
            } else if (p.value >= s.upper - tol) {
                p.at_bound = "upper";
            }
            if (!p.at_bound.empty()) {
                char buf[64];
                std::snprintf(buf, sizeof buf, "%.6g", p.at_bound == "lower" ? s.lower : s.upper);
                result.at_bounds.push_back(p.name + " (" + p.at_bound + " bound " + buf + ")");
            }
        }
    }
    if (!result.model.lobes.empty()) {
        const std::vector<double> share = lobe_shares(result.model, coarse.empty() ? used : coarse);
        for (std::size_t l = 0; l < share.size(); ++l) {
            if (!(share[l] >= kVanishedShare)) {
                result.vanished_lobes.push_back("lobes[" + std::to_string(l) + "]");
            }
        }
    }
    if (result.solver.usable && o.covariance) {
        uncertainties(map,
                      used,
                      o,
                      co,
                      best.x,
                      sum.final_cost,
                      co.use_sigma,
                      result.parameters,
                      result.not_identifiable);
    }
    result.metrics = evaluate_metrics(result.model, valid, o.relative_floor);
    result.solver.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return result;
}

}  // namespace gonio::fitting
