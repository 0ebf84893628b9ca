#pragma once

// Small string helpers shared by every module.

#include <string_view>

namespace gonio {

/// True when s ends with suffix ("fit.json" ends with ".json"); an empty suffix always matches.
inline bool ends_with(std::string_view s, std::string_view suffix) {
    return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

/// True when s starts with prefix.
inline bool starts_with(std::string_view s, std::string_view prefix) {
    return s.size() >= prefix.size() && s.substr(0, prefix.size()) == prefix;
}

}  // namespace gonio
