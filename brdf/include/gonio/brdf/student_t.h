#pragma once

// The Student-t distribution of slopes (STD): a microfacet normal distribution with a tail
// parameter gamma that contains GGX (gamma = 2) and tends to Beckmann (gamma -> infinity), with its
// Smith Lambda.
//
// [RBMS17] M. Ribardiere, B. Bringier, D. Meneveaux, L. Simonot, "STD: Student's t-Distribution
//          of Slopes for Microfacet Based BSDFs", Computer Graphics Forum 36(2), 2017: the
//          bivariate Student-t distribution of slopes, its NDF and Smith masking.
// [H14]    E. Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
//          JCGT 3(2), 2014, sec. 5: Lambda(w) = (1/mu) integral_mu^inf (q - mu) P2(q) dq with
//          P2 the marginal of the slope distribution along the direction's azimuth, mu = cot(theta)
//          / alpha(phi).
// [AS64]   M. Abramowitz, I. Stegun, "Handbook of Mathematical Functions", 1964: 26.5.8 (the
//          continued fraction of the incomplete beta function), 26.7.1 (Student's t in terms of
//          it), 6.1.40 (Stirling's series of log Gamma).
//
// Slopes normalised by alpha follow p(x, y) = (gamma - 1)^gamma / (pi (gamma - 1 + x^2 +
// y^2)^gamma) [RBMS17], hence
//   D(h) = (1 + e / (gamma - 1))^-gamma / (pi alpha_x alpha_y cos^4 theta_h),
//   e = (h_x^2 / alpha_x^2 + h_y^2 / alpha_y^2) / h_z^2,
// normalised over projected area for every gamma > 1. gamma = 2 is GGX exactly; as gamma grows,
// (1 + e / (gamma - 1))^-gamma -> exp(-e), Beckmann. The one-dimensional marginal of p is a
// Student-t with nu = 2 gamma - 2 degrees of freedom scaled by 1/sqrt(2), so Smith's integral has
// the closed form (c = gamma - 1, a2 = 1 / mu^2 = (alpha_x^2 w_x^2 + alpha_y^2 w_y^2) / w_z^2,
// u = c a2, w = u / (1 + u), B = B(c, 1/2)):
//   Lambda = P (1 + u) / (2 c - 1) - S,   P = w^c (1 - w)^(1/2) / B,
//   S = Prob(slope > mu) = I_w(c, 1/2) / 2   (regularised incomplete beta [AS64 26.7.1]),
// finite for gamma > 3/2 only: below, the mean slope is infinite and every direction but the
// normal is fully masked. At gamma = 2 this equals GGX's (sqrt(1 + a2) - 1) / 2 (tests check it).
//
// The functions are templated on the scalar (double, ceres::Jet). The continued fraction runs
// until its value changes by less than 1e-15 relative (at most 300 terms; 4 to 40 for gamma in
// [1.6, 100]); the derivative of a Jet is that of the evaluated terms.

#include <cmath>
#include <limits>

#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// Smallest and largest tail parameters gamma the fits use. Lambda is finite above 3/2. Against
/// Beckmann, log D differs by (e^2 / 2 - e) / (gamma - 1) to first order (e as in D_student_t): at
/// gamma = 100 under 2 % for e <= 3 (D above 5 % of its peak), 18 % at e = 6.9 (1e-3 of it).
constexpr double kStudentTGammaMin = 1.6;
constexpr double kStudentTGammaMax = 100.0;

namespace student_t_detail {

/// log Gamma(x) for x > 0 by Stirling's series [AS64 6.1.40] at x + 10 and the recurrence
/// Gamma(x + 1) = x Gamma(x): relative error below 1e-14 for every x > 0.3. Templated so that
/// Jets carry d/dx = digamma(x) through.
template <class T>
inline T log_gamma(const T& x) {
    using std::log;
    // log(x (x + 1) ... (x + 9)) as a sum of logs of products of two (no overflow for x < 1e30).
    T shift_log = T(0);
    for (int j = 0; j < 10; j += 2) {
        shift_log += log((x + T(j)) * (x + T(j + 1)));
    }
    const T z = x + T(10);
    const T iz = T(1) / z;
    const T iz2 = iz * iz;
    constexpr double kHalfLog2Pi = 0.91893853320467274178;
    const T series =
        iz * (T(1.0 / 12) +
              iz2 * (T(-1.0 / 360) +
                     iz2 * (T(1.0 / 1260) + iz2 * (T(-1.0 / 1680) + iz2 * T(1.0 / 1188)))));
    return (z - T(0.5)) * log(z) - z + T(kHalfLog2Pi) + series - shift_log;
}

/// The continued fraction of the regularised incomplete beta function [AS64 26.5.8],
///   I_x(a, b) = x^a (1 - x)^b / (a B(a, b)) * cf(x; a, b),
/// evaluated by the modified Lentz method; converges fast for x < (a + 1) / (a + b + 2).
template <class T>
inline T beta_cf(const T& x, const T& a, const T& b) {
    using std::abs;
    const double tiny = 1e-300;
    auto guard = [&](const T& v) {
        // Lentz's method: a zero denominator is replaced by a tiny one.
        return abs(value_of(v)) < tiny ? T(tiny) : v;
    };
    T c = T(1);
    T d = guard(T(1) - (a + b) * x / (a + T(1)));
    d = T(1) / d;
    T h = d;
    for (int m = 1; m <= 300; ++m) {
        const T m_t = T(double(m));
        const T m2 = T(2.0 * m);
        // Even step d_2m = m (b - m) x / ((a + 2m - 1)(a + 2m)).
        T aa = m_t * (b - m_t) * x / ((a + m2 - T(1)) * (a + m2));
        d = guard(T(1) + aa * d);
        c = guard(T(1) + aa / c);
        d = T(1) / d;
        h *= d * c;
        // Odd step d_2m+1 = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
        aa = -(a + m_t) * (a + b + m_t) * x / ((a + m2) * (a + m2 + T(1)));
        d = guard(T(1) + aa * d);
        c = guard(T(1) + aa / c);
        d = T(1) / d;
        const T del = d * c;
        h *= del;
        if (abs(value_of(del) - 1.0) < 1e-15) {
            break;
        }
    }
    return h;
}

}  // namespace student_t_detail

/// STD normal distribution [RBMS17]
///   D(h) = (1 + e / (gamma - 1))^-gamma / (pi alpha_x alpha_y h_z^4),
///   e = (h_x^2 / alpha_x^2 + h_y^2 / alpha_y^2) / h_z^2,
/// 1/sr, normalised over projected area for gamma > 1; alpha_x, alpha_y > 0. Evaluated as
/// exp(-gamma log1p(e / (gamma - 1)) - 2 log(h_z^2)) so that neither factor overflows near the
/// horizon. Edge behaviour: 0 for h_z <= 0 (microfacet normals face outward) and for h_z^2 <
/// 1e-300 (there h_z D(h) ~ h_z^(2 gamma - 3) -> 0, no projected area; for gamma < 2 D itself
/// grows without bound toward the horizon). At h = z: 1 / (pi alpha_x alpha_y). From the squared
/// components of h (an isotropic caller may pass h_x^2 + h_y^2 as hx2 and 0 as hy2).
template <class T>
inline T D_student_t_from_squares(
    const T& hx2, const T& hy2, const T& hz2, const T& alpha_x, const T& alpha_y, const T& gamma) {
    using std::exp;
    using std::log;
    using std::log1p;
    if (!(hz2 >= T(1e-300))) {
        // At the horizon through rounding: no projected area.
        return T(0);
    }
    const T e = (hx2 / (alpha_x * alpha_x) + hy2 / (alpha_y * alpha_y)) / hz2;
    return exp(-gamma * log1p(e / (gamma - T(1))) - T(2) * log(hz2)) / (T(kPi) * alpha_x * alpha_y);
}

/// D_student_t_from_squares of a unit h given by its components.
template <class T>
inline T D_student_t(const Vec3<T>& h, const T& alpha_x, const T& alpha_y, const T& gamma) {
    if (h.z() <= T(0)) {
        // Outward normals only.
        return T(0);
    }
    return D_student_t_from_squares(sqr(h.x()), sqr(h.y()), sqr(h.z()), alpha_x, alpha_y, gamma);
}

/// Smith Lambda of the STD from a2 = (alpha_x^2 w_x^2 + alpha_y^2 w_y^2) / w_z^2 (= alpha(phi)^2
/// tan^2 theta) and gamma > 3/2; see the closed form at the top of this file. Output in [0, inf).
/// Edge behaviour: 0 at a2 <= 0 (along the normal); +infinity for an infinite a2 (the horizon).
/// For u = (gamma - 1) a2 below 2 gamma / 3 (w < (c + 1) / (c + 5/2)) the direct fraction is used,
/// above it the complement I_w(a, b) = 1 - I_(1-w)(b, a), each where its continued fraction
/// converges fast.
template <class T>
inline T lambda_student_t_a2(const T& a2, const T& gamma) {
    using std::exp;
    using std::log;
    using std::log1p;
    using student_t_detail::beta_cf;
    using student_t_detail::log_gamma;
    if (a2 <= T(0)) {
        // Along the normal: nothing is masked.
        return T(0);
    }
    if (!(value_of(a2) < std::numeric_limits<double>::infinity())) {
        // At the horizon: fully masked.
        return T(std::numeric_limits<double>::infinity());
    }
    const T c = gamma - T(1);
    const T u = c * a2;
    // 1 / B(c, 1/2) = Gamma(c + 1/2) / (sqrt(pi) Gamma(c)).
    constexpr double kHalfLogPi = 0.57236494292470008707;
    const T log_inv_b = log_gamma(c + T(0.5)) - log_gamma(c) - T(kHalfLogPi);
    // P = w^c (1 - w)^(1/2) / B with w = u / (1 + u): u^c (1 + u)^(-c - 1/2) / B.
    const T log1p_u = log1p(u);
    const T P = exp(c * log(u) - (c + T(0.5)) * log1p_u + log_inv_b);
    const T first = P * (T(1) + u) / (T(2) * c - T(1));
    const T w = u / (T(1) + u);
    const T one_minus_w = T(1) / (T(1) + u);
    if (w < (c + T(1)) / (c + T(2.5))) {
        // S = I_w(c, 1/2) / 2 = P cf(w; c, 1/2) / (2 c).
        return first - P * beta_cf(w, c, T(0.5)) / (T(2) * c);
    }
    // S = 1/2 - I_(1-w)(1/2, c) / 2 = 1/2 - P cf(1 - w; 1/2, c).
    return first - T(0.5) + P * beta_cf(one_minus_w, T(0.5), c);
}

/// Smith Lambda of the STD for a direction w (unit, local frame) [H14 sec. 5], [RBMS17].
/// Edge behaviour: +infinity for w_z <= 0 (masked); 0 at w = z.
template <class T>
inline T lambda_student_t(const Vec3<T>& w, const T& alpha_x, const T& alpha_y, const T& gamma) {
    if (w.z() <= T(0)) {
        // At or below the horizon: masked.
        return T(std::numeric_limits<double>::infinity());
    }
    const T a2 = (sqr(alpha_x * w.x()) + sqr(alpha_y * w.y())) / sqr(w.z());
    return lambda_student_t_a2(a2, gamma);
}

}  // namespace gonio::brdf
