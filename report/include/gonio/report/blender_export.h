#pragma once

// Export of an analytic model to Blender: a Python script that, run by Blender 3.x (`blender -b
// --python material.py`, or from Blender's text editor), creates one material from Blender's own
// Cycles closures and nothing else in the scene. The mapping (docs/blender.md):
//
// - diffuse: a Diffuse BSDF of roughness 0 (Lambert, rho / pi) with colour rho. Exact.
// - a lobe without Fresnel (F = 1): a Glossy BSDF (isotropic) or an Anisotropic BSDF with the
//   lobe's distribution (GGX, Beckmann) and colour scale. Blender's roughness r gives alpha = r^2,
//   so r = sqrt(alpha); the Anisotropic BSDF takes r^2 = sqrt(alpha_x alpha_y) and anisotropy a with
//   (1 - a)^2 = alpha_x / alpha_y (a >= 0) or (1 + a)^2 = alpha_y / alpha_x (a < 0), along the
//   active UV map's tangent (Tangent node) turned by rotation = orientation_deg / 360 turns about
//   the normal. An RGB roughness is one Glossy BSDF per channel, coloured (scale_r, 0, 0), (0,
//   scale_g, 0), (0, 0, scale_b). Blender's shadowing is the separable Smith G1(wi) G1(wo): exact
//   for smith-separable lobes; a smith-correlated lobe is written with it (the measured difference
//   is stated).
// - a lobe with Fresnel: Blender's shader nodes see the view direction, not the half vector; only
//   the Principled BSDF (GGX) applies a Fresnel on wi . h, F = c0 + (1 - c0) (F_d(eta) - F_d0) /
//   (1 - F_d0) with F_d the dielectric Fresnel of eta = (1 + sqrt(0.08 s)) / (1 - sqrt(0.08 s)) (s
//   its Specular input) and c0 = 0.08 s (Metallic 0) or the Base Color (Metallic 1). An exact
//   dielectric with 1 < eta <= 1.80 is Metallic 0 with s = f0 / 0.08: F = F_d exactly. Schlick is
//   Metallic 1, Base Color f0, s = min(1, mean f0 / 0.08): equal at normal incidence, the measured
//   difference stated. The lobe's scale (grey) weights the closure: a Mix Shader for a weight up to
//   1, doubled with Add Shaders above.
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

/// A difference between a model and its Blender material, measured by the Blender integration
/// test (blender_render.h, sphere of 160 px, sun toward (0.5, 0.35, 0.79)) on the case named.
struct BlenderMeasured {
    const char* key;        ///< what is approximated
    const char* test_case;  ///< the model rendered
    double median_pct;      ///< stated bound of the median relative difference, percent
    double p90_pct;         ///< stated bound of the 90th percentile, percent
};
const std::vector<BlenderMeasured>& blender_measured_differences();
/// The entry of `key` (aborts on an unknown key: the keys are the export's own).
const BlenderMeasured& blender_measured(const std::string& key);

}  // namespace gonio::report
