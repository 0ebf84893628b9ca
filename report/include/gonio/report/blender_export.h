#pragma once

// Export of an analytic model to Blender: a Python script that, run by Blender 3.x (`blender -b
// --python material.py`, or from Blender's text editor), creates one material from Blender's own
// Cycles closures and nothing else in the scene. The mapping (docs/blender.md):
//
// - diffuse: a Diffuse BSDF of roughness 0 (Lambert, rho / pi) with colour rho. Exact.
// - a lobe without Fresnel (F = 1): a Glossy BSDF (isotropic) or an Anisotropic BSDF with the
//   lobe's distribution (GGX, Beckmann) and colour scale. Blender's roughness r gives alpha = r^2,
//   so r = sqrt(alpha); the Anisotropic BSDF takes r^2 = sqrt(alpha_x alpha_y) and anisotropy a
//   with (1 - a)^2 = alpha_x / alpha_y (a >= 0) or (1 + a)^2 = alpha_y / alpha_x (a < 0), along the
//   active UV map's tangent (Tangent node) turned by rotation = orientation_deg / 360 turns about
//   the normal. An RGB roughness is one Glossy BSDF per channel, coloured (scale_r, 0, 0), (0,
//   scale_g, 0), (0, 0, scale_b). Blender's shadowing is the separable Smith G1(wi) G1(wo): exact
//   for smith-separable lobes; a smith-correlated lobe is written with it (the measured difference
//   is stated).
// - a lobe with Fresnel: Blender's shader nodes see the view direction, not the half vector; only
//   the Principled BSDF (GGX) applies a Fresnel on wi . h, F = c0 + (1 - c0) (F_d(eta) - F_d0) /
//   (1 - F_d0) with F_d the dielectric Fresnel of eta = (1 + sqrt(0.08 s)) / (1 - sqrt(0.08 s)) (s
//   its Specular input) and c0 = 0.08 s (Metallic 0) or the Base Color (Metallic 1). An exact
//   dielectric with 1 < eta <= 1.788 is Metallic 0 with s = f0 / 0.08: F = F_d exactly. Schlick
//   is Metallic 1, Base Color f0 and s = principled_specular_for_schlick(mean f0): equal at normal
//   incidence, the measured difference stated. The lobe's scale (grey) weights the closure: a Mix
//   Shader for a weight up to 1, doubled with Add Shaders above.
// - lobes are summed with Add Shaders.
//
// Terms Blender cannot represent are refused (BlenderExportError::refused), naming the term; with
// `approximate`, those that have an approximation (Blinn-Phong as its Beckmann equivalent, a
// conductor Fresnel as the Principled BSDF's metallic Fresnel, Beckmann with a Fresnel as GGX, a
// coloured scale on a Fresnel lobe folded into the normal-incidence colour) are written and the
// difference measured by rendering in Blender is stated. The figures come from
// blender_measured_differences(), which the Blender integration test re-measures.

#include <string>
#include <tl/expected.hpp>
#include <vector>

#include "gonio/brdf/model.h"

namespace gonio::report {

struct BlenderExportOptions {
    std::string name = "gonio_fit";  ///< material name (letters, digits, '_', '-', '.')
    bool approximate = false;        ///< write the terms that have only an approximation
};

struct BlenderExportError {
    std::string message;
    /// True when the model holds a term Blender cannot represent (or the name is not allowed):
    /// a usage error (exit 2); false for values out of their domain in the model file.
    bool refused = false;
};

struct BlenderExport {
    std::string text;                         ///< the Python script
    std::vector<std::string> terms;           ///< per term: its closure and exact / approximated
    std::vector<std::string> approximations;  ///< the approximated terms with measured figures
};

tl::expected<BlenderExport, BlenderExportError> export_blender(const brdf::ModelD& model,
                                                               const BlenderExportOptions& options);

/// The index of refraction behind the Principled BSDF's Specular input s in [0, 1]: (1 +
/// sqrt(0.08 s)) / (1 - sqrt(0.08 s)), whose normal-incidence reflectance is 0.08 s.
double principled_eta(double specular);

/// The Specular input whose Fresnel shape comes closest to Schlick's for a normal-incidence
/// reflectance f0 in [0, 1]: it minimises the largest relative difference between f0 + (1 - f0)
/// (F_d(cos, eta) - F_d(1, eta)) / (1 - F_d(1, eta)) and Schlick's F over theta_d in [0, 75]
/// degrees (a grid of 0.001 in s and 0.25 degree in theta_d). About 0.21 for f0 = 0.04.
double principled_specular_for_schlick(double f0);

/// A difference between a model and its Blender material, measured by the Blender integration
/// test (blender_render.h: sphere of 160 px, sun 38 degrees from the view, then 120 degrees from
/// it, back-lit) on the case named. Bounds in percent, rounded up from the measured figures.
struct BlenderMeasured {
    const char* key;                         ///< what is approximated
    const char* test_case;                   ///< the model rendered
    double front_median_pct, front_p90_pct;  ///< sun 38 degrees from the view
    double back_median_pct, back_p90_pct;    ///< sun 120 degrees from the view
};
const std::vector<BlenderMeasured>& blender_measured_differences();
/// The entry of `key` (aborts on an unknown key: the keys are the export's own).
const BlenderMeasured& blender_measured(const std::string& key);

}  // namespace gonio::report
