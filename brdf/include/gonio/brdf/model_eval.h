#pragma once

// Evaluation of the analytic model of model.h:
//
//   f(wi, wo) = diffuse / pi + sum over lobes of scale * F(wi . h) * D(h) * G(wi, wo) /
//               (4 cos_i cos_o),   h = (wi + wo) / |wi + wo|,
//
// zero when either direction is at or below the horizon; RGB, 1/sr. The microfacet form is that
// of R. L. Cook, K. E. Torrance, "A Reflectance Model for Computer Graphics", ACM TOG 1(1), 1982,
// with the 4 cos_i cos_o denominator of B. Walter et al., EGSR 2007, eq. 20.
//
// Everything is templated on the scalar (double, long double, ceres::Jet) and allocates nothing.
// wi and wo are unit vectors in the local frame (z = normal), wi toward the light, wo toward the
// camera. Blinn-Phong lobes use D = (e + 2)/(2 pi) cos^e(theta_h) (normalised over projected
// area, blinn_phong.h) in the same microfacet form, so they compare directly with GGX and
// Beckmann lobes; their Smith Lambda is Beckmann's with alpha = sqrt(2/(e + 2)).

#include <cmath>

#include "gonio/brdf/blinn_phong.h"
#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/lambert.h"
#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/model.h"

namespace gonio::brdf {

/// Slope parameter along y actually in use (alpha_x for an isotropic lobe).
template <class T>
inline const T& lobe_alpha_y(const Lobe<T>& lobe) {
    return lobe.anisotropic ? lobe.alpha_y : lobe.alpha_x;
}

/// The lobe's normal distribution D(h), 1/sr, normalised over projected area.
template <class T>
inline T lobe_D(const Lobe<T>& lobe, const Vec3<T>& h) {
    switch (lobe.distribution) {
        case Distribution::kGgx:
            return D_ggx(h, lobe.alpha_x, lobe_alpha_y(lobe));
        case Distribution::kBeckmann:
            return D_beckmann(h, lobe.alpha_x, lobe_alpha_y(lobe));
        case Distribution::kBlinnPhong:
            return D_blinn_phong(h, lobe.exponent);
    }
    return T(0);
}

/// The Smith Lambda(w) of the lobe's distribution (w above the horizon).
template <class T>
inline T lobe_lambda(const Lobe<T>& lobe, const Vec3<T>& w) {
    switch (lobe.distribution) {
        case Distribution::kGgx:
            return lambda_ggx(w, lobe.alpha_x, lobe_alpha_y(lobe));
        case Distribution::kBeckmann:
            return lambda_beckmann(w, lobe.alpha_x, lobe_alpha_y(lobe));
        case Distribution::kBlinnPhong: {
            const T alpha = blinn_phong_equivalent_alpha(lobe.exponent);
            return lambda_beckmann(w, alpha, alpha);
        }
    }
    return T(0);
}

/// The lobe's shadowing-masking G(wi, wo) for the reflection half vector h; both directions above
/// the horizon.
template <class T>
inline T lobe_G(const Lobe<T>& lobe, const Vec3<T>& wi, const Vec3<T>& wo, const Vec3<T>& h) {
    switch (lobe.shadowing) {
        case Shadowing::kSmithCorrelated:
            return G_smith_correlated(lobe_lambda(lobe, wi), lobe_lambda(lobe, wo));
        case Shadowing::kSmithSeparable:
            return G_smith_separable(lobe_lambda(lobe, wi), lobe_lambda(lobe, wo));
        case Shadowing::kVGroove:
            return G_vgroove(wi, wo, h);
        case Shadowing::kNone:
            break;
    }
    return T(1);
}

namespace detail {

/// One lobe given the unit half vector and cos_i = wi.z > 0, cos_o = wo.z > 0.
template <class T>
inline Rgb<T> eval_lobe_half(const Lobe<T>& lobe,
                             const Vec3<T>& wi,
                             const Vec3<T>& wo,
                             const Vec3<T>& h,
                             const T& cos_i,
                             const T& cos_o) {
    const T D = lobe_D(lobe, h);
    if (D == T(0)) {
        // No microfacet with this normal: the lobe contributes exactly zero (and F, G are not
        // needed; this also skips them in the far tail of sharp lobes).
        return Rgb<T>::Zero();
    }
    const T cos_d = wi.dot(h);
    const Rgb<T> F = eval_fresnel(lobe.fresnel, cos_d);
    const T G = lobe_G(lobe, wi, wo, h);
    return lobe.scale * F * (D * G / (T(4) * cos_i * cos_o));
}

/// The unit half vector of two directions above the horizon (wi + wo has z > 0, so it is never
/// the zero vector).
template <class T>
inline Vec3<T> half_vector(const Vec3<T>& wi, const Vec3<T>& wo) {
    using std::sqrt;
    const Vec3<T> s = wi + wo;
    return s / sqrt(s.squaredNorm());
}

}  // namespace detail

/// One microfacet (or Blinn-Phong) lobe: scale * F(wi.h) * D(h) * G / (4 cos_i cos_o), RGB in
/// 1/sr. Zero when either direction is at or below the horizon (wi.z <= 0 or wo.z <= 0).
template <class T>
inline Rgb<T> eval_lobe(const Lobe<T>& lobe, const Vec3<T>& wi, const Vec3<T>& wo) {
    const T cos_i = wi.z();
    const T cos_o = wo.z();
    if (cos_i <= T(0) || cos_o <= T(0)) {
        // At or below the horizon: no reflection (also keeps 1/(cos_i cos_o) finite).
        return Rgb<T>::Zero();
    }
    return detail::eval_lobe_half(lobe, wi, wo, detail::half_vector(wi, wo), cos_i, cos_o);
}

/// The whole model: diffuse / pi (when present) plus every lobe; RGB in 1/sr, zero when either
/// direction is at or below the horizon. No allocation.
template <class T>
inline Rgb<T> eval_model(const Model<T>& m, const Vec3<T>& wi, const Vec3<T>& wo) {
    const T cos_i = wi.z();
    const T cos_o = wo.z();
    if (cos_i <= T(0) || cos_o <= T(0)) {
        // At or below the horizon: no reflection.
        return Rgb<T>::Zero();
    }
    Rgb<T> f = m.has_diffuse ? Rgb<T>(m.diffuse * T(kInvPi)) : Rgb<T>(Rgb<T>::Zero());
    if (m.lobes.empty()) {
        return f;
    }
    const Vec3<T> h = detail::half_vector(wi, wo);
    for (const Lobe<T>& lobe : m.lobes) {
        f += detail::eval_lobe_half(lobe, wi, wo, h, cos_i, cos_o);
    }
    return f;
}

}  // namespace gonio::brdf
