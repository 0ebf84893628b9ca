// Solve: bounded Levenberg-Marquardt on the normal-equation form of the prepared samples.

#include <algorithm>
#include <cmath>

#include "fit_stages.h"

namespace gonio::fitting::detail {

namespace {

using brdf::Rgbd;
using brdf::Sample;

ceres::LossFunction* make_loss(const FitOptions& o) {
    if (o.loss == LossKind::kHuber) {
        return new ceres::HuberLoss(o.loss_scale);
    }
    if (o.loss == LossKind::kCauchy) {
        return new ceres::CauchyLoss(o.loss_scale);
    }
    return nullptr;
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

/// The same problem as one residual block per sample (per-sample robust loss as Ceres applies
/// it), for Ceres' own gradient check (FitOptions::check_gradients): slow, for testing.
SolveOutcome solve_checked(const FitContext& ctx,
                           const std::vector<Sample>& samples,
                           std::vector<double> x0) {
    SolveOutcome out;
    out.x = std::move(x0);
    ceres::Problem problem;
    for (const Sample& s : samples) {
        problem.AddResidualBlock(make_batch_cost(ctx.map, {s}, ctx.cost).release(),
                                 make_loss(ctx.options),
                                 out.x.data());
    }
    set_bounds(problem, *ctx.map, out.x.data());
    ceres::Solver::Options so = solver_options(ctx.options.max_iterations, 1e-12);
    so.check_gradients = true;
    ceres::Solve(so, &problem, &out.summary);
    return out;
}

}  // namespace

int iterations_of(const ceres::Solver::Summary& s) {
    return std::max(0, static_cast<int>(s.iterations.size()) - 1);
}

bool all_finite(const std::vector<double>& x) {
    for (double v : x) {
        if (!std::isfinite(v)) {
            return false;
        }
    }
    return true;
}

void record_stage(SolverInfo& solver,
                  const std::string& name,
                  std::size_t samples,
                  const ceres::Solver::Summary& last,
                  Clock::time_point since,
                  int iterations) {
    StageInfo st;
    st.name = name;
    st.samples = samples;
    st.iterations = iterations;
    st.termination = ceres::TerminationTypeToString(last.termination_type);
    st.time_s = std::chrono::duration<double>(Clock::now() - since).count();
    st.final_cost = last.final_cost;
    solver.stages.push_back(st);
    solver.iterations += iterations;
}

std::shared_ptr<PreparedSamples> prepare(const FitContext& ctx,
                                         const std::vector<Sample>& samples) {
    auto ps = std::make_shared<PreparedSamples>(ctx.map, samples, ctx.cost);
    ps->set_loss(std::shared_ptr<const ceres::LossFunction>(make_loss(ctx.options)));
    return ps;
}

SolveOutcome solve(const FitContext& ctx,
                   const std::shared_ptr<const PreparedSamples>& ps,
                   std::vector<double> x0,
                   int max_iterations,
                   double tolerance,
                   bool hold_bounds) {
    SolveOutcome out;
    out.x = std::move(x0);
    ceres::Problem problem;
    problem.AddResidualBlock(new NormalEquationCost(ps, ctx.threads), nullptr, out.x.data());
    const ParameterMap& map = ps->map();
    set_bounds(problem, map, out.x.data());
    if (hold_bounds) {
        std::vector<int> held;
        for (int k = 0; k < map.size(); ++k) {
            if (at_bound(out.x[k], map.scalars()[map.free()[k]]) != Bound::kNone) {
                held.push_back(k);
            }
        }
        if (!held.empty() && static_cast<int>(held.size()) < map.size()) {
            problem.SetManifold(out.x.data(), new ceres::SubsetManifold(map.size(), held));
        }
    }
    ceres::Solve(solver_options(max_iterations, tolerance), &problem, &out.summary);
    return out;
}

SolveOutcome main_solve(const FitContext& ctx,
                        const std::shared_ptr<const PreparedSamples>& ps_work,
                        const std::vector<Sample>& work,
                        const std::vector<Candidate>& candidates,
                        const std::string& stage_name,
                        SolverInfo& solver) {
    const auto since = Clock::now();
    SolveOutcome best;
    bool have = false;
    int its = 0;
    for (std::size_t c = 0; c < candidates.size() && c < 3; ++c) {
        SolveOutcome s = ctx.options.check_gradients
                             ? solve_checked(ctx, work, candidates[c].x)
                             : solve(ctx, ps_work, candidates[c].x, ctx.options.max_iterations);
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
    record_stage(solver, stage_name, work.size(), best.summary, since, its);
    return best;
}

void refine(const FitContext& ctx,
            const std::vector<Sample>& used,
            bool reduced,
            std::shared_ptr<PreparedSamples>& ps_used,
            SolveOutcome& best,
            SolverInfo& solver) {
    const FitOptions& o = ctx.options;
    auto polish = [&](const std::string& name, int max_iterations) {
        const auto since = Clock::now();
        if (!ps_used) {
            ps_used = prepare(ctx, used);
        }
        // Relative cost changes below 1e-9 no longer move the parameters by a visible amount.
        SolveOutcome s = solve(ctx, ps_used, best.x, max_iterations, 1e-9, true);
        record_stage(solver, name, used.size(), s.summary, since, iterations_of(s.summary));
        // A polish that stops at its iteration bound still improves on a converged start.
        if (s.summary.IsSolutionUsable() && all_finite(s.x)) {
            best.x = s.x;
            best.summary.final_cost = s.summary.final_cost;
        }
    };
    if (reduced && o.polish_iterations > 0) {
        polish("polish", o.polish_iterations);
    }
    if (ctx.cost.use_sigma) {
        for (int round = 1; round <= o.reweight_rounds; ++round) {
            if (!ps_used) {
                ps_used = prepare(ctx, used);
            }
            std::vector<Rgbd> values;
            ps_used->model_values(ctx.map->model<double>(best.x.data()), values, ctx.threads);
            ps_used->reweight_relative(used, values);
            polish("reweight " + std::to_string(round),
                   reduced ? std::max(1, o.polish_iterations) : o.max_iterations);
        }
    }
}

}  // namespace gonio::fitting::detail
