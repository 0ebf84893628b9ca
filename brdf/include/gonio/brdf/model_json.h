#pragma once

// Reading and writing analytic models as JSON (schema: docs/model-schema.md). Example:
//   {"diffuse": [0.1, 0.1, 0.1],
//    "lobes": [{"distribution": "ggx", "alpha": 0.2, "shadowing": "smith-correlated",
//               "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]}
// Unknown keys, missing keys, wrong types and out-of-domain values are rejected with the key path
// and the rule: "model.json: lobes[0].alpha = -0.1: must be > 0".

#include <nlohmann/json.hpp>
#include <string>

#include "gonio/base/error.h"
#include "gonio/brdf/model.h"

namespace gonio::brdf {

/// Parses a model from JSON text; source_name prefixes every message (a file name or "<stdin>").
Expected<ModelD> parse_model_json(const std::string& text, const std::string& source_name);

/// Reads a model from a parsed JSON value whose key path is `path` ("" for a model file, "model"
/// inside a fit template), so that messages name "model.lobes[0].alpha". On the first problem it
/// throws gonio::JsonFailure: call it inside gonio::read_strict_json (base/strict_json.h).
ModelD read_model_json(const nlohmann::json& j, const std::string& path);

/// Reads and parses a model file; the error names the path.
Expected<ModelD> load_model_json(const std::string& path);

/// Pretty JSON (4-space indent) of a model. Numbers are written with the shortest representation
/// that reads back to the same double, so parse_model_json(model_to_json(m)) == m exactly.
/// A conductor is written with its numeric eta and k (the material name is not kept).
/// `fit_verdict`, when not empty, is the JSON text of an object written under the key "fit" (the
/// verdict of the fit that produced the model; parse_model_json accepts and ignores it).
std::string model_to_json(const ModelD& m, const std::string& fit_verdict = "");

/// One line summary: "diffuse [0.1 0.1 0.1] + ggx(alpha 0.2, smith-correlated, schlick)".
std::string describe_model(const ModelD& m);

}  // namespace gonio::brdf
