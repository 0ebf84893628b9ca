#pragma once

// Small string helpers shared by every module.

#include <cstddef>
#include <string>
#include <string_view>

namespace gonio {

/// True when s ends with suffix ("fit.json" ends with ".json"); an empty suffix always matches.
inline bool ends_with(std::string_view s, std::string_view suffix) {
    return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

/// s without its leading and trailing spaces, tabs, carriage returns and line feeds (a field of a
/// CSV line or manifest, a key of an option).
inline std::string trim(std::string_view s) {
    const auto b = s.find_first_not_of(" \t\r\n");
    if (b == std::string_view::npos) {
        return {};
    }
    const auto e = s.find_last_not_of(" \t\r\n");
    return std::string(s.substr(b, e - b + 1));
}

/// True when s starts with prefix.
inline bool starts_with(std::string_view s, std::string_view prefix) {
    return s.size() >= prefix.size() && s.substr(0, prefix.size()) == prefix;
}

/// Longest quote of an input that a message carries (excerpt's default).
inline constexpr std::size_t kMaxQuote = 32;

/// A piece of input as an error message quotes it: at most max_bytes of it, then "... (N bytes)"
/// when it is longer, so that a message about a megabyte-long column name or key stays short.
/// Control bytes and bytes that are not UTF-8 are written \xHH (a NUL would end the message where
/// it is printed as a C string); a UTF-8 character is kept whole or left out whole.
inline std::string excerpt(std::string_view s, std::size_t max_bytes = kMaxQuote) {
    std::string out;
    std::size_t i = 0;
    while (i < s.size() && i < max_bytes) {
        const auto c = static_cast<unsigned char>(s[i]);
        if (c >= 0x20 && c < 0x7F) {
            out += static_cast<char>(c);
            ++i;
            continue;
        }
        const std::size_t len = c >= 0xC2 && c <= 0xDF   ? 2
                                : c >= 0xE0 && c <= 0xEF ? 3
                                : c >= 0xF0 && c <= 0xF4 ? 4
                                                         : 0;
        bool utf8 = len > 0 && i + len <= s.size();
        for (std::size_t k = 1; utf8 && k < len; ++k) {
            utf8 = (static_cast<unsigned char>(s[i + k]) & 0xC0u) == 0x80u;
        }
        if (utf8) {
            if (i + len > max_bytes) {
                break;
            }
            out.append(s.substr(i, len));
            i += len;
            continue;
        }
        static const char* const kHex = "0123456789ABCDEF";
        out += "\\x";
        out += kHex[c >> 4];
        out += kHex[c & 0xF];
        ++i;
    }
    if (i < s.size()) {
        out += "... (" + std::to_string(s.size()) + " bytes)";
    }
    return out;
}

/// The text of a nlohmann::json exception as an error message shows it: without its
/// "[json.exception.<kind>.<id>] " code (a library detail), and with the input it quotes after
/// "last read: '" or "number overflow parsing '" cut by excerpt (the token can be the whole rest of
/// a large file).
inline std::string json_error_text(std::string_view what) {
    std::string s(what);
    if (starts_with(s, "[json.exception.")) {
        if (const auto pos = s.find("] "); pos != std::string::npos) {
            s = s.substr(pos + 2);
        }
    }
    // Syntax errors quote after "last read: '", numbers out of range after "number overflow
    // parsing '".
    std::string_view key = "last read: '";
    auto at = s.find(key);
    if (at == std::string::npos) {
        key = "number overflow parsing '";
        at = s.find(key);
    }
    if (at == std::string::npos) {
        return s;
    }
    const std::size_t begin = at + key.size();
    // The quote ends at the last "'". nlohmann may follow it with "; expected <what>", a short
    // phrase of its own (at most 48 bytes here); a "'; expected" further from the end is part of
    // the quoted input.
    std::size_t end = s.rfind("'; expected ");
    if (end == std::string::npos || end < begin || s.size() - end > 48) {
        end = s.size() >= begin + 1 && s.back() == '\'' ? s.size() - 1 : std::string::npos;
    }
    if (end == std::string::npos || end < begin) {
        return s.substr(0, begin) + excerpt(std::string_view(s).substr(begin));
    }
    return s.substr(0, begin) + excerpt(std::string_view(s).substr(begin, end - begin)) +
           s.substr(end);
}

}  // namespace gonio
