// Helpers shared by the brdf tests: a chi-square tail for the sampling tests and the message of a
// model file that does not parse.
#pragma once

#include <cmath>
#include <string>

#include "gonio/brdf/model_json.h"

namespace gonio::brdf::test_util {

/// Upper tail probability of a chi-square variable with `dof` degrees of freedom, by the
/// Wilson-Hilferty normal approximation (E. B. Wilson, M. M. Hilferty, PNAS 17, 1931): accurate to
/// a few percent of p for dof >= 30, enough for a 1e-4 rejection threshold.
inline double chi2_upper_tail(double chi2, double dof) {
    const double z = (std::cbrt(chi2 / dof) - (1 - 2 / (9 * dof))) / std::sqrt(2 / (9 * dof));
    return 0.5 * std::erfc(z / std::sqrt(2.0));
}

/// The error message of parse_model_json on `text` (named model.json), or "(parsed)".
inline std::string error_of(const std::string& text) {
    const Expected<ModelD> m = parse_model_json(text, "model.json");
    return m ? std::string("(parsed)") : m.error().message;
}

}  // namespace gonio::brdf::test_util
