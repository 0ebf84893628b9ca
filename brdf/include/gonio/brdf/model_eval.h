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
#include "gonio/brdf/lobe_body.h"
#include "gonio/brdf/lobe_orientation.h"
#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/student_t.h"
#include "gonio/brdf/tabulated_ndf.h"

namespace gonio::brdf {

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
    if (lobe_is_turned(lobe)) {
        hs = in_lobe_frame(hs, lobe_rotation_deg(lobe.orientation_deg));
    }
    LobeSquares<T> g;
    g.hx2 = sqr(hs.x);
    g.hy2 = sqr(hs.y);
    g.hz2 = sqr(hs.z);
    g.cos_h = hs.z;
    g.log_cos_h = log_cos_theta_h(g.hx2 + g.hy2, hs.z);
    return select(below,
                  T(0),
                  lobe_D_squares<T>(lobe_shape_params(lobe, lobe.alpha_x, lobe_alpha_y(lobe)), g));
}

/// The per-sample geometry of eval_lanes in the form the lobe body takes (lobe_body.h): the
/// squares of the half vector and of both directions, in the sample's frame or turned into a
/// lobe's; the values only some structures need are computed when a lobe of [lobes, lobes_end)
/// needs them.
template <class T>
class DirectionSquares {
  public:
    template <class P>
    DirectionSquares(const Dir3<T>& wi,
                     const Dir3<T>& wo,
                     const Lobe<P>* lobes,
                     const Lobe<P>* lobes_end)
        : wi_(wi), wo_(wo), g_(half_geometry(wi, wo)), inv_4cc_(T(1) / (T(4) * wi.z * wo.z)) {
        for (const Lobe<P>* it = lobes; it != lobes_end; ++it) {
            blinn_phong_ = blinn_phong_ || it->distribution == Distribution::kBlinnPhong;
            vgroove_ = vgroove_ || it->shadowing == Shadowing::kVGroove;
            schlick_ = schlick_ || it->fresnel.type == FresnelType::kSchlick;
        }
        if (vgroove_) {
            g_vgroove_ = G_vgroove_from_cosines(g_.h.z, wi.z, wo.z, g_.cos_d);
        }
        fresnel_.cos_d = g_.cos_d;
        if (schlick_) {
            fresnel_.x5 = pow5(clamp_to(g_.one_minus_cos_d, T(0), T(1)));
        }
    }

    /// In the sample's frame.
    LobeSquares<T> squares() const { return of(g_.h, wi_, wo_); }

    /// In the frame of a lobe turned by r about the normal (the cosines are kept).
    template <class P>
    LobeSquares<T> turned(const LobeRotation<P>& r) const {
        return of(in_lobe_frame(g_.h, r), in_lobe_frame(wi_, r), in_lobe_frame(wo_, r));
    }

    const FresnelGeometry<T>& fresnel() const { return fresnel_; }

  private:
    LobeSquares<T> of(const Dir3<T>& h, const Dir3<T>& wi, const Dir3<T>& wo) const {
        LobeSquares<T> s;
        s.hx2 = sqr(h.x);
        s.hy2 = sqr(h.y);
        s.hz2 = sqr(h.z);
        s.cos_h = h.z;
        if (blinn_phong_) {
            s.log_cos_h = log_cos_theta_h(s.hx2 + s.hy2, h.z);
        }
        s.wi = {sqr(wi.x), sqr(wi.y), wi.z, wi.z};
        s.wo = {sqr(wo.x), sqr(wo.y), wo.z, wo.z};
        s.g_vgroove = g_vgroove_;
        s.inv_4cc = inv_4cc_;
        return s;
    }

    Dir3<T> wi_, wo_;
    HalfGeometry<T> g_;
    T inv_4cc_;
    T g_vgroove_{};
    FresnelGeometry<T> fresnel_;
    bool blinn_phong_ = false, vgroove_ = false, schlick_ = false;
};

/// The Fresnel term of a lobe for channel c at cos_d = wi . h, with one_minus_cos = 1 - cos_d
/// computed by the caller without cancellation.
template <class T, class P>
inline T lobe_F(const Fresnel<P>& f, int c, const T& cos_d, const T& one_minus_cos) {
    FresnelGeometry<T> g;
    g.cos_d = cos_d;
    if (f.type == FresnelType::kSchlick) {
        g.x5 = pow5(clamp_to(one_minus_cos, T(0), T(1)));
    }
    return lobe_F<T>(f, c, g);
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
        add_lobes<SquaresForm::kComponents>(
            lobes, lobes_end, DirectionSquares<T>(wi, wo, lobes, lobes_end), out);
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
