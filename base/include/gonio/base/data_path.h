#pragma once

// Where gonio finds its shipped data (data/materials, data/devices, data/rigs, data/models).

#include <string>

#include "gonio/base/error.h"

namespace gonio {

/// Resolves a path under the data directory, e.g. find_data_file("materials/ngan2005.json"). Looks
/// in $GONIO_DATA_DIR first, then in the source tree's data/ the binary was built from. The error
/// lists the places tried.
Expected<std::string> find_data_file(const std::string& relative);

}  // namespace gonio
