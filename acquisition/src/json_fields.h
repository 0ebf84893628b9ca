#pragma once

// Strict reading of the acquisition's JSON files (campaign, scene, rig): every key is known, every
// number is finite and inside a documented range before it is cast, every string has a bounded
// length, and a message names the file, the key path, the value and the allowed range. Internal to
// the module: a JsonFailure never crosses its boundary (the parse functions catch it).

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "gonio/base/limits.h"
#include "gonio/base/strings.h"

namespace gonio::acquisition::detail {

struct JsonFailure {
    std::string message;
};

[[noreturn]] inline void json_fail(const std::string& message) {
    throw JsonFailure{message};
}

inline std::string json_type(const nlohmann::json& j) {
    return j.is_number() ? std::string("number") : std::string(j.type_name());
}

/// nlohmann's message without its "[json.exception.type_error.302] " code.
inline std::string json_error_text(const char* what) {
    return gonio::json_error_text(what);
}

/// Parses text after the size and depth checks; a syntax error names the line and column.
inline nlohmann::json parse_json_checked(const std::string& text, const std::string& source) {
    if (auto ok = check_json_text(text, source); !ok) {
        json_fail(ok.error().message);
    }
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        // "[json.exception.parse_error.101] parse error at line 1, column 2: ..." -> from "parse".
        json_fail(source + ": " + gonio::json_error_text(e.what()));
    }
}

/// One JSON object being read; finish() rejects the keys nobody asked for.
class JsonFields {
  public:
    JsonFields(const nlohmann::json& j, std::string path) : j_(j), path_(std::move(path)) {
        if (!j_.is_object()) {
            json_fail(where() + ": expected an object, got " + json_type(j_));
        }
    }

    bool has(const char* key) {
        seen_.insert(key);
        return j_.contains(key);
    }

    /// The value of a key that must be present.
    const nlohmann::json& raw(const char* key) {
        seen_.insert(key);
        auto it = j_.find(key);
        if (it == j_.end()) {
            json_fail(where() + ": missing key \"" + key + "\"");
        }
        return *it;
    }

    std::string key_path(const char* key) const {
        return path_.empty() ? std::string(key) : path_ + "." + key;
    }

    std::string string(const char* key, const std::string& fallback, std::size_t max_len) {
        if (!has(key)) {
            return fallback;
        }
        const nlohmann::json& v = j_.at(key);
        if (!v.is_string()) {
            json_fail(key_path(key) + ": expected a string, got " + json_type(v));
        }
        std::string s = v.get<std::string>();
        if (s.size() > max_len) {
            json_fail(key_path(key) + ": " + std::to_string(s.size()) + " characters, at most " +
                      std::to_string(max_len) + " allowed");
        }
        for (unsigned char c : s) {
            if (c < 0x20 && c != '\t') {
                json_fail(key_path(key) + ": control characters (line breaks, ...) not allowed");
            }
        }
        return s;
    }

    double number(const char* key, double fallback, double lo, double hi, const char* unit = "") {
        if (!has(key)) {
            return fallback;
        }
        const nlohmann::json& v = j_.at(key);
        if (!v.is_number()) {
            json_fail(key_path(key) + ": expected a number, got " + json_type(v));
        }
        const double x = v.get<double>();
        if (!std::isfinite(x) || x < lo || x > hi) {
            json_fail(key_path(key) + " = " + show_number(x) + ": must be in [" + show_number(lo) +
                      ", " + show_number(hi) + "]" + (*unit ? std::string(" ") + unit : ""));
        }
        return x;
    }

    /// A whole number in [lo, hi], checked as a double before the cast (1e20 is refused, never
    /// wrapped).
    int integer(const char* key, int fallback, int lo, int hi) {
        if (!has(key)) {
            return fallback;
        }
        const nlohmann::json& v = j_.at(key);
        if (!v.is_number()) {
            json_fail(key_path(key) + ": expected a whole number, got " + json_type(v));
        }
        const double x = v.get<double>();
        if (!std::isfinite(x) || x != std::floor(x) || x < lo || x > hi) {
            json_fail(key_path(key) + " = " + show_number(x) + ": must be a whole number in [" +
                      std::to_string(lo) + ", " + std::to_string(hi) + "]");
        }
        return static_cast<int>(x);
    }

    bool boolean(const char* key, bool fallback) {
        if (!has(key)) {
            return fallback;
        }
        const nlohmann::json& v = j_.at(key);
        if (!v.is_boolean()) {
            json_fail(key_path(key) + ": expected true or false, got " + json_type(v));
        }
        return v.get<bool>();
    }

    void finish() const {
        for (auto it = j_.begin(); it != j_.end(); ++it) {
            if (seen_.count(it.key()) == 0) {
                std::string allowed;
                for (const std::string& k : seen_) {
                    allowed += allowed.empty() ? "" : ", ";
                    allowed += k;
                }
                json_fail(key_path(it.key().substr(0, 64).c_str()) +
                          ": unknown key (allowed here: " + allowed + ")");
            }
        }
    }

    std::string where() const { return path_.empty() ? std::string("top level") : path_; }

  private:
    const nlohmann::json& j_;
    std::string path_;
    std::set<std::string> seen_;
};

}  // namespace gonio::acquisition::detail
