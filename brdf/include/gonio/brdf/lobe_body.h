#pragma once

// One microfacet lobe, assembled once for every caller:
//
//   S = D(h) G(wi, wo) / (4 cos_i cos_o),   lobe term of channel c: scale_c F_c S,
//
// with D the lobe's distribution, G its shadowing-masking (height-correlated or separable Smith
// from the distribution's Lambda, V-groove, or none) and F its Fresnel term [CT82], [W07 eq. 20].
// The formulas themselves live in microfacet.h, blinn_phong.h, student_t.h, tabulated_ndf.h and
// fresnel.h; this file only chooses and combines them. Adding a distribution means adding it to
// lobe_D_squares and lobe_lambda_squares below.
//
// The callers differ only in how they hold a sample's geometry: the evaluation (model_eval.h) has
// the directions themselves, the fitting's prepared samples (fitting/prepared_samples.h) and its
// packet kernels have squared components and squared tangents computed once per sample. Both
// hand over a LobeSquares: the squares of the half vector and of the two directions in the lobe's
// frame (lobe_orientation.h), and the few per-sample values that one distribution or shadowing
// needs (log cos theta_h for Blinn-Phong, cos theta for a tabulated distribution, the V-groove G).
//
// Templated on the numeric type T of the result (double, ceres::Jet, xsimd::batch), the type P of
// the lobe's parameters (double, or the Jet for Jets) and the type Geo of the geometry (double or
// T), and on whether it carries the derivative with respect to the width alpha in closed form
// (microfacet_derivatives.h: for packets, where a Jet cannot go; a Jet carries its own).

#include <cmath>
#include <limits>

#include "gonio/base/check.h"
#include "gonio/brdf/blinn_phong.h"
#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/lobe_orientation.h"
#include "gonio/brdf/math.h"
#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/microfacet_derivatives.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/student_t.h"
#include "gonio/brdf/tabulated_ndf.h"

/// The body's choosing functions (lobe_shape and what it calls, lobe_F) are inlined into their
/// caller whatever the compiler's size estimate, and so is a packet kernel's call of lobe_shape
/// (fitting/src/lobe_shape_kernel.h). Their switches hold every distribution, Fresnel and check,
/// which makes them look large; left to itself the compiler kept them out of line, and the
/// fitting's fused packet pass then made four calls per lobe and packet, passing the 14 packets
/// of a LobeSquares through memory and, since a call clobbers every vector register, saving and
/// restoring the pass's packets around each (one LM iteration over 1.1 M samples 37 % slower on
/// AVX-512, three times slower where measured first). Inlined, only the structure's own case is
/// executed, a branch that is the same for every packet; the large formulas (Beckmann's Lambda
/// with erfc) stay calls as before. The checks in these functions are GONIO_CHECK (no stream
/// with its unwinding code in the caller).
#define GONIO_LOBE_INLINE inline __attribute__((always_inline))

namespace gonio::brdf {

/// How the direction parts of a LobeSquares are given.
enum class SquaresForm {
    /// x2 = w_x^2, y2 = w_y^2, z = w_z of a unit direction: alpha(phi)^2 tan^2(theta) =
    /// (alpha_x^2 x2 + alpha_y^2 y2) / z^2.
    kComponents,
    /// x2 = w_x^2 / w_z^2, y2 = w_y^2 / w_z^2, the squared slopes (z unused).
    kTangents,
};

/// One direction's squares in a lobe's frame (see SquaresForm).
template <class Geo>
struct DirSquares {
    Geo x2{};
    Geo y2{};
    Geo z{};          ///< w_z (SquaresForm::kComponents only).
    Geo cos_theta{};  ///< cos theta (a tabulated distribution's Lambda only).
};

/// The geometry of one sample (or of lanes of samples) that a lobe's shape takes, in the lobe's
/// frame; both directions above the horizon, so h_z > 0.
template <class Geo>
struct LobeSquares {
    /// hy2 and both directions' y2 are 0, their x parts hold the sums (an isotropic structure).
    bool isotropic = false;
    Geo hx2{};
    Geo hy2{};
    Geo hz2{};
    Geo cos_h{};      ///< cos theta_h (a tabulated distribution only).
    Geo log_cos_h{};  ///< log cos theta_h, -infinity where cos^e underflows (Blinn-Phong only).
    DirSquares<Geo> wi, wo;
    Geo g_vgroove{};  ///< The V-groove G (that shadowing only).
    Geo inv_4cc{};    ///< 1 / (4 cos_i cos_o).
};

/// What the Fresnel terms take of a sample.
template <class Geo>
struct FresnelGeometry {
    Geo x5{};     ///< (1 - cos_d)^5 with 1 - cos_d clamped to [0, 1] (Schlick only).
    Geo cos_d{};  ///< cos_d = wi . h (dielectric and conductor only).
};

/// A lobe's structure and the parameters its shape takes (references to the caller's values).
template <class P>
struct LobeShapeParams {
    Distribution distribution;
    Shadowing shadowing;
    const P& alpha_x;   ///< GGX, Beckmann, Student-t.
    const P& alpha_y;   ///< Likewise; equal to alpha_x for an isotropic lobe.
    const P& exponent;  ///< Blinn-Phong.
    const P& gamma;     ///< Student-t.
    const TabulatedNdf* table;
};

/// Slope parameter along y actually in use (alpha_x for an isotropic lobe).
template <class T>
inline const T& lobe_alpha_y(const Lobe<T>& lobe) {
    return lobe.anisotropic ? lobe.alpha_y : lobe.alpha_x;
}

/// The shape parameters of `lobe` with the slope parameters (ax, ay) (one channel's alpha of an
/// RGB-roughness lobe, or the lobe's own).
template <class P>
inline LobeShapeParams<P> lobe_shape_params(const Lobe<P>& lobe, const P& ax, const P& ay) {
    return {lobe.distribution, lobe.shadowing, ax, ay, lobe.exponent, lobe.gamma, lobe.table.get()};
}

/// True when the lobe's D and G depend on its orientation (Lobe::orientation_deg), i.e. the
/// geometry must be turned into its frame: an anisotropic analytic lobe other than Blinn-Phong.
template <class P>
inline bool lobe_is_turned(const Lobe<P>& lobe) {
    return lobe.anisotropic && lobe.distribution != Distribution::kBlinnPhong &&
           lobe.distribution != Distribution::kTabulated;
}

/// The lobe's normal distribution D(h), 1/sr, from the squares (h_z > 0).
template <class T, class P, class Geo>
GONIO_LOBE_INLINE T lobe_D_squares(const LobeShapeParams<P>& p, const LobeSquares<Geo>& g) {
    switch (p.distribution) {
        case Distribution::kGgx:
            return D_ggx_from_squares(T(g.hx2), T(g.hy2), T(g.hz2), T(p.alpha_x), T(p.alpha_y));
        case Distribution::kBeckmann:
            return D_beckmann_from_squares(
                T(g.hx2), T(g.hy2), T(g.hz2), T(p.alpha_x), T(p.alpha_y));
        case Distribution::kBlinnPhong: {
            const T log_cos(g.log_cos_h);
            const auto underflow = !(log_cos > T(-std::numeric_limits<double>::infinity()));
            if (all_of(underflow)) {
                // cos^e(theta_h) underflows to 0 (h at the horizon through rounding).
                return T(0);
            }
            // Branch of the mask: cos^e underflowing, D = 0.
            return select(
                underflow,
                T(0),
                D_blinn_phong_from_log_cos(select(underflow, T(0), log_cos), T(p.exponent)));
        }
        case Distribution::kStudentT:
            if constexpr (IsPacket<T>::value) {
                // Not reached: a Student-t lobe goes lane by lane (its Lambda's continued
                // fraction iterates a data-dependent number of times).
                GONIO_CHECK(false && "Student-t lobe evaluated on packets");
                return T(0);
            } else {
                return D_student_t_from_squares(
                    T(g.hx2), T(g.hy2), T(g.hz2), T(p.alpha_x), T(p.alpha_y), T(p.gamma));
            }
        case Distribution::kTabulated:
            if constexpr (IsPacket<T>::value) {
                // Not reached: a tabulated lobe goes lane by lane (a lookup per lane's value).
                GONIO_CHECK(false && "tabulated lobe evaluated on packets");
                return T(0);
            } else {
                GONIO_CHECK(p.table != nullptr && "tabulated lobe without its table");
                return D_tabulated(*p.table, T(g.cos_h));
            }
    }
    return T(0);
}

/// The squared slope parameters (alpha_x^2, alpha_y^2) that the Smith Lambda takes: a Blinn-Phong
/// lobe uses Beckmann's Lambda with alpha = sqrt(2 / (e + 2)) (blinn_phong.h).
template <class T, class P>
GONIO_LOBE_INLINE void lambda_alpha_squares(const LobeShapeParams<P>& p, T& ax2, T& ay2) {
    if (p.distribution == Distribution::kBlinnPhong) {
        ax2 = ay2 = sqr(blinn_phong_equivalent_alpha(T(p.exponent)));
        return;
    }
    ax2 = T(p.alpha_x) * T(p.alpha_x);
    ay2 = T(p.alpha_y) * T(p.alpha_y);
}

/// The Smith Lambda of one direction as a fraction (GGX's is t / (2 z (z + sqrt(z^2 + t))),
/// lambda_ggx_fraction, so that G divides once for both directions; the others' the value over
/// 1), from the squares and the squared slope parameters.
template <SquaresForm kForm, class T, class P, class Geo>
GONIO_LOBE_INLINE Fraction<T> lobe_lambda_squares(const LobeShapeParams<P>& p,
                                                  bool isotropic,
                                                  const DirSquares<Geo>& w,
                                                  const T& ax2,
                                                  const T& ay2) {
    if (p.distribution == Distribution::kTabulated) {
        if constexpr (IsPacket<T>::value) {
            // Not reached: see lobe_D_squares.
            GONIO_CHECK(false && "tabulated lobe evaluated on packets");
            return {T(0), T(1)};
        } else {
            GONIO_CHECK(p.table != nullptr && "tabulated lobe without its table");
            return {lambda_tabulated(*p.table, T(w.cos_theta)), T(1)};
        }
    }
    // t = alpha_x^2 x2 + alpha_y^2 y2: alpha(phi)^2 tan^2(theta) times z^2.
    const T t = isotropic ? ax2 * T(w.x2) : ax2 * T(w.x2) + ay2 * T(w.y2);
    constexpr bool kTan = kForm == SquaresForm::kTangents;
    if (p.distribution == Distribution::kGgx) {
        return kTan ? lambda_ggx_fraction(t, T(1)) : lambda_ggx_fraction(t, T(w.z));
    }
    const T a2 = kTan ? t : t / sqr(T(w.z));
    if (p.distribution == Distribution::kStudentT) {
        if constexpr (IsPacket<T>::value) {
            // Not reached: see lobe_D_squares.
            GONIO_CHECK(false && "Student-t lobe evaluated on packets");
            return {T(0), T(1)};
        } else {
            return {lambda_student_t_a2(a2, T(p.gamma)), T(1)};
        }
    }
    // Beckmann, and Blinn-Phong through Beckmann's Lambda.
    return {lambda_beckmann_from_a2(a2), T(1)};
}

/// dLambda/dalpha of an isotropic GGX or Beckmann lobe at a2 = alpha^2 tan^2(theta).
template <class T, class P>
GONIO_LOBE_INLINE T lobe_dlambda_dalpha(const LobeShapeParams<P>& p, const T& a2, const T& alpha) {
    return p.distribution == Distribution::kBeckmann ? dlambda_beckmann_dalpha_from_a2(a2, alpha)
                                                     : dlambda_ggx_dalpha_from_a2(a2, alpha);
}

/// The lobe's shape S = D G / (4 cos_i cos_o) at one sample (or lanes), 1/sr; exactly 0 where D
/// is 0. With Deriv, also *dS = dS/dalpha in closed form: an isotropic GGX or Beckmann lobe with
/// no or Smith shadowing whose squares are given as tangents (the fitting's packet kernels); the
/// value is then computed with the Lambdas divided out, as the derivative needs them.
template <bool Deriv, SquaresForm kForm, class T, class P, class Geo>
GONIO_LOBE_INLINE T lobe_shape(const LobeShapeParams<P>& p,
                               const LobeSquares<Geo>& g,
                               T* dS = nullptr) {
    if constexpr (Deriv) {
        GONIO_CHECK(
            (p.distribution == Distribution::kGgx || p.distribution == Distribution::kBeckmann) &&
            "closed-form width derivative of a GGX or Beckmann lobe only");
    }
    const T D = lobe_D_squares<T>(p, g);
    if constexpr (!Deriv) {
        if (all_of(D == T(0))) {
            // No microfacet with this normal (the far tail of a sharp lobe): exactly zero, and
            // G is not needed.
            return T(0);
        }
    }
    T G(1);
    T dG(0);
    if (p.shadowing == Shadowing::kSmithCorrelated || p.shadowing == Shadowing::kSmithSeparable) {
        T ax2, ay2;
        lambda_alpha_squares(p, ax2, ay2);
        const Fraction<T> fi = lobe_lambda_squares<kForm>(p, g.isotropic, g.wi, ax2, ay2);
        const Fraction<T> fo = lobe_lambda_squares<kForm>(p, g.isotropic, g.wo, ax2, ay2);
        const bool correlated = p.shadowing == Shadowing::kSmithCorrelated;
        if constexpr (Deriv) {
            // The Lambdas themselves (GGX's fraction has a denominator, the others' is 1).
            const bool ggx = p.distribution == Distribution::kGgx;
            const T li = ggx ? fi.num / fi.den : fi.num;
            const T lo = ggx ? fo.num / fo.den : fo.num;
            const T alpha(p.alpha_x);
            const T dli = lobe_dlambda_dalpha(p, ax2 * T(g.wi.x2), alpha);
            const T dlo = lobe_dlambda_dalpha(p, ax2 * T(g.wo.x2), alpha);
            G = correlated ? G_smith_correlated(li, lo) : G_smith_separable(li, lo);
            dG = correlated ? dG_smith_correlated(G, dli, dlo)
                            : dG_smith_separable(G, li, lo, dli, dlo);
        } else {
            G = correlated ? G_smith_correlated(fi, fo) : G_smith_separable(fi, fo);
        }
    } else if (p.shadowing == Shadowing::kVGroove) {
        G = T(g.g_vgroove);
    }
    const T inv_4cc(g.inv_4cc);
    if constexpr (Deriv) {
        const T alpha(p.alpha_x);
        const T dD = p.distribution == Distribution::kBeckmann
                         ? dD_beckmann_dalpha_from_squares(T(g.hx2), T(g.hz2), alpha, D)
                         : dD_ggx_dalpha_from_squares(T(g.hx2), T(g.hz2), alpha, D);
        *dS = (dD * G + D * dG) * inv_4cc;
    }
    return D * G * inv_4cc;
}

/// The Fresnel term of a lobe for channel c (fresnel.h).
template <class T, class P, class Geo>
GONIO_LOBE_INLINE T lobe_F(const Fresnel<P>& f, int c, const FresnelGeometry<Geo>& g) {
    switch (f.type) {
        case FresnelType::kSchlick:
            return fresnel_schlick_from_pow5(T(g.x5), T(f.f0[c]));
        case FresnelType::kDielectric:
            return fresnel_dielectric(T(g.cos_d), T(f.eta));
        case FresnelType::kConductor:
            return fresnel_conductor(T(g.cos_d), T(f.eta_rgb[c]), T(f.k[c]));
        case FresnelType::kNone:
            break;
    }
    return T(1);
}

/// Adds every lobe of [lobes, lobes_end) to out[0..2]: out_c += scale_c F_c S. `src` gives the
/// sample's geometry: src.squares() in the sample's frame, src.turned(r) in the frame of a lobe
/// turned by the rotation r (lobe_orientation.h), src.fresnel() the Fresnel inputs. A lobe with
/// RGB-varying roughness (Lobe::rgb_roughness, an isotropic analytic lobe) takes each channel's
/// shape with that channel's alpha.
template <SquaresForm kForm, class T, class P, class Source>
inline void add_lobes(const Lobe<P>* lobes, const Lobe<P>* lobes_end, const Source& src, T out[3]) {
    for (const Lobe<P>* it = lobes; it != lobes_end; ++it) {
        const Lobe<P>& lobe = *it;
        if (lobe.rgb_roughness) {
            const auto g = src.squares();
            for (int c = 0; c < 3; ++c) {
                const P& a = lobe.alpha_rgb[c];
                const T S = lobe_shape<false, kForm, T>(lobe_shape_params(lobe, a, a), g);
                if (all_of(S == T(0))) {
                    // No microfacet with this normal at this channel's width.
                    continue;
                }
                out[c] = out[c] + T(lobe.scale[c]) * lobe_F<T>(lobe.fresnel, c, src.fresnel()) * S;
            }
            continue;
        }
        const auto params = lobe_shape_params(lobe, lobe.alpha_x, lobe_alpha_y(lobe));
        const T S = lobe_is_turned(lobe)
                        ? lobe_shape<false, kForm, T>(
                              params, src.turned(lobe_rotation_deg(lobe.orientation_deg)))
                        : lobe_shape<false, kForm, T>(params, src.squares());
        if (all_of(S == T(0))) {
            // No microfacet with this normal: the lobe contributes exactly zero (F is not needed).
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            out[c] = out[c] + T(lobe.scale[c]) * lobe_F<T>(lobe.fresnel, c, src.fresnel()) * S;
        }
    }
}

}  // namespace gonio::brdf
