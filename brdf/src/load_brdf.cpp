// load_brdf(): picks the reader from the file name.

#include <memory>
#include <string>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/model_json.h"

namespace gonio::brdf {

namespace {

bool has_suffix(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

Expected<std::unique_ptr<Brdf>> load_model(const std::string& path) {
    Expected<ModelD> m = load_model_json(path);
    if (!m) {
        return tl::unexpected(m.error());
    }
    return std::unique_ptr<Brdf>(std::make_unique<AnalyticBrdf>(std::move(*m), path));
}

}  // namespace

Expected<std::unique_ptr<Brdf>> load_brdf(const std::string& path) {
    if (has_suffix(path, ".json")) {
        return load_model(path);
    }
    return make_error(path + ": unknown BRDF file type (expected a model *.json)");
}

}  // namespace gonio::brdf
