#pragma once

// Derivatives with respect to the width alpha of an isotropic lobe (alpha_x = alpha_y = alpha) of
// the microfacet formulas of microfacet.h, in the same style: one body per formula, templated on
// the numeric type T (double and xsimd::batch; see math.h), branch-free with each degenerate case a
// commented branch of the mask. They serve the fitting's closed-form derivatives on packets, where
// a Jet cannot carry a packet through the masked formulas (a Jet's comparison returns one bool).
// Each is derived below from the formula it differentiates; tests/brdf/unit_microfacet_derivatives
// _test.cpp holds them against Jets of the formulas themselves.

#include <cmath>

#include "gonio/brdf/math.h"
#include "gonio/brdf/microfacet.h"

namespace gonio::brdf {

/// dD/dalpha of the isotropic GGX distribution D = 1 / (pi alpha^2 s^2), s = hxy2 / alpha^2 + hz2
/// (D_ggx_from_squares with hx2 = h_x^2 + h_y^2, hy2 = 0, alpha_x = alpha_y = alpha), given its
/// value D:
///   dD/dalpha = D (-2/alpha - 2 (ds/dalpha) / s),  ds/dalpha = -2 hxy2 / alpha^3 = -2 (s - hz2)/alpha
///             = (2 D / alpha) (1 - 2 hz2 / s).
/// No degenerate case: s >= hz2 > 0.
template <class T>
inline T dD_ggx_dalpha_from_squares(const T& hxy2, const T& hz2, const T& alpha, const T& D) {
    const T s = hxy2 / (alpha * alpha) + hz2;
    return T(2) * D / alpha * (T(1) - T(2) * hz2 / s);
}

/// dD/dalpha of the isotropic Beckmann distribution D = exp(-e) / (pi alpha^2 hz2^2),
/// e = hxy2 / (alpha^2 hz2) (D_beckmann_from_squares with hy2 = 0), given its value D:
///   de/dalpha = -2 e / alpha,  dD/dalpha = D (2 e / alpha - 2 / alpha) = (2 D / alpha) (e - 1).
/// Edge behaviour: 0 in the far tail where D_beckmann_from_squares returns 0 (e > 700, or h_z = 0).
template <class T>
inline T dD_beckmann_dalpha_from_squares(const T& hxy2, const T& hz2, const T& alpha, const T& D) {
    const T e = hxy2 / (alpha * alpha * hz2);
    const auto tail = !(e <= T(700));
    if (all_of(tail)) {
        // Far tail: D is exactly 0 and so is its derivative.
        return T(0);
    }
    // Branch of the mask: far tail (or NaN from h_z = 0), D = 0 with a zero derivative.
    return select(tail, T(0), T(2) * D / alpha * (select(tail, T(0), e) - T(1)));
}

/// dLambda/dalpha of the GGX Smith Lambda = (sqrt(1 + a2) - 1) / 2 (lambda_ggx_from_a2), where
/// a2 = alpha^2 tan^2(theta) is proportional to alpha^2 (da2/dalpha = 2 a2 / alpha):
///   dLambda/da2 = 1 / (4 sqrt(1 + a2)),  dLambda/dalpha = a2 / (2 alpha sqrt(1 + a2)).
/// No degenerate case for finite a2 >= 0 (0 along the normal).
template <class T>
inline T dlambda_ggx_dalpha_from_a2(const T& a2, const T& alpha) {
    using std::sqrt;
    return a2 / (T(2) * alpha * sqrt(T(1) + a2));
}

/// dLambda/dalpha of the exact Beckmann Smith Lambda (lambda_beckmann_from_a2),
///   Lambda = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2,  a = 1 / sqrt(a2) = 1 / (alpha tan(theta)):
///   d/da [exp(-a^2)/(a sqrt(pi))] = -2 exp(-a^2)/sqrt(pi) - exp(-a^2)/(a^2 sqrt(pi)),
///   d/da [-erfc(a)] = 2 exp(-a^2)/sqrt(pi), so dLambda/da = -exp(-a^2) / (2 a^2 sqrt(pi));
///   da/dalpha = -a / alpha, so dLambda/dalpha = exp(-a^2) / (2 a alpha sqrt(pi)).
/// Edge behaviour: 0 where lambda_beckmann_from_a2 returns 0 (a2 <= 1/676, a > 26: exp(-a^2)
/// below 1e-293).
template <class T>
inline T dlambda_beckmann_dalpha_from_a2(const T& a2, const T& alpha) {
    using std::exp;
    using std::sqrt;
    const auto negligible = a2 <= T(1.0 / 676.0);
    if (all_of(negligible)) {
        // Lambda is returned as exactly 0 there, and so is its derivative.
        return T(0);
    }
    // The negligible lanes evaluate at a = 1 and are replaced by 0 below.
    const T a = T(1) / sqrt(select(negligible, T(1), a2));
    const T d = exp(-a * a) * T(kInvSqrtPi) / (T(2) * a * alpha);
    // Branch of the mask: Lambda = 0 with a zero derivative.
    return select(negligible, T(0), d);
}

/// dG/dalpha of the height-correlated Smith G = 1 / (1 + Lambda_i + Lambda_o)
/// (G_smith_correlated) given G and the derivatives of the two Lambdas:
///   dG/dalpha = -G^2 (dLambda_i + dLambda_o).
template <class T>
inline T dG_smith_correlated(const T& G, const T& dlambda_i, const T& dlambda_o) {
    return -G * G * (dlambda_i + dlambda_o);
}

/// dG/dalpha of the separable Smith G = 1 / ((1 + Lambda_i)(1 + Lambda_o)) (G_smith_separable)
/// given G, the Lambdas and their derivatives:
///   dG/dalpha = -G (dLambda_i / (1 + Lambda_i) + dLambda_o / (1 + Lambda_o)).
template <class T>
inline T dG_smith_separable(
    const T& G, const T& lambda_i, const T& lambda_o, const T& dlambda_i, const T& dlambda_o) {
    return -G * (dlambda_i / (T(1) + lambda_i) + dlambda_o / (T(1) + lambda_o));
}

}  // namespace gonio::brdf
