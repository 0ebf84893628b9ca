// Fuzz target for the fit template reader (fitting::parse_fit_template): a model plus free, fixed,
// shared parameter paths and bounds. Properties: a failure names the source and leaks no
// internals; a success has finite bounds, lower below upper, and a model within the model limits.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/base/limits.h"
#include "gonio/fitting/spec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    gonio::Expected<gonio::fitting::FitSpec> s =
        gonio::fitting::parse_fit_template(text, "template.json");
    if (!s) {
        gonio::fuzz::check_message("fit_template", s.error().message, "template.json", data, size);
        return 0;
    }
    gonio::fuzz::require(
        s->model.lobes.size() <= gonio::kMaxModelLobes, "fit_template", "lobe limit");
    for (const auto& p : s->params) {
        gonio::fuzz::require(!(p.lower >= p.upper), "fit_template", "lower below upper");
        gonio::fuzz::require(
            !std::isnan(p.lower) && !std::isnan(p.upper), "fit_template", "bounds are numbers");
    }
    return 0;
}
