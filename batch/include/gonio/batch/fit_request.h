#pragma once

// A fit named by a few options, as `gonio fit` flags, a manifest's options column and
// gonio.fit() keywords name it: the model structure (or a JSON fit template) and the solver
// options. make_fit_spec() turns it into the fitting library's FitSpec.

#include <cstddef>
#include <cstdint>
#include <string>

#include "gonio/base/error.h"
#include "gonio/fitting/spec.h"

namespace gonio::batch {

/// The defaults of the fitting library (fitting::ModelOptions, fitting::FitOptions) as option
/// values, so that an entry without options fits exactly as `gonio fit DATA` does.
std::string default_distribution();
std::string default_fresnel();
std::string default_shadowing();

struct FitRequest {
    std::string model =
        default_distribution();  ///< ggx, beckmann, blinn-phong, or a *.json template.
    std::string fresnel =
        default_fresnel();  ///< schlick, schlick-rgb, dielectric, conductor, none.
    std::string shadowing =
        default_shadowing();  ///< smith-correlated, smith-separable, v-groove, none.
    bool diffuse = fitting::ModelOptions{}.diffuse;
    bool anisotropic = fitting::ModelOptions{}.anisotropic;
    int lobes = fitting::ModelOptions{}.lobes;
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
};

/// Sets one option by name, as written in a manifest ("residual", "max_samples", "diffuse", ...;
/// a '-' in the name counts as '_'). Booleans take true/false/1/0/yes/no. The error names the key,
/// the value and the rule.
Expected<void> set_option(FitRequest& request, const std::string& key, const std::string& value);

/// Parses "key=value;key=value" (whitespace around items ignored, empty string = no option).
Expected<void> set_options(FitRequest& request, const std::string& options);

/// The request in the option syntax of set_options() (every option, defaults included).
std::string format_options(const FitRequest& request);

/// The fit spec: a template when `model` ends in ".json" (load_fit_template), else the structure
/// from model/fresnel/shadowing/diffuse/anisotropic/lobes; then the solver options.
Expected<fitting::FitSpec> make_fit_spec(const FitRequest& request);

}  // namespace gonio::batch
