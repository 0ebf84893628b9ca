// Uncertainties: identifiability and the covariance of the free parameters.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "fit_stages.h"

namespace gonio::fitting::detail {

namespace {

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

/// The covariance of the parameters `good` (free indices) into `out`, named.
void keep_covariance(const ParameterMap& map,
                     const std::vector<int>& good,
                     const Eigen::MatrixXd& cov,
                     ParameterCovariance* out) {
    const int g = static_cast<int>(good.size());
    out->names.clear();
    out->matrix.assign(static_cast<std::size_t>(g) * g, 0.0);
    for (int a = 0; a < g; ++a) {
        out->names.push_back(map.scalars()[map.free()[good[a]]].name);
        for (int b = 0; b < g; ++b) {
            out->matrix[static_cast<std::size_t>(a) * g + b] = cov(a, b);
        }
    }
}

/// The rows and columns `idx` of a square matrix.
Eigen::MatrixXd submatrix(const Eigen::MatrixXd& a, const std::vector<int>& idx) {
    const int m = static_cast<int>(idx.size());
    Eigen::MatrixXd sub(m, m);
    for (int r = 0; r < m; ++r) {
        for (int c = 0; c < m; ++c) {
            sub(r, c) = a(idx[r], idx[c]);
        }
    }
    return sub;
}

/// (1) The parameters with a visible effect on the residuals over a step of their own size;
/// the others are marked not identifiable in `ident`.
std::vector<int> visible_parameters(const ParameterMap& map,
                                    const Eigen::MatrixXd& jtj,
                                    const std::vector<double>& x,
                                    std::vector<bool>& ident) {
    const int n = map.size();
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
    return kept;
}

/// (2) Marks not identifiable every parameter of `kept` with a component above 0.1 in an
/// unconstrained combination of the column-scaled normal matrix.
void mark_unconstrained(const Eigen::MatrixXd& jtj,
                        const std::vector<int>& kept,
                        std::vector<bool>& ident) {
    const int m = static_cast<int>(kept.size());
    if (m == 0) {
        return;
    }
    const Eigen::MatrixXd sub = submatrix(jtj, kept);
    Eigen::VectorXd scale(m);
    for (int a = 0; a < m; ++a) {
        scale[a] = 1 / std::sqrt(jtj(kept[a], kept[a]));
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

/// The covariance of the parameters `good`: H^-1 max(1, chi2 / dof) with sigmas, the sandwich
/// H^-1 M H^-1 without. Empty when H is not invertible or the score products fail.
Eigen::MatrixXd covariance_of(const PreparedSamples& ps,
                              int threads,
                              const std::vector<double>& x,
                              bool with_sigma,
                              const std::optional<double>& reduced_chi2,
                              const Eigen::MatrixXd& jtj,
                              const std::vector<int>& good) {
    const int g = static_cast<int>(good.size());
    Eigen::MatrixXd h_inv;
    if (g == 0 || !spd_inverse(submatrix(jtj, good), h_inv)) {
        return {};
    }
    if (with_sigma) {
        const double s2 = reduced_chi2.has_value() ? std::max(1.0, *reduced_chi2) : 1.0;
        return h_inv * s2;
    }
    Eigen::MatrixXd meat_full;
    if (!ps.score_outer_products(x.data(), meat_full, threads)) {
        return {};
    }
    return h_inv * submatrix(meat_full, good) * h_inv;
}

/// Writes identifiable and sigma into the fitted parameters and lists the unidentifiable ones.
void write_parameters(const ParameterMap& map,
                      const std::vector<bool>& ident,
                      const std::vector<double>& sigma,
                      std::vector<FittedParameter>& params,
                      std::vector<std::string>& not_identifiable) {
    for (int k = 0; k < map.size(); ++k) {
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

}  // namespace

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
                   int threads,
                   const std::vector<double>& x,
                   bool with_sigma,
                   const std::vector<bool>& on_bound,
                   std::vector<FittedParameter>& params,
                   std::vector<std::string>& not_identifiable,
                   std::optional<double>* reduced_chi2,
                   ParameterCovariance* covariance) {
    const ParameterMap& map = ps.map();
    const int n = map.size();
    NormalEquations ne;
    const bool evaluated = ps.normal_equations(x.data(), ne, threads);
    const double dof = 3.0 * static_cast<double>(ps.size()) - n;
    if (evaluated && with_sigma && dof > 0) {
        *reduced_chi2 = ne.cost_sum / dof;
    }
    std::vector<bool> ident(n, evaluated);
    std::vector<double> sigma(n, -1);
    if (evaluated) {
        mark_unconstrained(ne.jtj, visible_parameters(map, ne.jtj, x, ident), ident);
        // Covariance of the identifiable parameters off their bounds, the others held.
        std::vector<int> good;
        for (int k = 0; k < n; ++k) {
            if (ident[k] && !on_bound[k]) {
                good.push_back(k);
            }
        }
        const int g = static_cast<int>(good.size());
        const Eigen::MatrixXd cov =
            covariance_of(ps, threads, x, with_sigma, *reduced_chi2, ne.jtj, good);
        for (int a = 0; a < g && cov.rows() == g; ++a) {
            sigma[good[a]] = std::sqrt(std::max(0.0, cov(a, a)));
        }
        if (g > 0 && cov.rows() == g && cov.allFinite()) {
            keep_covariance(map, good, cov, covariance);
        }
    }
    write_parameters(map, ident, sigma, params, not_identifiable);
}

}  // namespace gonio::fitting::detail
