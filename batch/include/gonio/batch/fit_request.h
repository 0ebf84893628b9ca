#pragma once

// A fit named by a few options, as `gonio fit` flags, a manifest's options column and
// gonio.fit() keywords name it: the model structure (or a JSON fit template) and the solver
// options. make_fit_spec() turns it into the fitting library's FitSpec.

#include <cstddef>
#include <cstdint>
#include <string>

#include "gonio/brdf/error.h"
#include "gonio/fitting/spec.h"

namespace gonio::batch {

struct FitRequest {
    std::string model = "ggx";  ///< ggx, beckmann, blinn-phong, or a template *.json path.
    std::string fresnel = "schlick-rgb";  ///< schlick, schlick-rgb, dielectric, conductor, none.
    std::string shadowing = "smith-correlated";
    bool diffuse = true;
    bool anisotropic = false;
    int lobes = 1;
    std::string residual = "log";  ///< absolute, relative, log, cosine, cbrt.
    std::string loss = "none";     ///< none, huber, cauchy.
    double loss_scale = 0.1;
    std::size_t max_samples = 0;  ///< Stratified reduction to about this many samples; 0 = all.
    int starts = 6;
    std::uint64_t seed = 1;
    int max_iterations = 200;
    int threads = 0;  ///< Solver threads; 0 = all cores.
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
