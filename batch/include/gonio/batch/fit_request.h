#pragma once

// A fit named by a few options, as `gonio fit` flags, a manifest's options column and
// gonio.fit() keywords name it: the model structure (a distribution, `auto`, or a JSON fit
// template) and the solver options. Every front end fills one FitRequest, checks it with
// find_conflict() and runs it with run_fit(); make_fit_spec() is the one builder of the fitting
// library's FitSpec.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"

namespace gonio::batch {

/// The defaults of the fitting library (fitting::ModelOptions, fitting::FitOptions) as option
/// values, so that an entry without options fits exactly as `gonio fit DATA` does.
std::string default_distribution();
std::string default_fresnel();
std::string default_shadowing();

/// The model name that picks the structure itself (candidates ranked by BIC, the winner polished).
inline constexpr const char* kAutoModel = "auto";

struct FitRequest {
    std::string model =
        default_distribution();  ///< ggx, beckmann, blinn-phong, auto, or a *.json template.
    /// A fit template given inline (JSON text); when not empty it takes the place of `model`.
    std::string template_json;
    std::string fresnel =
        default_fresnel();  ///< schlick, schlick-rgb, dielectric, conductor, none.
    std::string shadowing =
        default_shadowing();  ///< smith-correlated, smith-separable, v-groove, none.
    bool diffuse = fitting::ModelOptions{}.diffuse;
    bool anisotropic = fitting::ModelOptions{}.anisotropic;
    int lobes = fitting::ModelOptions{}.lobes;
    /// shared (one slope parameter for the three channels) or rgb (one per channel).
    std::string roughness = fitting::ModelOptions{}.rgb_roughness ? "rgb" : "shared";
    std::string residual = fitting::to_string(
        fitting::FitOptions{}.residual);  ///< absolute, relative, log, cosine, cbrt.
    std::string loss = fitting::to_string(fitting::FitOptions{}.loss);  ///< none, huber, cauchy.
    double loss_scale = fitting::FitOptions{}.loss_scale;
    std::size_t max_samples =
        fitting::FitOptions{}.max_samples;  ///< Stratified reduction; 0 = all.
    int starts = fitting::FitOptions{}.starts;
    std::uint64_t seed = fitting::FitOptions{}.seed;
    int max_iterations = fitting::FitOptions{}.max_iterations;
    int threads = fitting::FitOptions{}.num_threads;  ///< Solver threads; 0 = all cores.
    /// The options set by name through set_option() (canonical keys, '_' spelling), so that a
    /// choice the model makes itself can be told apart from one the caller asked for.
    std::vector<std::string> given;

    bool is_auto() const { return template_json.empty() && model == kAutoModel; }
    bool is_template() const;
    bool was_given(const std::string& key) const;
};

/// Two options of a request that cannot be honoured together (keys as set_option() names them).
struct OptionConflict {
    std::string option;  ///< The option the caller set ("fresnel", "lobes", ...).
    std::string with;    ///< What it conflicts with ("model" for auto or a template).
    std::string rule;    ///< Why, in a few words.
};

/// The structure options (fresnel, shadowing, diffuse, anisotropic, lobes, roughness) given with
/// model = auto (which chooses the structure) or with a fit template (which states it).
std::optional<OptionConflict> find_conflict(const FitRequest& request);

/// Sets one option by name, as written in a manifest ("residual", "max_samples", "diffuse", ...;
/// a '-' in the name counts as '_'). Booleans take true/false/1/0/yes/no. The error names the key,
/// the value and the rule.
Expected<void> set_option(FitRequest& request, const std::string& key, const std::string& value);

/// Parses "key=value;key=value" (whitespace around items ignored, empty string = no option).
Expected<void> set_options(FitRequest& request, const std::string& options);

/// The request in the option syntax of set_options() (every option, defaults included).
std::string format_options(const FitRequest& request);

/// The fit spec: the inline template, or a template file when `model` ends in ".json"
/// (load_fit_template), else the structure from model/fresnel/shadowing/diffuse/anisotropic/
/// lobes; then the solver options. For model = auto: the spec of the default distribution, whose
/// solver options the candidates share.
Expected<fitting::FitSpec> make_fit_spec(const FitRequest& request);

/// What run_fit() did.
struct FitRun {
    fitting::FitResult result;  ///< The fit (for auto: the winner, polished on all samples).
    /// For model = auto: the candidates ranked (best first), the winner's name and the criterion.
    std::vector<fitting::RankedModel> ranking;
    std::string chosen;
    std::string criterion;
};

/// The one way every front end runs a request: refuses a conflict (find_conflict), builds the
/// spec and fits (for auto: fitting::fit_auto over fitting::auto_candidates with the request's
/// solver options).
Expected<FitRun> run_fit(const brdf::Dataset& data, const FitRequest& request);

}  // namespace gonio::batch
