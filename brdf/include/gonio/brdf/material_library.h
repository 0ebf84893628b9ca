#pragma once

// Named real materials: data/materials/ngan2005.json (86 published fits of MERL materials, in the
// model schema; source and licence in data/materials/README.md).

#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/model.h"

namespace gonio::brdf {

/// The default library file (found with find_data_file).
Expected<std::string> default_material_library();

/// Names of the materials in a library file, in file order.
Expected<std::vector<std::string>> material_names(const std::string& library_path);

/// One material's model. Unknown names give an error that lists a few close names.
Expected<ModelD> load_material(const std::string& name, const std::string& library_path);

/// load_material from the default library.
Expected<ModelD> load_material(const std::string& name);

}  // namespace gonio::brdf
