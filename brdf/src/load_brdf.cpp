// load_brdf(): picks the reader from the file name.

#include <memory>
#include <string>

#include "gonio/base/strings.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {

namespace {

Expected<std::unique_ptr<Brdf>> load_model(const std::string& path) {
    Expected<ModelD> m = load_model_json(path);
    if (!m) {
        return tl::unexpected(m.error());
    }
    return std::unique_ptr<Brdf>(std::make_unique<AnalyticBrdf>(std::move(*m), path));
}

Expected<std::unique_ptr<Brdf>> load_table(const std::string& path) {
    Expected<TabulatedBrdf> t = read_table_file(path);
    if (!t) {
        return tl::unexpected(t.error());
    }
    return std::unique_ptr<Brdf>(std::make_unique<TabulatedBrdf>(std::move(*t)));
}

}  // namespace

Expected<std::unique_ptr<Brdf>> load_brdf(const std::string& path) {
    const std::string kMaterialPrefix = "material:";
    if (path.compare(0, kMaterialPrefix.size(), kMaterialPrefix) == 0) {
        Expected<ModelD> m = load_material(path.substr(kMaterialPrefix.size()));
        if (!m) {
            return tl::unexpected(m.error());
        }
        return std::unique_ptr<Brdf>(std::make_unique<AnalyticBrdf>(std::move(*m), path));
    }
    if (ends_with(path, ".json")) {
        return load_model(path);
    }
    if (is_table_path(path)) {
        return load_table(path);
    }
    if (is_rgl_path(path)) {
        Expected<RglBsdf> rgl = read_rgl_bsdf(path);
        if (!rgl) {
            return tl::unexpected(rgl.error());
        }
        return std::unique_ptr<Brdf>(std::make_unique<RglBsdf>(std::move(*rgl)));
    }
    return make_error(
        path +
        ": unknown BRDF file type (expected a model *.json or a table *.binary, "
        "*.merl, *.gtab, an RGL material *.bsdf, or material:NAME from data/materials)");
}

}  // namespace gonio::brdf
