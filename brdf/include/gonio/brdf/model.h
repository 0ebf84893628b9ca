#pragma once

// The analytic model: the contract of `gonio eval`, of fits and of the simulator's ground truth.
//
//   f(wi, wo) = diffuse / pi + sum over lobes of scale * F(wi . h) * D(h) * G(wi, wo) / (4 cos_i cos_o)
//
// zero when either direction is at or below the horizon; RGB values in 1/sr. The numeric fields are
// templated so that a fit can hold Ceres Jets in them; the structure (enums, lobe count) is fixed
// during a fit. Evaluation lives in model_eval.h; JSON reading and writing in model_json.h (schema:
// docs/model-schema.md).

#include <memory>
#include <string>
#include <vector>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// Microfacet normal distribution D of a lobe.
enum class Distribution {
    kGgx,         ///< Trowbridge-Reitz (GGX), slope parameters alpha_x, alpha_y.
    kBeckmann,    ///< Beckmann, slope parameters alpha_x, alpha_y.
    kBlinnPhong,  ///< Normalised Blinn-Phong lobe (pre-PBR practice), exponent; no F, G unless
                  ///< requested.
    kStudentT,    ///< Student-t distribution of slopes (STD, student_t.h): alpha_x, alpha_y and the
                  ///< tail parameter gamma (2 = GGX, infinity = Beckmann).
    kTabulated,   ///< Isotropic D(theta_h) tabulated from data by power iteration
                  ///< (tabulated_ndf.h) with its own Smith Lambda; Lobe::table holds it.
};

struct TabulatedNdf;

/// Shadowing-masking term G of a lobe.
enum class Shadowing {
    kSmithCorrelated,  ///< Height-correlated Smith: 1 / (1 + Lambda(wi) + Lambda(wo)).
    kSmithSeparable,   ///< Separable Smith: G1(wi) G1(wo).
    kVGroove,  ///< Cook-Torrance V-groove: min(1, 2 cos_h cos_o / (wo.h), 2 cos_h cos_i / (wi.h)).
    kNone,     ///< G = 1.
};

/// Fresnel term F of a lobe, a function of cos(wi . h).
enum class FresnelType {
    kNone,        ///< F = 1.
    kSchlick,     ///< F = f0 + (1 - f0)(1 - cos)^5, f0 per channel.
    kDielectric,  ///< Exact unpolarised dielectric, relative index eta (scalar), total internal
                  ///< reflection.
    kConductor,   ///< Exact conductor, complex index eta + i k per channel.
};

template <class T>
struct Fresnel {
    FresnelType type = FresnelType::kNone;
    Rgb<T> f0 = Rgb<T>::Constant(T(0.04));    ///< Schlick normal-incidence reflectance, [0, 1].
    T eta = T(1.5);                           ///< Dielectric relative index of refraction, > 0.
    Rgb<T> eta_rgb = Rgb<T>::Constant(T(1));  ///< Conductor real part of the index, > 0.
    Rgb<T> k = Rgb<T>::Constant(T(0));        ///< Conductor extinction coefficient, >= 0.
};

template <class T>
struct Lobe {
    Distribution distribution = Distribution::kGgx;
    bool anisotropic =
        false;  ///< When false alpha_y == alpha_x is implied and only alpha_x is used.
    T alpha_x =
        T(0.1);  ///< Slope parameter along x (alpha itself, not a perceptual roughness), > 0.
    T alpha_y = T(0.1);  ///< Slope parameter along y, > 0.
    /// Anisotropic lobes: the angle of the lobe's x axis (the direction of alpha_x) from the
    /// sample's x axis, degrees, counter-clockwise about the normal (lobe_orientation.h); the
    /// lobe has period 180 in it. Degrees as in the model schema and the fit's parameter
    /// (`orientation_deg`), so that files and reports hold the number the operator wrote; the
    /// evaluation turns it into radians once per lobe. Always 0 for an isotropic lobe, which does
    /// not depend on it.
    T orientation_deg = T(0);
    /// RGB-varying roughness: when true (isotropic GGX, Beckmann and Student-t lobes only),
    /// channel c of the lobe is evaluated with alpha_x = alpha_y = alpha_rgb[c] in D and in
    /// Smith's Lambda, so that the lobe's width depends on the wavelength as in measured
    /// materials whose peak is wider in one channel (dispersion in a coating, a coloured
    /// substrate seen through a rough interface). alpha_x then holds alpha_rgb[1] (green), the
    /// one width that sampling and previews use.
    bool rgb_roughness = false;
    Rgb<T> alpha_rgb = Rgb<T>::Constant(T(0.1));  ///< Per-channel slope parameters, > 0.
    T exponent = T(100);                          ///< Blinn-Phong exponent, > 0.
    T gamma = T(2);  ///< Student-t tail parameter, > 3/2 (2 is GGX; larger is Beckmann-like).
    /// The table of a kTabulated lobe (data, never a fitted parameter; shared by copies). Null for
    /// the analytic distributions, and in a fit specification whose table is still to be extracted
    /// from the data (fitting/power_iteration.h).
    std::shared_ptr<const TabulatedNdf> table;
    Shadowing shadowing = Shadowing::kSmithCorrelated;
    Fresnel<T> fresnel;
    Rgb<T> scale = Rgb<T>::Constant(T(1));  ///< Per-channel lobe weight, >= 0.
};

template <class T>
struct Model {
    bool has_diffuse = true;
    Rgb<T> diffuse =
        Rgb<T>::Constant(T(0));  ///< Lambert albedo rho per channel, >= 0 (f = rho / pi).
    std::vector<Lobe<T>> lobes;
};

using ModelD = Model<double>;

/// Names used in JSON and on the command line.
const char* to_string(Distribution d);
const char* to_string(Shadowing s);
const char* to_string(FresnelType f);

/// Copies a model changing its scalar type (double -> Jet for fits, Jet -> double for reports).
template <class To, class From, class Convert>
Model<To> cast_model(const Model<From>& m, Convert convert) {
    Model<To> out;
    out.has_diffuse = m.has_diffuse;
    auto rgb = [&](const Rgb<From>& v) {
        return Rgb<To>(convert(v[0]), convert(v[1]), convert(v[2]));
    };
    out.diffuse = rgb(m.diffuse);
    for (const Lobe<From>& l : m.lobes) {
        Lobe<To> o;
        o.distribution = l.distribution;
        o.anisotropic = l.anisotropic;
        o.alpha_x = convert(l.alpha_x);
        o.alpha_y = convert(l.alpha_y);
        o.orientation_deg = convert(l.orientation_deg);
        o.rgb_roughness = l.rgb_roughness;
        o.alpha_rgb = rgb(l.alpha_rgb);
        o.exponent = convert(l.exponent);
        o.gamma = convert(l.gamma);
        o.table = l.table;
        o.shadowing = l.shadowing;
        o.fresnel.type = l.fresnel.type;
        o.fresnel.f0 = rgb(l.fresnel.f0);
        o.fresnel.eta = convert(l.fresnel.eta);
        o.fresnel.eta_rgb = rgb(l.fresnel.eta_rgb);
        o.fresnel.k = rgb(l.fresnel.k);
        o.scale = rgb(l.scale);
        out.lobes.push_back(o);
    }
    return out;
}

}  // namespace gonio::brdf
