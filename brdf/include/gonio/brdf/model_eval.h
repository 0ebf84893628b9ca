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
#include "gonio/brdf/student_t.h"

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
        case Distribution::kStudentT:
            return D_student_t(h, lobe.alpha_x, lobe_alpha_y(lobe), lobe.gamma);
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
        case Distribution::kStudentT:
            return lambda_student_t(w, lobe.alpha_x, lobe_alpha_y(lobe), lobe.gamma);
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

/// The reflection geometry shared by every lobe: unit half vector h, cos_d = wi . h and
/// 1 - cos_d. For unit wi, wo: |wi + wo| = 2 cos_d and |wi - wo| = 2 sin_d, so
/// cos_d = |wi + wo| / 2 and 1 - cos_d = sin_d^2 / (1 + cos_d) = |wi - wo|^2 / (4 (1 + cos_d)),
/// which has no cancellation near the retro-reflection configuration (cos_d -> 1).
template <class T>
struct HalfGeometry {
    Vec3<T> h;
    T cos_d;
    T one_minus_cos_d;
};

/// Both directions above the horizon: wi + wo has z > 0, so it is never the zero vector.
template <class T>
inline HalfGeometry<T> half_geometry(const Vec3<T>& wi, const Vec3<T>& wo) {
    using std::sqrt;
    const Vec3<T> s = wi + wo;
    const T len = sqrt(s.squaredNorm());
    HalfGeometry<T> g;
    g.h = s / len;
    g.cos_d = min_of(len / T(2), T(1));
    g.one_minus_cos_d = (wi - wo).squaredNorm() / (T(4) * (T(1) + g.cos_d));
    return g;
}

/// One lobe given the half-vector geometry and cos_i = wi.z > 0, cos_o = wo.z > 0.
template <class T>
inline Rgb<T> eval_lobe_half(const Lobe<T>& lobe,
                             const Vec3<T>& wi,
                             const Vec3<T>& wo,
                             const HalfGeometry<T>& g,
                             const T& cos_i,
                             const T& cos_o) {
    const T D = lobe_D(lobe, g.h);
    if (D == T(0)) {
        // No microfacet with this normal: the lobe contributes exactly zero (and F, G are not
        // needed; this also skips them in the far tail of sharp lobes).
        return Rgb<T>::Zero();
    }
    const Rgb<T> F = eval_fresnel(lobe.fresnel, g.cos_d, g.one_minus_cos_d);
    const T G = lobe_G(lobe, wi, wo, g.h);
    return lobe.scale * F * (D * G / (T(4) * cos_i * cos_o));
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
    return detail::eval_lobe_half(lobe, wi, wo, detail::half_geometry(wi, wo), cos_i, cos_o);
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
    const detail::HalfGeometry<T> g = detail::half_geometry(wi, wo);
    for (const Lobe<T>& lobe : m.lobes) {
        f += detail::eval_lobe_half(lobe, wi, wo, g, cos_i, cos_o);
    }
    return f;
}

}  // namespace gonio::brdf
