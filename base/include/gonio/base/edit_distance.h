#pragma once

// Levenshtein distance between two names: the fewest insertions, deletions and substitutions of one
// character that turn one into the other. Used to suggest the closest known name in an error
// message (a material, a command).

#include <cstddef>
#include <string>

namespace gonio {

std::size_t edit_distance(const std::string& a, const std::string& b);

}  // namespace gonio
