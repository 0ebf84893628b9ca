#pragma once

// Microfacet normal distributions D and Smith masking functions Lambda, G1, G for the GGX
// (Trowbridge-Reitz) and Beckmann distributions, isotropic or anisotropic, plus the Cook-Torrance
// V-groove term. Conventions: z is the macro-surface normal, h the microfacet normal (unit),
// w a unit direction; alpha_x, alpha_y > 0 are the slope parameters along x and y (alpha itself,
// not a perceptual roughness). D is in 1/sr and normalised over projected area:
// integral over the hemisphere of D(h) cos(theta_h) dh = 1.
//
// Every formula has one body, templated on the numeric type T (double, ceres::Jet, xsimd::batch;
// see math.h): a "core" form on the precomputed quantities the fitting also stores (squared
// components of h, alpha^2 tan^2 theta), branch-free, and the form on unit vectors that computes
// those quantities and masks the horizon. Degenerate cases are masks merged with select, each one
// named in a comment.
//
// Main sources:
// [TR75] T. S. Trowbridge, K. P. Reitz, "Average irregularity representation of a rough surface
//        for ray reflection", JOSA 65(5), 1975.
// [W07]  B. Walter, S. Marschner, H. Li, K. Torrance, "Microfacet Models for Refraction through
//        Rough Surfaces", EGSR 2007, sec. 5 (eqs. 25-27 Beckmann, 33-34 GGX).
// [H14]  E. Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
//        JCGT 3(2), 2014: Smith Lambda for anisotropic distributions (sec. 5), separable and
//        height-correlated G2 (sec. 6).
// [CT82] R. L. Cook, K. E. Torrance, "A Reflectance Model for Computer Graphics", ACM TOG 1(1),
//        1982, sec. 3 (geometrical attenuation factor G).

#include <cmath>
#include <limits>

#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// GGX (Trowbridge-Reitz) distribution from the squared Cartesian components of the unit half
/// vector h (h_z > 0, which the caller's horizon mask guarantees):
///   D(h) = 1 / (pi alpha_x alpha_y (h_x^2/alpha_x^2 + h_y^2/alpha_y^2 + h_z^2)^2)
/// [TR75], [W07 eq. 33], [H14 sec. 5.2]; equal to the usual form with cos^4(theta_h) (1 +
/// tan^2 theta_h (...))^2 but without trigonometry. An isotropic caller may pass h_x^2 + h_y^2 as
/// hx2 and 0 as hy2. At h = z the value is 1/(pi alpha_x alpha_y) (3.2e7 at alpha = 1e-4, no
/// overflow). No degenerate case: the bracket is >= h_z^2 > 0.
/// Evaluated with one division: with the bracket times alpha_x^2 alpha_y^2,
///   u = h_x^2 alpha_y^2 + h_y^2 alpha_x^2 + h_z^2 alpha_x^2 alpha_y^2,
///   D = (alpha_x alpha_y)^3 / (pi u^2)
/// (a division is the slowest arithmetic of a packet; no under- or overflow for alpha >= 1e-6).
template <class T>
inline T D_ggx_from_squares(
    const T& hx2, const T& hy2, const T& hz2, const T& alpha_x, const T& alpha_y) {
    const T ax2 = alpha_x * alpha_x;
    const T ay2 = alpha_y * alpha_y;
    const T axy = alpha_x * alpha_y;
    const T u = hx2 * ay2 + hy2 * ax2 + hz2 * (ax2 * ay2);
    return axy * axy * axy / (T(kPi) * u * u);
}

/// GGX distribution D(h) of a unit half vector h, 1/sr (see D_ggx_from_squares). Edge
/// behaviour: 0 for h_z <= 0.
template <class T>
inline T D_ggx(const Vec3<T>& h, const T& alpha_x, const T& alpha_y) {
    const auto below = h.z() <= T(0);
    if (all_of(below)) {
        // Microfacet normals face outward only.
        return T(0);
    }
    const T D = D_ggx_from_squares(sqr(h.x()), sqr(h.y()), sqr(h.z()), alpha_x, alpha_y);
    // Branch of the mask: below the horizon, no microfacet.
    return select(below, T(0), D);
}

/// Beckmann distribution from the squared components of the unit half vector h (h_z > 0):
///   D(h) = exp(-(h_x^2/alpha_x^2 + h_y^2/alpha_y^2) / h_z^2) / (pi alpha_x alpha_y h_z^4)
/// [W07 eq. 25], [H14 sec. 5.1]. Edge behaviour: when the exponent's argument exceeds 700 the
/// value is below 1e-300 and returned as exactly 0 (this avoids 0/0 when h_z^4 underflows near
/// the horizon).
template <class T>
inline T D_beckmann_from_squares(
    const T& hx2, const T& hy2, const T& hz2, const T& alpha_x, const T& alpha_y) {
    using std::exp;
    const T e = (hx2 / (alpha_x * alpha_x) + hy2 / (alpha_y * alpha_y)) / hz2;
    const auto tail = !(e <= T(700));
    if (all_of(tail)) {
        // Far tail: exp(-e) underflows; the exact value is < 1e-300 for every alpha in use.
        return T(0);
    }
    // The tail lanes evaluate at h = z (e = 0, hz2 = 1) and are replaced by 0 below.
    const T e_safe = select(tail, T(0), e);
    const T hz2_safe = select(tail, T(1), hz2);
    const T D = exp(-e_safe) / (T(kPi) * alpha_x * alpha_y * hz2_safe * hz2_safe);
    // Branch of the mask: far tail (or NaN from h_z = 0), exactly 0.
    return select(tail, T(0), D);
}

/// Beckmann distribution D(h) of a unit half vector h, 1/sr (see D_beckmann_from_squares). Edge
/// behaviour: 0 for h_z <= 0.
template <class T>
inline T D_beckmann(const Vec3<T>& h, const T& alpha_x, const T& alpha_y) {
    const auto below = h.z() <= T(0);
    if (all_of(below)) {
        // Microfacet normals face outward only.
        return T(0);
    }
    // The lanes below the horizon evaluate at h = z and are replaced by 0 below.
    const T hx2 = select(below, T(0), sqr(h.x()));
    const T hy2 = select(below, T(0), sqr(h.y()));
    const T hz2 = select(below, T(1), sqr(h.z()));
    const T D = D_beckmann_from_squares(hx2, hy2, hz2, alpha_x, alpha_y);
    // Branch of the mask: below the horizon, no microfacet.
    return select(below, T(0), D);
}

/// alpha(phi)^2 tan^2(theta) of a direction w above the horizon, the argument of both Smith
/// Lambdas: (alpha_x^2 w_x^2 + alpha_y^2 w_y^2) / w_z^2 [H14 sec. 5, eq. 80].
template <class T>
inline T smith_a2(const Vec3<T>& w, const T& alpha_x, const T& alpha_y) {
    return (sqr(alpha_x * w.x()) + sqr(alpha_y * w.y())) / sqr(w.z());
}

/// A value as numerator and denominator, so that a caller combining several can divide once.
template <class T>
struct Fraction {
    T num;
    T den;
};

/// Smith Lambda of GGX (below, lambda_ggx_from_a2) of a direction with w_z = z > 0, from
/// t = alpha_x^2 w_x^2 + alpha_y^2 w_y^2 (so a2 = t / z^2), as a fraction:
///   Lambda = t / (2 z (z + sqrt(z^2 + t))),
/// the same value as a2 / (2 (1 + sqrt(1 + a2))) multiplied through by z^2; lambda_ggx_from_a2
/// is this with z = 1. No cancellation; den > 0 for z > 0.
template <class T>
inline Fraction<T> lambda_ggx_fraction(const T& t, const T& z) {
    using std::sqrt;
    return {t, T(2) * z * (z + sqrt(z * z + t))};
}

/// Smith Lambda of GGX from a2 = alpha(phi)^2 tan^2(theta) >= 0:
///   Lambda = (sqrt(1 + a2) - 1) / 2   [W07 eq. 34], [H14 sec. 5.2],
/// evaluated as a2 / (2 (1 + sqrt(1 + a2))), which has no cancellation for small a2. Output in
/// [0, inf); 0 at a2 = 0 (w = z). No degenerate case for finite a2 >= 0.
template <class T>
inline T lambda_ggx_from_a2(const T& a2) {
    const Fraction<T> l = lambda_ggx_fraction(a2, T(1));
    return l.num / l.den;
}

/// Smith Lambda of GGX of a unit direction w (see lambda_ggx_from_a2). Edge behaviour: 0 at
/// w = z; +infinity for w_z <= 0 (the direction is fully masked; callers reject such directions
/// before evaluating).
template <class T>
inline T lambda_ggx(const Vec3<T>& w, const T& alpha_x, const T& alpha_y) {
    const auto below = w.z() <= T(0);
    const T inf(std::numeric_limits<double>::infinity());
    if (all_of(below)) {
        // At or below the horizon: masked.
        return inf;
    }
    const T a2 = smith_a2(w, alpha_x, alpha_y);
    // Branch of the mask: at or below the horizon, masked (the lane's a2 is not used).
    return select(below, inf, lambda_ggx_from_a2(select(below, T(0), a2)));
}

/// Smith Lambda of Beckmann, exact (with the complementary error function), from a2 =
/// alpha(phi)^2 tan^2(theta) >= 0:
///   Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)),  a = 1 / sqrt(a2)   [W07 sec. 5.1],
///   [H14 sec. 5.1];
/// evaluated as (exp(-a^2)/(a sqrt(pi)) - erfc(a)) / 2 to avoid erf(a) - 1 losing digits.
/// Output in [0, inf). Edge behaviour: 0 at a2 = 0 (w = z, a infinite); for a > 26 (a2 < 1/676)
/// the value is below 1e-300 and returned as 0.
template <class T>
inline T lambda_beckmann_from_a2(const T& a2) {
    using std::erfc;
    using std::exp;
    using std::sqrt;
    // a > 26, including a2 = 0 along the normal.
    const auto negligible = a2 <= T(1.0 / 676.0);
    if (all_of(negligible)) {
        // exp(-a^2) underflows; Lambda ~ exp(-a^2)/(4 a^3 sqrt(pi)) < 1e-300 (0 along the normal).
        return T(0);
    }
    // The negligible lanes evaluate at a = 1 and are replaced by 0 below.
    const T a = T(1) / sqrt(select(negligible, T(1), a2));
    const T lambda = (exp(-a * a) * T(kInvSqrtPi) / a - erfc(a)) / T(2);
    // Branch of the mask: tan(theta) = 0 or exp(-a^2) underflowing, Lambda = 0.
    return select(negligible, T(0), lambda);
}

/// Smith Lambda of Beckmann of a unit direction w (see lambda_beckmann_from_a2). Edge
/// behaviour: 0 at w = z; +infinity for w_z <= 0.
template <class T>
inline T lambda_beckmann(const Vec3<T>& w, const T& alpha_x, const T& alpha_y) {
    const auto below = w.z() <= T(0);
    const T inf(std::numeric_limits<double>::infinity());
    if (all_of(below)) {
        // At or below the horizon: masked.
        return inf;
    }
    const T a2 = smith_a2(w, alpha_x, alpha_y);
    // Branch of the mask: at or below the horizon, masked (the lane's a2 is not used).
    return select(below, inf, lambda_beckmann_from_a2(select(below, T(0), a2)));
}

/// Smith masking function of one direction given Lambda(w):
///   G1(w, h) = chi+(w.h / w.z) / (1 + Lambda(w))   [H14 sec. 5, eq. 43 form].
/// chi+ removes microfacets seen from behind. Output in [0, 1].
template <class T>
inline T G1(const Vec3<T>& w, const Vec3<T>& h, const T& lambda) {
    const auto hidden = w.dot(h) * w.z() <= T(0);
    if (all_of(hidden)) {
        // Back-facing microfacet (or a direction at the horizon): invisible.
        return T(0);
    }
    // Branch of the mask: back-facing, invisible.
    return select(hidden, T(0), T(1) / (T(1) + lambda));
}

/// G_smith_correlated of two Lambdas given as fractions, with one division:
///   1 / (1 + n_i/d_i + n_o/d_o) = d_i d_o / (d_i d_o + n_i d_o + n_o d_i);
/// with d_i = d_o = 1 exactly 1 / (1 + Lambda_i + Lambda_o).
template <class T>
inline T G_smith_correlated(const Fraction<T>& lambda_i, const Fraction<T>& lambda_o) {
    const T dd = lambda_i.den * lambda_o.den;
    return dd / (dd + lambda_i.num * lambda_o.den + lambda_o.num * lambda_i.den);
}

/// Height-correlated Smith shadowing-masking  G2 = 1 / (1 + Lambda(wi) + Lambda(wo))  [H14 sec.
/// 6.3]. The chi+ factors are 1 for a reflection half vector with both directions above the
/// horizon (wi.h = wo.h > 0); callers check the horizon. Output in [0, 1].
template <class T>
inline T G_smith_correlated(const T& lambda_i, const T& lambda_o) {
    return G_smith_correlated(Fraction<T>{lambda_i, T(1)}, Fraction<T>{lambda_o, T(1)});
}

/// Separable (uncorrelated) Smith shadowing-masking  G2 = G1(wi) G1(wo) = 1 / ((1 + Lambda(wi))
/// (1 + Lambda(wo)))  [H14 sec. 6.1]; same horizon convention as G_smith_correlated. Output in
/// [0, 1], never above the correlated form.
template <class T>
inline T G_smith_separable(const Fraction<T>& lambda_i, const Fraction<T>& lambda_o) {
    // 1 / ((1 + n_i/d_i) (1 + n_o/d_o)) with one division; with d = 1 exactly the form below.
    return lambda_i.den * lambda_o.den /
           ((lambda_i.den + lambda_i.num) * (lambda_o.den + lambda_o.num));
}

template <class T>
inline T G_smith_separable(const T& lambda_i, const T& lambda_o) {
    return G_smith_separable(Fraction<T>{lambda_i, T(1)}, Fraction<T>{lambda_o, T(1)});
}

/// Cook-Torrance V-groove shadowing-masking from the cosines of the reflection configuration:
///   G = min(1, 2 (n.h)(n.wo) / (wo.h), 2 (n.h)(n.wi) / (wo.h))   [CT82 sec. 3],
/// cos_h = n.h, cos_i = n.wi, cos_o = n.wo, cos_d = wo.h = wi.h. Output in [0, 1]. Edge behaviour:
/// 0 when either direction is at the horizon; 0 when cos_d <= 0 (only for wi = -wo, where no half
/// vector exists).
template <class T>
inline T G_vgroove_from_cosines(const T& cos_h, const T& cos_i, const T& cos_o, const T& cos_d) {
    const auto no_half = cos_d <= T(0);
    if (all_of(no_half)) {
        // Degenerate half vector: no reflection configuration.
        return T(0);
    }
    const T inv_d = T(1) / select(no_half, T(1), cos_d);
    const T g_o = T(2) * cos_h * cos_o * inv_d;
    const T g_i = T(2) * cos_h * cos_i * inv_d;
    // Branch of the mask: degenerate half vector, G = 0.
    return select(no_half, T(0), clamp_to(min_of(g_o, g_i), T(0), T(1)));
}

/// Cook-Torrance V-groove shadowing-masking for the reflection half vector h (see
/// G_vgroove_from_cosines).
template <class T>
inline T G_vgroove(const Vec3<T>& wi, const Vec3<T>& wo, const Vec3<T>& h) {
    return G_vgroove_from_cosines(h.z(), wi.z(), wo.z(), T(wo.dot(h)));
}

}  // namespace gonio::brdf
