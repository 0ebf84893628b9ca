#include "gonio/brdf/material_library.h"

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/base/data_path.h"
#include "gonio/base/edit_distance.h"
#include "gonio/brdf/model_json.h"

namespace gonio::brdf {
namespace {

Expected<nlohmann::json> read_library(const std::string& path) {
    std::ifstream in(path);
    if (!in) {
        return make_error(path + ": cannot open material library");
    }
    std::stringstream ss;
    ss << in.rdbuf();
    nlohmann::json doc = nlohmann::json::parse(ss.str(), nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded()) {
        return make_error(path + ": not valid JSON");
    }
    if (!doc.is_object() || !doc.contains("materials") || !doc["materials"].is_object()) {
        return make_error(path + ": expected an object with a \"materials\" object");
    }
    return doc;
}

}  // namespace

Expected<std::string> default_material_library() {
    return find_data_file("materials/ngan2005.json");
}

Expected<std::vector<std::string>> material_names(const std::string& library_path) {
    auto doc = read_library(library_path);
    if (!doc) {
        return tl::unexpected(doc.error());
    }
    std::vector<std::string> names;
    for (auto it = (*doc)["materials"].begin(); it != (*doc)["materials"].end(); ++it) {
        names.push_back(it.key());
    }
    return names;
}

Expected<ModelD> load_material(const std::string& name, const std::string& library_path) {
    auto doc = read_library(library_path);
    if (!doc) {
        return tl::unexpected(doc.error());
    }
    const nlohmann::json& materials = (*doc)["materials"];
    auto it = materials.find(name);
    if (it == materials.end()) {
        std::vector<std::pair<std::size_t, std::string>> close;
        for (auto m = materials.begin(); m != materials.end(); ++m) {
            close.emplace_back(edit_distance(name, m.key()), m.key());
        }
        std::sort(close.begin(), close.end());
        std::string hint;
        for (std::size_t k = 0; k < close.size() && k < 3; ++k) {
            hint += (k ? ", " : "") + close[k].second;
        }
        return make_error(library_path + ": no material \"" + name + "\" (closest: " + hint + ")");
    }
    return parse_model_json(it->dump(), library_path + ": materials." + name);
}

Expected<ModelD> load_material(const std::string& name) {
    auto lib = default_material_library();
    if (!lib) {
        return tl::unexpected(lib.error());
    }
    return load_material(name, *lib);
}

}  // namespace gonio::brdf
