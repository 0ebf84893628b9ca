#pragma once

// Fresnel reflectance F: the fraction of light a perfectly smooth interface reflects, as a function
// of the cosine between the incident direction and the (micro)surface normal. In a microfacet lobe
// the cosine is wi . h.

#include "gonio/brdf/math.h"
#include "gonio/brdf/model.h"

namespace gonio::brdf {

/// Schlick's approximation from its factor x5 = (1 - cos(theta))^5 in [0, 1]: F = f0 + (1 - f0) x5
/// (the body shared by the forms below and by callers that precompute x5 for many f0).
template <class T, class F0>
inline F0 fresnel_schlick_from_pow5(const T& x5, const F0& f0) {
    return f0 + (T(1) - f0) * x5;
}

/// Schlick's approximation F = f0 + (1 - f0) (1 - cos)^5.
/// Source: C. Schlick, "An Inexpensive BRDF Model for Physically-based Rendering", Computer
/// Graphics Forum 13(3), 1994, eq. 24.
/// Inputs: cos_theta in [0, 1] (values outside are clamped: a negative cosine is grazing, F = 1;
/// above 1 is rounding noise); f0 in [0, 1] the reflectance at normal incidence. Output in
/// [f0, 1], dimensionless. Absolute error against the exact dielectric (f0 = ((eta-1)/(eta+1))^2):
/// below 0.025 up to 60 degrees and below 0.07 over all angles for eta in [1.3, 1.8] (largest
/// between 60 and 85 degrees; both tend to 1 at grazing incidence).
template <class T, class F0>
inline F0 fresnel_schlick(const T& cos_theta, const F0& f0) {
    return fresnel_schlick_from_pow5(pow5(T(1) - clamp_to(cos_theta, T(0), T(1))), f0);
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface, the mean of the s and p
/// reflectances r_s = (cos_i - eta cos_t)/(cos_i + eta cos_t), r_p = (eta cos_i - cos_t)/(eta
/// cos_i + cos_t), F = (r_s^2 + r_p^2)/2, with Snell's law sin_t = sin_i / eta.
/// Source: M. Born, E. Wolf, "Principles of Optics", 7th ed., 1999, sec. 1.5.2, eqs. 21a and 21b.
/// Inputs: cos_i in [-1, 1], cosine of the incident direction with the normal on the side the
/// light comes from; eta > 0, the index of the far side relative to the incident side. A
/// negative cos_i means the light arrives from the far side: the interface is seen with 1/eta.
/// Output in [0, 1]. Edge behaviour: total internal reflection (sin_t >= 1, only when eta < 1)
/// gives exactly 1; grazing incidence (cos_i = 0) gives 1; eta = 1 gives 0.
template <class T>
inline T fresnel_dielectric(T cos_i, T eta) {
    // Branch of the mask: light from the far side, the media swap (1/eta, -cos_i).
    const auto far_side = cos_i < T(0);
    eta = select(far_side, T(1) / eta, eta);
    cos_i = select(far_side, -cos_i, cos_i);
    cos_i = min_of(cos_i, T(1));
    const T sin2_i = T(1) - cos_i * cos_i;
    const T sin2_t = sin2_i / (eta * eta);
    const auto tir = !(sin2_t < T(1));
    if (all_of(tir)) {
        // Total internal reflection: no transmitted wave.
        return T(1);
    }
    const T cos_t = safe_sqrt(T(1) - sin2_t);
    // Both denominators are > 0 outside total internal reflection: cos_i = 0 implies
    // sin2_t = 1/eta^2 < 1, so cos_t > 0.
    const T r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    const T r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    // Branch of the mask: total internal reflection, F = 1.
    return select(tir, T(1), (r_s * r_s + r_p * r_p) / T(2));
}

/// Exact unpolarised Fresnel reflectance of a conductor with complex index n = eta + i k seen
/// from a non-absorbing medium of index 1. With w = n cos_t = sqrt(n^2 - sin_i^2) = u + i v
/// (principal root, v >= 0) the Fresnel amplitudes are r_s = (cos_i - w)/(cos_i + w) and r_p =
/// (n^2 cos_i - w)/(n^2 cos_i + w); F = (|r_s|^2 + |r_p|^2)/2.
/// Source: M. Born, E. Wolf, "Principles of Optics", 7th ed., 1999, sec. 14.2 (the Fresnel formulae
/// of sec. 1.5.2 with the complex index of eq. 14.2(15)).
/// Inputs: cos_i in [0, 1] (clamped), eta > 0, k >= 0. Output in [0, 1]. Edge behaviour: k = 0
/// reduces exactly to fresnel_dielectric (including total internal reflection when eta < 1);
/// grazing incidence gives 1. Where a square root's argument is exactly zero the Jet derivative
/// is taken as zero instead of infinite (safe_sqrt).
template <class T>
inline T fresnel_conductor(T cos_i, const T& eta, const T& k) {
    cos_i = clamp_to(cos_i, T(0), T(1));
    const T sin2_i = T(1) - cos_i * cos_i;
    // n^2 = a + i b.
    const T a = eta * eta - k * k;
    const T b = T(2) * eta * k;
    // z = n^2 - sin^2 = re + i b; w = sqrt(z) = u + i v.
    const T re = a - sin2_i;
    const T abs_z = safe_sqrt(re * re + b * b);
    const T u = safe_sqrt((abs_z + re) / T(2));
    const T v = safe_sqrt((abs_z - re) / T(2));
    const T rs_num = sqr(cos_i - u) + v * v;
    const T rs_den = sqr(cos_i + u) + v * v;
    const T rp_num = sqr(a * cos_i - u) + sqr(b * cos_i - v);
    const T rp_den = sqr(a * cos_i + u) + sqr(b * cos_i + v);
    const auto degenerate = mask_or(rs_den <= T(0), rp_den <= T(0));
    if (all_of(degenerate)) {
        // Only at grazing incidence onto n^2 = 1 (eta = 1, k = 0, cos_i = 0): the limit is 1.
        return T(1);
    }
    // The degenerate lanes divide by 1 and are replaced by the limit 1 below.
    const T F =
        (rs_num / select(degenerate, T(1), rs_den) + rp_num / select(degenerate, T(1), rp_den)) /
        T(2);
    // Branch of the mask: grazing incidence onto n^2 = 1, F = 1.
    return select(degenerate, T(1), F);
}

/// Schlick's approximation given 1 - cos(theta) directly (in [0, 1]): callers that can compute
/// it without cancellation (eval_model does, from |wi - wo|) keep full relative precision of the
/// (1 - cos)^5 term near normal incidence, where 1 - cos computed from cos would lose digits.
template <class T, class F0>
inline F0 fresnel_schlick_from_one_minus_cos(const T& one_minus_cos, const F0& f0) {
    return fresnel_schlick_from_pow5(pow5(clamp_to(one_minus_cos, T(0), T(1))), f0);
}

/// The Fresnel term of a lobe per RGB channel at cos_theta = wi . h (in [0, 1]), with
/// one_minus_cos = 1 - cos_theta computed by the caller (see fresnel_schlick_from_one_minus_cos).
template <class T>
inline Rgb<T> eval_fresnel(const Fresnel<T>& f, const T& cos_theta, const T& one_minus_cos) {
    switch (f.type) {
        case FresnelType::kSchlick:
            return fresnel_schlick_from_one_minus_cos(one_minus_cos, f.f0);
        case FresnelType::kDielectric:
            return Rgb<T>::Constant(fresnel_dielectric(cos_theta, f.eta));
        case FresnelType::kConductor:
            return Rgb<T>(fresnel_conductor(cos_theta, f.eta_rgb[0], f.k[0]),
                          fresnel_conductor(cos_theta, f.eta_rgb[1], f.k[1]),
                          fresnel_conductor(cos_theta, f.eta_rgb[2], f.k[2]));
        case FresnelType::kNone:
            break;
    }
    return Rgb<T>::Constant(T(1));
}

/// The Fresnel term of a lobe per RGB channel at cos_theta = wi . h (in [0, 1]).
template <class T>
inline Rgb<T> eval_fresnel(const Fresnel<T>& f, const T& cos_theta) {
    return eval_fresnel(f, cos_theta, T(1) - cos_theta);
}

}  // namespace gonio::brdf
