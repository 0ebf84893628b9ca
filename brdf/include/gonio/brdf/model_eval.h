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
// Everything is templated on the numeric type and allocates nothing. One body, eval_model_lanes,
// serves every type: T is the lane type (double, ceres::Jet or an xsimd::batch of directions) and
// P the model's parameter type (double for double and packets, the Jet for Jets); a packet
// evaluates several directions against one model. The per-lobe choices (distribution, shadowing,
// Fresnel) are the model's structure, the same for every lane; only the horizon and the
// degenerate cases of the formulas are masks.
// wi and wo are unit vectors in the local frame (z = normal), wi toward the light, wo toward the
// camera. Blinn-Phong lobes use D = (e + 2)/(2 pi) cos^e(theta_h) (normalised over projected
// area, blinn_phong.h) in the same microfacet form, so they compare directly with GGX and
// Beckmann lobes; their Smith Lambda is Beckmann's with alpha = sqrt(2/(e + 2)).
// A lobe with RGB-varying roughness (Lobe::rgb_roughness) evaluates D and G of channel c with
// alpha = alpha_rgb[c]: f_c = scale_c F_c D(h; a_c) G(wi, wo; a_c) / (4 cos_i cos_o).
// An anisotropic lobe evaluates D and G at the lobe-frame components of h, wi and wo, the
// sample's frame turned by Lobe::orientation_deg about the normal (lobe_orientation.h); F, the
// cosines and the V-groove G do not depend on the turn.

#include <cmath>

#include "gonio/base/check.h"
#include "gonio/brdf/blinn_phong.h"
#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/lambert.h"
#include "gonio/brdf/lobe_orientation.h"
#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/student_t.h"
#include "gonio/brdf/tabulated_ndf.h"

namespace gonio::brdf {

/// Slope parameter along y actually in use (alpha_x for an isotropic lobe).
template <class T>
inline const T& lobe_alpha_y(const Lobe<T>& lobe) {
    return lobe.anisotropic ? lobe.alpha_y : lobe.alpha_x;
}

/// A direction's components as lanes (double, Jet or packet), without Eigen.
template <class T>
struct Dir3 {
    T x, y, z;
};

/// The reflection geometry shared by every lobe, per lane: the unit half vector h, cos_d = wi . h
/// and 1 - cos_d. For unit wi, wo: |wi + wo| = 2 cos_d and |wi - wo| = 2 sin_d, so
/// cos_d = |wi + wo| / 2 and 1 - cos_d = sin_d^2 / (1 + cos_d) = |wi - wo|^2 / (4 (1 + cos_d)),
/// which has no cancellation near the retro-reflection configuration (cos_d -> 1).
template <class T>
struct HalfGeometry {
    Dir3<T> h;
    T cos_d;
    T one_minus_cos_d;
};

/// A direction's components in the frame of a lobe turned by the rotation r about the normal
/// (lobe_orientation.h): z is kept.
template <class T, class P>
inline Dir3<T> in_lobe_frame(const Dir3<T>& w, const LobeRotation<P>& r) {
    Dir3<T> out{w.x, w.y, w.z};
    to_lobe_frame(w.x, w.y, r, out.x, out.y);
    return out;
}

/// Half geometry of directions with wi + wo != 0 (both above the horizon gives (wi + wo).z > 0).
template <class T>
inline HalfGeometry<T> half_geometry(const Dir3<T>& wi, const Dir3<T>& wo) {
    using std::sqrt;
    const T sx = wi.x + wo.x;
    const T sy = wi.y + wo.y;
    const T sz = wi.z + wo.z;
    const T len = sqrt(sx * sx + sy * sy + sz * sz);
    const T inv_len = T(1) / len;
    HalfGeometry<T> g;
    g.h = {sx * inv_len, sy * inv_len, sz * inv_len};
    g.cos_d = min_of(len * T(0.5), T(1));
    g.one_minus_cos_d =
        (sqr(wi.x - wo.x) + sqr(wi.y - wo.y) + sqr(wi.z - wo.z)) / (T(4) * (T(1) + g.cos_d));
    return g;
}

/// The lobe's normal distribution D(h), 1/sr, normalised over projected area; h_z > 0; with
/// the slope parameters (ax, ay) given by the caller (one channel's alpha of an RGB-roughness
/// lobe) for the analytic distributions.
template <class T, class P>
inline T lobe_D_alpha(const Lobe<P>& lobe, const Dir3<T>& h, const P& ax, const P& ay) {
    switch (lobe.distribution) {
        case Distribution::kGgx:
            return D_ggx_from_squares(sqr(h.x), sqr(h.y), sqr(h.z), T(ax), T(ay));
        case Distribution::kBeckmann:
            return D_beckmann_from_squares(sqr(h.x), sqr(h.y), sqr(h.z), T(ax), T(ay));
        case Distribution::kBlinnPhong:
            return D_blinn_phong(Vec3<T>(h.x, h.y, h.z), T(lobe.exponent));
        case Distribution::kStudentT:
            if constexpr (IsPacket<T>::value) {
                // Not reached: eval_model_packets evaluates a model with a Student-t lobe lane by
                // lane (its Lambda's continued fraction iterates a data-dependent number of times).
                GONIO_CHECK_MSG(false, "Student-t lobe evaluated on packets");
                return T(0);
            } else {
                return D_student_t(Vec3<T>(h.x, h.y, h.z), T(ax), T(ay), T(lobe.gamma));
            }
        case Distribution::kTabulated:
            if constexpr (IsPacket<T>::value) {
                // Not reached: eval_model_packets evaluates a model with a tabulated lobe lane by
                // lane (the table is looked up at each lane's value).
                GONIO_CHECK_MSG(false, "tabulated lobe evaluated on packets");
                return T(0);
            } else {
                GONIO_CHECK_MSG(lobe.table != nullptr, "tabulated lobe without its table");
                return D_tabulated(*lobe.table, h.z);
            }
    }
    return T(0);
}

/// The lobe's normal distribution D(h) with its own slope parameters; h_z > 0.
template <class T, class P>
inline T lobe_D(const Lobe<P>& lobe, const Dir3<T>& h) {
    return lobe_D_alpha(lobe, h, lobe.alpha_x, lobe_alpha_y(lobe));
}

/// The lobe's normal distribution D(h) of a unit h given in the sample's frame, 1/sr; 0 for
/// h_z <= 0. An anisotropic lobe is evaluated in its own frame (Lobe::orientation_deg).
template <class T>
inline T lobe_D(const Lobe<T>& lobe, const Vec3<T>& h) {
    const auto below = h.z() <= T(0);
    if (all_of(below)) {
        // Microfacet normals face outward only.
        return T(0);
    }
    // Branch of the mask: below the horizon, no microfacet (evaluated at h = z, replaced by 0).
    Dir3<T> hs{select(below, T(0), T(h.x())),
               select(below, T(0), T(h.y())),
               select(below, T(1), T(h.z()))};
    if (lobe.anisotropic) {
        hs = in_lobe_frame(hs, lobe_rotation_deg(lobe.orientation_deg));
    }
    return select(below, T(0), lobe_D(lobe, hs));
}

/// The Smith Lambda of the lobe's distribution from a2 = alpha(phi)^2 tan^2(theta) with the
/// slope parameters (ax, ay) (a Blinn-Phong lobe uses Beckmann's with alpha = sqrt(2/(e + 2))).
template <class T, class P>
inline T lobe_lambda_alpha(const Lobe<P>& lobe, const Dir3<T>& w, const P& ax, const P& ay) {
    const T w_z2 = sqr(w.z);
    switch (lobe.distribution) {
        case Distribution::kGgx: {
            const Fraction<T> l = lambda_ggx_fraction(sqr(T(ax) * w.x) + sqr(T(ay) * w.y), w.z);
            return l.num / l.den;
        }
        case Distribution::kBeckmann: {
            const T a2 = (sqr(T(ax) * w.x) + sqr(T(ay) * w.y)) / w_z2;
            return lambda_beckmann_from_a2(a2);
        }
        case Distribution::kBlinnPhong: {
            const T alpha = blinn_phong_equivalent_alpha(T(lobe.exponent));
            return lambda_beckmann_from_a2(sqr(alpha) * (sqr(w.x) + sqr(w.y)) / w_z2);
        }
        case Distribution::kStudentT: {
            if constexpr (IsPacket<T>::value) {
                // Not reached: see lobe_D.
                GONIO_CHECK_MSG(false, "Student-t lobe evaluated on packets");
                return T(0);
            } else {
                const T a2 = (sqr(T(ax) * w.x) + sqr(T(ay) * w.y)) / w_z2;
                return lambda_student_t_a2(a2, T(lobe.gamma));
            }
        }
        case Distribution::kTabulated: {
            if constexpr (IsPacket<T>::value) {
                // Not reached: see lobe_D.
                GONIO_CHECK_MSG(false, "tabulated lobe evaluated on packets");
                return T(0);
            } else {
                GONIO_CHECK_MSG(lobe.table != nullptr, "tabulated lobe without its table");
                return lambda_tabulated(*lobe.table, w.z);
            }
        }
    }
    return T(0);
}

/// The Smith Lambda of the lobe's distribution from a2 = alpha(phi)^2 tan^2(theta) with the
/// slope parameters (ax, ay) (a Blinn-Phong lobe uses Beckmann's with alpha = sqrt(2/(e + 2))),
/// as a fraction: GGX's is t / (2 w_z (w_z + sqrt(w_z^2 + t))) (lambda_ggx_fraction), the
/// others' the value over 1, so that G divides once for both Lambdas.
template <class T, class P>
inline Fraction<T> lobe_lambda_fraction_alpha(const Lobe<P>& lobe,
                                              const Dir3<T>& w,
                                              const P& ax,
                                              const P& ay) {
    if (lobe.distribution == Distribution::kGgx) {
        return lambda_ggx_fraction(sqr(T(ax) * w.x) + sqr(T(ay) * w.y), w.z);
    }
    return {lobe_lambda_alpha(lobe, w, ax, ay), T(1)};
}

/// The Smith Lambda with the lobe's own slope parameters.
template <class T, class P>
inline T lobe_lambda(const Lobe<P>& lobe, const Dir3<T>& w) {
    return lobe_lambda_alpha(lobe, w, lobe.alpha_x, lobe_alpha_y(lobe));
}

/// The lobe's shadowing-masking G(wi, wo) for the reflection half geometry g and the slope
/// parameters (ax, ay); both directions above the horizon.
template <class T, class P>
inline T lobe_G_alpha(const Lobe<P>& lobe,
                      const Dir3<T>& wi,
                      const Dir3<T>& wo,
                      const HalfGeometry<T>& g,
                      const P& ax,
                      const P& ay) {
    switch (lobe.shadowing) {
        case Shadowing::kSmithCorrelated:
            return G_smith_correlated(lobe_lambda_fraction_alpha(lobe, wi, ax, ay),
                                      lobe_lambda_fraction_alpha(lobe, wo, ax, ay));
        case Shadowing::kSmithSeparable:
            return G_smith_separable(lobe_lambda_fraction_alpha(lobe, wi, ax, ay),
                                     lobe_lambda_fraction_alpha(lobe, wo, ax, ay));
        case Shadowing::kVGroove:
            return G_vgroove_from_cosines(g.h.z, wi.z, wo.z, g.cos_d);
        case Shadowing::kNone:
            break;
    }
    return T(1);
}

/// The lobe's shadowing-masking G(wi, wo) with its own slope parameters.
template <class T, class P>
inline T lobe_G(const Lobe<P>& lobe,
                const Dir3<T>& wi,
                const Dir3<T>& wo,
                const HalfGeometry<T>& g) {
    return lobe_G_alpha(lobe, wi, wo, g, lobe.alpha_x, lobe_alpha_y(lobe));
}

/// D G of a tabulated lobe (the lobe term without F, scale and 1 / (4 cos_i cos_o)) from the
/// squares the fitting precomputes per sample: cos2_h = cos^2(theta_h), tan2_i and tan2_o the
/// squared tangents of the two directions, g_vgroove the V-groove G (used for that shadowing
/// only). The same table lookups as lobe_D and lobe_G; both directions above the horizon.
inline double tabulated_lobe_shape(const TabulatedNdf& table,
                                   Shadowing shadowing,
                                   double cos2_h,
                                   double tan2_i,
                                   double tan2_o,
                                   double g_vgroove) {
    using std::sqrt;
    const double D = D_tabulated(table, sqrt(cos2_h));
    switch (shadowing) {
        case Shadowing::kSmithCorrelated:
        case Shadowing::kSmithSeparable: {
            const double li = lambda_tabulated(table, 1.0 / sqrt(1.0 + tan2_i));
            const double lo = lambda_tabulated(table, 1.0 / sqrt(1.0 + tan2_o));
            return D * (shadowing == Shadowing::kSmithCorrelated ? G_smith_correlated(li, lo)
                                                                 : G_smith_separable(li, lo));
        }
        case Shadowing::kVGroove:
            return D * g_vgroove;
        case Shadowing::kNone:
            break;
    }
    return D;
}

/// The Fresnel term of a lobe for channel c at cos_d = wi . h, with one_minus_cos = 1 - cos_d
/// computed by the caller without cancellation.
template <class T, class P>
inline T lobe_F(const Fresnel<P>& f, int c, const T& cos_d, const T& one_minus_cos) {
    switch (f.type) {
        case FresnelType::kSchlick:
            return fresnel_schlick_from_one_minus_cos(one_minus_cos, T(f.f0[c]));
        case FresnelType::kDielectric:
            return fresnel_dielectric(cos_d, T(f.eta));
        case FresnelType::kConductor:
            return fresnel_conductor(cos_d, T(f.eta_rgb[c]), T(f.k[c]));
        case FresnelType::kNone:
            break;
    }
    return T(1);
}

/// The whole model at lanes of direction pairs, RGB into out[0..2], 1/sr: diffuse / pi (when
/// present) plus every lobe's scale * F * D * G / (4 cos_i cos_o). Lanes with either direction at
/// or below the horizon give 0 (a mask: they are evaluated at wi = wo = z, which is regular, and
/// replaced by 0). The lobe term of a lane where D = 0 is exactly 0.
/// The diffuse albedo is `diffuse` (none when null) and the lobes [lobes, lobes_end).
template <class T, class P>
inline void eval_lanes(const Rgb<P>* diffuse,
                       const Lobe<P>* lobes,
                       const Lobe<P>* lobes_end,
                       Dir3<T> wi,
                       Dir3<T> wo,
                       T out[3]) {
    const auto below = mask_or(wi.z <= T(0), wo.z <= T(0));
    if (all_of(below)) {
        // At or below the horizon: no reflection.
        out[0] = out[1] = out[2] = T(0);
        return;
    }
    // Branch of the mask: the lanes below the horizon (including wi = -wo, where no half vector
    // exists) take the regular configuration wi = wo = z; their values are replaced by 0 at the
    // end.
    wi = {select(below, T(0), wi.x), select(below, T(0), wi.y), select(below, T(1), wi.z)};
    wo = {select(below, T(0), wo.x), select(below, T(0), wo.y), select(below, T(1), wo.z)};
    for (int c = 0; c < 3; ++c) {
        out[c] = diffuse != nullptr ? lambert_from_cosines(T((*diffuse)[c]), wi.z, wo.z) : T(0);
    }
    if (lobes != lobes_end) {
        const HalfGeometry<T> g = half_geometry(wi, wo);
        const T inv_4cc = T(1) / (T(4) * wi.z * wo.z);
        for (const Lobe<P>* it = lobes; it != lobes_end; ++it) {
            const Lobe<P>& lobe = *it;
            if (lobe.rgb_roughness) {
                // RGB-varying roughness: D and G of each channel with that channel's alpha (the
                // same microfacet form per wavelength band; an isotropic analytic lobe, checked
                // by the model readers and the fit specs).
                for (int c = 0; c < 3; ++c) {
                    const P& a = lobe.alpha_rgb[c];
                    const T D = lobe_D_alpha(lobe, g.h, a, a);
                    if (all_of(D == T(0))) {
                        // No microfacet with this normal at this channel's width.
                        continue;
                    }
                    const T S = D * lobe_G_alpha(lobe, wi, wo, g, a, a) * inv_4cc;
                    const T F = lobe_F(lobe.fresnel, c, g.cos_d, g.one_minus_cos_d);
                    out[c] = out[c] + T(lobe.scale[c]) * F * S;
                }
                continue;
            }
            T D, G;
            if (lobe.anisotropic) {
                // D and G in the lobe's own frame, turned by its orientation about the normal
                // (lobe_orientation.h); F and the cosines do not depend on the turn.
                const LobeRotation<P> r = lobe_rotation_deg(lobe.orientation_deg);
                HalfGeometry<T> g_l = g;
                g_l.h = in_lobe_frame(g.h, r);
                D = lobe_D(lobe, g_l.h);
                if (all_of(D == T(0))) {
                    // No microfacet with this normal: the lobe contributes exactly zero.
                    continue;
                }
                G = lobe_G(lobe, in_lobe_frame(wi, r), in_lobe_frame(wo, r), g_l);
            } else {
                D = lobe_D(lobe, g.h);
                if (all_of(D == T(0))) {
                    // No microfacet with this normal: the lobe contributes exactly zero (F and G
                    // are not needed; this also skips them in the far tail of sharp lobes).
                    continue;
                }
                G = lobe_G(lobe, wi, wo, g);
            }
            const T S = D * G * inv_4cc;
            for (int c = 0; c < 3; ++c) {
                const T F = lobe_F(lobe.fresnel, c, g.cos_d, g.one_minus_cos_d);
                out[c] = out[c] + T(lobe.scale[c]) * F * S;
            }
        }
    }
    for (int c = 0; c < 3; ++c) {
        // Branch of the mask: at or below the horizon, no reflection.
        out[c] = select(below, T(0), out[c]);
    }
}

/// The whole model at lanes of direction pairs (see eval_lanes).
template <class T, class P>
inline void eval_model_lanes(const Model<P>& m, const Dir3<T>& wi, const Dir3<T>& wo, T out[3]) {
    const Lobe<P>* lobes = m.lobes.data();
    eval_lanes(m.has_diffuse ? &m.diffuse : nullptr, lobes, lobes + m.lobes.size(), wi, wo, out);
}

/// One microfacet (or Blinn-Phong) lobe: scale * F(wi.h) * D(h) * G / (4 cos_i cos_o), RGB in
/// 1/sr. Zero when either direction is at or below the horizon (wi.z <= 0 or wo.z <= 0).
template <class T>
inline Rgb<T> eval_lobe(const Lobe<T>& lobe, const Vec3<T>& wi, const Vec3<T>& wo) {
    T out[3];
    eval_lanes(static_cast<const Rgb<T>*>(nullptr),
               &lobe,
               &lobe + 1,
               Dir3<T>{wi.x(), wi.y(), wi.z()},
               Dir3<T>{wo.x(), wo.y(), wo.z()},
               out);
    return Rgb<T>(out[0], out[1], out[2]);
}

/// The whole model: diffuse / pi (when present) plus every lobe; RGB in 1/sr, zero when either
/// direction is at or below the horizon. No allocation.
template <class T>
inline Rgb<T> eval_model(const Model<T>& m, const Vec3<T>& wi, const Vec3<T>& wo) {
    T out[3];
    eval_model_lanes(m, Dir3<T>{wi.x(), wi.y(), wi.z()}, Dir3<T>{wo.x(), wo.y(), wo.z()}, out);
    return Rgb<T>(out[0], out[1], out[2]);
}

}  // namespace gonio::brdf
