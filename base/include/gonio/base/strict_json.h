#pragma once

// Strict reading of the project's JSON files (model, campaign, scene, rig, camera model): every key
// is known, every value has the expected type, every number is finite and inside a documented range
// before it is cast, every string has a bounded length, and a message names the file, the key path,
// the value and the rule: "campaign.json: plan.n_theta = 2.5: must be a whole number in [2, 500]",
// "model.json: lobes[0].alhpa: unknown key (allowed here: distribution, alpha, ...)".
//
// The checks report the first problem by throwing a JsonFailure; read_strict_json() runs a reading
// function, catches it (and nlohmann's own exceptions) and returns an Expected, so the exception
// never leaves the reading function's module. Keys are listed, in "allowed here", in the order the
// reader names them (the schema's order).

#include <cstddef>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/base/strings.h"

namespace gonio {

/// The first problem of a document being read; caught by read_strict_json().
struct JsonFailure {
    std::string message;
};

/// Ends the reading with `message` (a key path and the rule; read_strict_json() adds the file).
[[noreturn]] void json_fail(const std::string& message);

/// "object", "array", "string", "boolean", "null" or "number".
std::string json_type(const nlohmann::json& j);

/// "plan.n_theta" from "plan" and "n_theta"; the key alone at the top level. A key from the input
/// is quoted through excerpt() (at most kMaxQuote bytes).
std::string json_key_path(const std::string& parent, const std::string& key);

/// Parses text after the size and depth checks (check_json_text); a syntax error names the line and
/// column without nlohmann's exception code.
nlohmann::json parse_json_checked(const std::string& text, const std::string& source);

/// The keys of `obj` at `path` must be among `allowed`; the first other key fails with the list.
/// `obj` must be an object.
void check_json_keys(const nlohmann::json& obj,
                     const std::string& path,
                     const std::vector<std::string>& allowed);

/// One JSON object being read: each accessor names the key it reads, finish() refuses the keys
/// nobody asked for.
class JsonObject {
  public:
    /// `path` is the object's key path ("" at the top level); `j` must be an object.
    JsonObject(const nlohmann::json& j, std::string path);

    /// Whether the key is present (and marks it as known).
    bool has(const char* key);
    /// The value of a key that must be present.
    const nlohmann::json& raw(const char* key);
    /// The value of a key when present, nullptr otherwise (marks it as known).
    const nlohmann::json* find(const char* key);

    /// A string of at most max_len bytes without control characters (tab allowed).
    std::string string(const char* key, const std::string& fallback, std::size_t max_len);
    /// A finite number in [lo, hi]; `unit` is written after the range.
    double number(const char* key, double fallback, double lo, double hi, const char* unit = "");
    /// A whole number in [lo, hi], checked as a double before the cast (1e20 is refused, never
    /// wrapped).
    int integer(const char* key, int fallback, int lo, int hi);
    bool boolean(const char* key, bool fallback);

    /// Marks keys as known without reading them (read elsewhere, or ignored by rule).
    void allow(std::initializer_list<const char*> keys);
    /// Fails on the first key that no accessor named.
    void finish() const;

    /// The key path of a key of this object.
    std::string key_path(const std::string& key) const { return json_key_path(path_, key); }
    /// The object's path, "top level" at the top.
    std::string where() const { return path_.empty() ? std::string("top level") : path_; }

  private:
    void mark(const char* key);

    const nlohmann::json& j_;
    std::string path_;
    std::vector<std::string> asked_;
};

/// Requires an object at `path` ("top level" when empty).
void require_json_object(const nlohmann::json& j, const std::string& path);

/// The value of a key of `obj` (at `path`) that must be present.
const nlohmann::json& json_member(const nlohmann::json& obj,
                                  const std::string& path,
                                  const char* key);

/// A string value at `path`.
std::string json_string_at(const nlohmann::json& j, const std::string& path);

/// A finite number at `path`.
double json_number_at(const nlohmann::json& j, const std::string& path);

/// Runs `read` (which throws JsonFailure or nlohmann's exceptions on the first problem) and returns
/// its value, or an error whose message starts with `source` (added unless the message already
/// names it).
template <class F>
auto read_strict_json(const std::string& source, F&& read) -> Expected<decltype(read())> {
    std::string message;
    try {
        if constexpr (std::is_void_v<decltype(read())>) {
            read();
            return {};
        } else {
            return read();
        }
    } catch (const JsonFailure& f) {
        message = f.message;
    } catch (const nlohmann::json::exception& e) {
        message = json_error_text(e.what());
    }
    const bool named = message.compare(0, source.size(), source) == 0;
    return make_error(named ? message : source + ": " + message);
}

}  // namespace gonio
