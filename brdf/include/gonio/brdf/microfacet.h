#pragma once

// Microfacet normal distributions D and Smith masking functions Lambda, G1, G for the GGX
// (Trowbridge-Reitz) and Beckmann distributions, isotropic or anisotropic, plus the Cook-Torrance
// V-groove term. Conventions: z is the macro-surface normal, h the microfacet normal (unit),
// w a unit direction; alpha_x, alpha_y > 0 are the slope parameters along x and y (alpha itself,
// not a perceptual roughness). D is in 1/sr and normalised over projected area:
// integral over the hemisphere of D(h) cos(theta_h) dh = 1.
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

/// GGX (Trowbridge-Reitz) distribution, anisotropic form written with the Cartesian components of
/// h:  D(h) = 1 / (pi alpha_x alpha_y (h_x^2/alpha_x^2 + h_y^2/alpha_y^2 + h_z^2)^2)  [TR75], [W07
/// eq. 33], [H14 sec. 5.2]; equal to the usual form with cos^4(theta_h) (1 + tan^2 theta_h (...))^2
/// but without trigonometry. Edge behaviour: 0 for h_z <= 0; at h = z the value is
/// 1/(pi alpha_x alpha_y) (3.2e7 at alpha = 1e-4, no overflow).
template <class T>
inline T D_ggx(const Vec3<T>& h, const T& alpha_x, const T& alpha_y) {
    if (h.z() <= T(0)) {
        // Microfacet normals face outward only.
        return T(0);
    }
    const T s = sqr(h.x() / alpha_x) + sqr(h.y() / alpha_y) + sqr(h.z());
    return T(1) / (T(kPi) * alpha_x * alpha_y * s * s);
}

/// Beckmann distribution  D(h) = exp(-(h_x^2/alpha_x^2 + h_y^2/alpha_y^2) / h_z^2) /
/// (pi alpha_x alpha_y h_z^4)  [W07 eq. 25], [H14 sec. 5.1]. Edge behaviour: 0 for h_z <= 0; when
/// the exponent's argument exceeds 700 the value is below 1e-300 and returned as exactly 0 (this
/// avoids 0/0 when h_z^4 underflows near the horizon).
template <class T>
inline T D_beckmann(const Vec3<T>& h, const T& alpha_x, const T& alpha_y) {
    using std::exp;
    if (h.z() <= T(0)) {
        // Microfacet normals face outward only.
        return T(0);
    }
    const T cos2 = sqr(h.z());
    const T e = (sqr(h.x() / alpha_x) + sqr(h.y() / alpha_y)) / cos2;
    if (e > T(700)) {
        // Far tail: exp(-e) underflows; the exact value is < 1e-300 for every alpha in use.
        return T(0);
    }
    return exp(-e) / (T(kPi) * alpha_x * alpha_y * cos2 * cos2);
}

/// Smith Lambda of GGX:  Lambda(w) = (sqrt(1 + a2) - 1) / 2,  a2 = (alpha_x^2 w_x^2 + alpha_y^2
/// w_y^2) / w_z^2 = alpha(phi)^2 tan^2(theta)  [W07 eq. 34], [H14 sec. 5.2]; evaluated as
/// a2 / (2 (1 + sqrt(1 + a2))) which has no cancellation for small a2. Output in [0, inf).
/// Edge behaviour: 0 at w = z; +infinity for w_z <= 0 (the direction is fully masked; callers
/// reject such directions before evaluating).
template <class T>
inline T lambda_ggx(const Vec3<T>& w, const T& alpha_x, const T& alpha_y) {
    using std::sqrt;
    if (w.z() <= T(0)) {
        // At or below the horizon: masked.
        return T(std::numeric_limits<double>::infinity());
    }
    const T a2 = (sqr(alpha_x * w.x()) + sqr(alpha_y * w.y())) / sqr(w.z());
    return a2 / (T(2) * (T(1) + sqrt(T(1) + a2)));
}

/// Smith Lambda of Beckmann, exact (with the error function):
///   Lambda(w) = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)),  a = w_z / sqrt(alpha_x^2 w_x^2 +
///   alpha_y^2 w_y^2) = 1 / (alpha(phi) tan(theta))   [W07 sec. 5.1], [H14 sec. 5.1];
/// evaluated as (exp(-a^2)/(a sqrt(pi)) - erfc(a)) / 2 to avoid erf(a) - 1 losing digits.
/// Output in [0, inf). Edge behaviour: 0 at w = z (a infinite); +infinity for w_z <= 0.
/// For a > 26 the value is below 1e-300 and returned as 0.
template <class T>
inline T lambda_beckmann(const Vec3<T>& w, const T& alpha_x, const T& alpha_y) {
    using std::erfc;
    using std::exp;
    using std::sqrt;
    if (w.z() <= T(0)) {
        // At or below the horizon: masked.
        return T(std::numeric_limits<double>::infinity());
    }
    const T s2 = sqr(alpha_x * w.x()) + sqr(alpha_y * w.y());
    if (s2 <= T(0)) {
        // Along the normal: tan(theta) = 0, nothing is masked.
        return T(0);
    }
    const T a = w.z() / sqrt(s2);
    if (a > T(26)) {
        // exp(-a^2) underflows; Lambda ~ exp(-a^2)/(4 a^3 sqrt(pi)) < 1e-300.
        return T(0);
    }
    constexpr double kInvSqrtPi = 0.56418958354775628695;
    return (exp(-a * a) * T(kInvSqrtPi) / a - erfc(a)) / T(2);
}

/// Smith masking function of one direction given Lambda(w):
///   G1(w, h) = chi+(w.h / w.z) / (1 + Lambda(w))   [H14 sec. 5, eq. 43 form].
/// chi+ removes microfacets seen from behind. Output in [0, 1].
template <class T>
inline T G1(const Vec3<T>& w, const Vec3<T>& h, const T& lambda) {
    if (w.dot(h) * w.z() <= T(0)) {
        // Back-facing microfacet (or a direction at the horizon): invisible.
        return T(0);
    }
    return T(1) / (T(1) + lambda);
}

/// Height-correlated Smith shadowing-masking  G2 = 1 / (1 + Lambda(wi) + Lambda(wo))  [H14 sec.
/// 6.3]. The chi+ factors are 1 for a reflection half vector with both directions above the
/// horizon (wi.h = wo.h > 0); callers check the horizon. Output in [0, 1].
template <class T>
inline T G_smith_correlated(const T& lambda_i, const T& lambda_o) {
    return T(1) / (T(1) + lambda_i + lambda_o);
}

/// Separable (uncorrelated) Smith shadowing-masking  G2 = G1(wi) G1(wo) = 1 / ((1 + Lambda(wi))
/// (1 + Lambda(wo)))  [H14 sec. 6.1]; same horizon convention as G_smith_correlated. Output in
/// [0, 1], never above the correlated form.
template <class T>
inline T G_smith_separable(const T& lambda_i, const T& lambda_o) {
    return T(1) / ((T(1) + lambda_i) * (T(1) + lambda_o));
}

/// Cook-Torrance V-groove shadowing-masking
///   G = min(1, 2 (n.h)(n.wo) / (wo.h), 2 (n.h)(n.wi) / (wo.h))   [CT82 sec. 3],
/// for the reflection half vector h (wo.h = wi.h). Output in [0, 1]. Edge behaviour: 0 when either
/// direction is at the horizon; 0 when wo.h <= 0 (only for wi = -wo, where no half vector exists).
template <class T>
inline T G_vgroove(const Vec3<T>& wi, const Vec3<T>& wo, const Vec3<T>& h) {
    const T cos_d = wo.dot(h);
    if (cos_d <= T(0)) {
        // Degenerate half vector: no reflection configuration.
        return T(0);
    }
    const T g_o = T(2) * h.z() * wo.z() / cos_d;
    const T g_i = T(2) * h.z() * wi.z() / cos_d;
    return clamp_to(min_of(g_o, g_i), T(0), T(1));
}

}  // namespace gonio::brdf
