#pragma once

// What a fit is asked to do: the model structure with starting (or fixed) values, which of its
// numbers are free, fixed or shared across the RGB channels and within which bounds, and how the
// misfit is measured (docs/fitting-guide.md).

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/model.h"

namespace gonio::fitting {

/// How one sample's misfit is measured; m = model value, d = measured value (1/sr), per channel.
enum class ResidualForm {
    kAbsolute,  ///< r = m - d.
    kRelative,  ///< r = (m - d) / (d + relative_floor).
    kLog,       ///< r = log(1 + m cos_i) - log(1 + d cos_i) (Low et al. 2012, E2).
    kCosine,    ///< r = (m - d) cos_i (cosine-weighted L2, Ngan et al. 2005).
    kCubeRoot,  ///< r = cbrt(m + eps) - cbrt(d + eps), eps = 1e-6 1/sr.
};

/// Robust loss applied to each sample's squared residual (the three channels together).
enum class LossKind {
    kNone,    ///< Plain least squares.
    kHuber,   ///< Huber loss with scale FitOptions::loss_scale.
    kCauchy,  ///< Cauchy loss with scale FitOptions::loss_scale.
};

/// A numeric field of the model that a fit may adjust.
enum class Field {
    kDiffuse,  ///< Model::diffuse (RGB).
    kAlphaX,   ///< Lobe::alpha_x (for an isotropic lobe also the implied alpha_y).
    kAlphaY,   ///< Lobe::alpha_y (anisotropic lobes only).
    /// Lobe::orientation_deg (anisotropic lobes only): the fit's scalar, its bounds and its sigma
    /// are degrees.
    kOrientation,
    kAlphaRgb,  ///< Lobe::alpha_rgb (RGB; lobes with RGB-varying roughness only).
    kExponent,  ///< Lobe::exponent (Blinn-Phong).
    kGamma,     ///< Lobe::gamma (Student-t tail parameter).
    kScale,     ///< Lobe::scale (RGB).
    kF0,        ///< Lobe::fresnel.f0 (RGB).
    kEta,       ///< Lobe::fresnel.eta (scalar).
    kEtaRgb,    ///< Lobe::fresnel.eta_rgb (RGB).
    kK,         ///< Lobe::fresnel.k (RGB).
};

/// True for the RGB fields.
bool is_rgb(Field f);
/// Path of a field in the model schema: "diffuse", "lobes[0].alpha_x", "lobes[1].fresnel.f0".
std::string field_path(Field f, int lobe);

/// The rule for one field of the model.
struct ParamSpec {
    Field field = Field::kDiffuse;
    int lobe = -1;        ///< Lobe index, -1 for the diffuse term.
    bool free = true;     ///< False: held at the template's value (not in the problem at all).
    bool shared = false;  ///< RGB fields only: one value for the three channels.
    double lower = 0;     ///< Bounds, enforced by the solver (never by clamping in the model).
    double upper = 1;
};

struct FitOptions {
    ResidualForm residual = ResidualForm::kLog;
    LossKind loss = LossKind::kNone;
    double loss_scale = 0.1;  ///< Scale of the robust loss, in residual units.
    double relative_floor =
        1e-3;                     ///< 1/sr; denominator offset of the relative residual and metric.
    std::size_t max_samples = 0;  ///< Stratified reduction to about this many samples; 0 = all.
    /// Coarse to fine: the starts and the main solve use a stratified reduction to about this
    /// many samples when the input has more than twice as many (0 = solve on all samples).
    std::size_t coarse_samples = 20000;
    /// Bound on the iterations of the polish on all samples after a reduced solve (0 = no
    /// polish: the result is that of the reduction).
    int polish_iterations = 10;
    /// Rounds of relative-noise reweighting at the model when the data carry sigmas.
    int reweight_rounds = 2;
    bool auto_init = true;   ///< Data-driven initial values (else the template's values).
    int starts = 6;          ///< Multi-start candidates over alpha (>= 1).
    std::uint64_t seed = 1;  ///< Seed of the multi-start and of the reduction.
    int max_iterations = 200;
    int num_threads = 0;           ///< 0 = number of hardware threads.
    bool use_sigma = true;         ///< Weight by 1/sigma when the dataset has sigma.
    bool covariance = true;        ///< Compute uncertainties.
    bool check_gradients = false;  ///< Ceres' own gradient check during the solve (slow; testing).
};

struct FitSpec {
    brdf::ModelD model;  ///< Structure, starting values and the values of fixed fields.
    std::vector<ParamSpec> params;
    FitOptions options;
};

/// A model named on the command line.
struct ModelOptions {
    brdf::Distribution distribution = brdf::Distribution::kGgx;
    bool diffuse = true;
    brdf::FresnelType fresnel = brdf::FresnelType::kSchlick;
    bool fresnel_rgb =
        false;  ///< Schlick only: f0 per channel ("schlick-rgb") or shared ("schlick").
    brdf::Shadowing shadowing = brdf::Shadowing::kSmithCorrelated;
    bool anisotropic = false;
    int lobes = 1;
    /// Roughness per channel ("rgb": Lobe::alpha_rgb free per channel) or one for the three
    /// ("shared", the default); isotropic ggx, beckmann and student-t lobes only.
    bool rgb_roughness = false;
};

/// Parses "ggx", "beckmann", "blinn-phong", "student-t".
Expected<brdf::Distribution> parse_distribution(const std::string& name);
/// Parses "schlick", "schlick-rgb", "dielectric", "conductor", "none" into (type, rgb).
Expected<std::pair<brdf::FresnelType, bool>> parse_fresnel(const std::string& name);
/// Parses "shared" (false) and "rgb" (true): one slope parameter for the three channels or one
/// per channel.
Expected<bool> parse_roughness(const std::string& name);
/// Parses "smith-correlated", "smith-separable", "v-groove", "none".
Expected<brdf::Shadowing> parse_shadowing(const std::string& name);
/// Parses "absolute", "relative", "log", "cosine", "cbrt".
Expected<ResidualForm> parse_residual(const std::string& name);
/// Parses "none", "huber", "cauchy".
Expected<LossKind> parse_loss(const std::string& name);
const char* to_string(ResidualForm r);
const char* to_string(LossKind l);

/// The default parameter rules for a model structure: every numeric field the structure uses is
/// free with physical bounds, except a lobe's scale when its Fresnel term carries the colour
/// (Schlick RGB, conductor), where scale stays at 1 (docs/fitting-guide.md, "Defaults"). With a
/// scalar Schlick f0 the scale is free per channel (it carries the colour).
std::vector<ParamSpec> default_params(const brdf::ModelD& model, bool fresnel_rgb);

/// Builds a spec from command-line choices (default GGX + Lambert + scalar Schlick with an RGB
/// scale).
Expected<FitSpec> make_fit_spec(const ModelOptions& options);

/// Parses a JSON fit template: {"model": <model schema>, "free": [...paths], "fixed": [...paths],
/// "shared": [...paths], "bounds": {"path": [lo, hi]}} (docs/fitting-guide.md). Errors name
/// `source` and the key path.
Expected<FitSpec> parse_fit_template(const std::string& json_text, const std::string& source);
Expected<FitSpec> load_fit_template(const std::string& path);

}  // namespace gonio::fitting
