#pragma once

// Where gonio finds its shipped data (materials/, devices/, rigs/, models/, scenes/).

#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio {

/// Resolves a path under the data directory, e.g. find_data_file("materials/ngan2005.json").
/// Looks, in order:
///  1. beside the installed program: the data folder of the install (share/gonio) reached from the
///     folder of the binary that holds this code (the executable, or the Python module), along the
///     relative paths of the install layout (bin/, libexec/gonio/, the Python package folder);
///  2. in $GONIO_DATA_DIR;
///  3. only for a binary inside a build tree (a CMakeCache.txt of this project in its folder or up
///     to three folders above): the source tree's data/ that the cache names.
/// No path of the build is compiled in, so an installed tree works wherever it is moved. The error
/// lists the places tried.
Expected<std::string> find_data_file(const std::string& relative);

/// The folders find_data_file looks in, in its order (existing or not), each with what it is.
struct DataDirCandidate {
    std::string dir;
    std::string origin;  ///< "install", "$GONIO_DATA_DIR" or "build tree"
};
std::vector<DataDirCandidate> data_dir_candidates();

/// The folder of the binary that holds this code: the shared object (the Python module) when the
/// code was loaded as one, else the executable (/proc/self/exe). Empty if neither can be read.
std::string binary_dir();

/// The source data/ named by the CMakeCache.txt of a gonio build tree found in `dir` or up to
/// three folders above it; empty when there is none.
std::string build_tree_data_dir(const std::string& dir);

}  // namespace gonio
