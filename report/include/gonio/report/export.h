#pragma once

// Renderer exports of an analytic model: a Mitsuba 3 scene fragment (XML) and a pbrt-v4 material
// (scene-description text). The mapping of every convention is explicit and documented in
// docs/file-formats.md; whatever a renderer cannot represent exactly is stated in a comment at the
// top of the output and listed in RendererExport::approximations.
//
// The model is f = diffuse / pi + sum_k scale_k F_k D_k G_k / (4 cos_i cos_o) (brdf/model.h).
//
// Mitsuba 3 (scene format 3.0.0): the m non-zero terms are combined with nested `blendbsdf`s whose
// weights give each term 1/m, and each term is multiplied by m: the diffuse term is a `diffuse`
// with reflectance m * diffuse; lobe k is a `roughconductor` with the same distribution (ggx or
// beckmann), alpha (alpha_u = alpha_x, alpha_v = alpha_y when anisotropic; Mitsuba's alpha is the
// same slope parameter, no remapping) and specular_reflectance m * scale_k. Fresnel: conductor ->
// eta, k; exact dielectric -> eta = (eta, eta, eta), k = 0 (the conductor equations with k = 0 are
// the dielectric ones); Schlick -> eta_c = (1 + sqrt(f0_c)) / (1 - sqrt(f0_c)), k = 0 (equal at
// normal incidence); none -> material "none" (F = 1). Mitsuba's shadowing is the separable Smith
// G1(wi) G1(wo).
//
// pbrt-v4: the terms are combined with nested `mix` materials (pbrt picks one material per shading
// point with probability amount for the second, so the expected BRDF is the weighted sum). Lobe k
// gets mix weight w_k = max_c scale_k,c and is a `conductor` (Trowbridge-Reitz = GGX, height-
// correlated Smith G) with roughness = alpha (remaproughness false; uroughness / vroughness when
// anisotropic). Fresnel: conductor -> eta, k; dielectric -> eta, k = 0; Schlick -> eta = 1, k_c =
// 2 sqrt(f0_c) / sqrt(1 - f0_c) (equal at normal incidence); none -> eta = 1, k = 1e4 (F >= 1 -
// 4e-8). A lobe whose scale is not grey has its colour r_c = scale_c / w_k folded into the normal-
// incidence reflectance: eta = 1, k from f0'_c = r_c F_c(normal). The diffuse term gets the weight
// w_d = 1 - sum w_k and reflectance diffuse / w_d; when sum w_k + max diffuse > 1 every weight is
// divided by T = sum w_k + max_c diffuse_c (the material is the model / T, stated in the comment).

#include <optional>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/model.h"

namespace gonio::report {

struct RendererExport {
    std::string text;                         ///< the file contents
    std::vector<std::string> approximations;  ///< what is not mapped exactly (also in the text)
};

/// Names and ids must be 1 to 128 characters of letters, digits, '_', '-', '.'; others are refused.
/// Mitsuba 3 XML: <scene version="3.0.0"> holding one <bsdf id="id">. Error for non-finite or
/// out-of-domain parameters (the message names the key path, e.g. "lobes[0].alpha_x").
Expected<RendererExport> export_mitsuba(const brdf::ModelD& model, const std::string& id);

/// pbrt-v4 scene text: MakeNamedMaterial statements, the last one named `name`.
Expected<RendererExport> export_pbrt(const brdf::ModelD& model, const std::string& name);

/// The verdict a fitted model file carries under "fit" (written by `gonio fit --out`).
struct ModelFileVerdict {
    std::string verdict;   ///< "represents", "visible-misfit", "does-not-represent"
    std::string headline;  ///< the fit's headline, as `gonio fit` printed it
    std::string report;    ///< the report's file name
};

/// Reads the "fit" object of a model file: nothing when the file has none (a model written by
/// hand), an error when it cannot be read. A file from before the three-state verdict gives
/// "represents" or "does-not-represent" from its "represents" flag.
Expected<std::optional<ModelFileVerdict>> read_model_verdict(const std::string& model_path);

/// The export text with the verdict of a misfit stated at its top, as a comment of the format
/// (`xml`: an XML comment after the declaration, else `#` lines for pbrt): a material exported from
/// a fit that does not represent its data says so wherever the file goes. Unchanged for a fit that
/// represents its data.
std::string with_verdict(const std::string& text, const ModelFileVerdict& v, bool xml);

/// Refractive index with k = 0 whose normal-incidence reflectance is f0: (1 + sqrt f0) / (1 -
/// sqrt f0). Domain f0 in [0, 1); f0 = 0 gives 1.
double eta_from_f0(double f0);

/// Extinction coefficient with eta = 1 whose normal-incidence reflectance ((eta - 1)^2 + k^2) /
/// ((eta + 1)^2 + k^2) = k^2 / (4 + k^2) is f0: k = 2 sqrt(f0) / sqrt(1 - f0). Domain f0 in [0, 1);
/// values at or above 1 - 1e-8 give k = 1e4.
double k_from_f0(double f0);

}  // namespace gonio::report
