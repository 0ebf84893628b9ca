#include "gonio/base/strict_json.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/limits.h"

namespace gonio {

void json_fail(const std::string& message) {
    throw JsonFailure{message};
}

std::string json_type(const nlohmann::json& j) {
    return j.is_number() ? std::string("number") : std::string(j.type_name());
}

std::string json_key_path(const std::string& parent, const std::string& key) {
    const std::string k = excerpt(key);
    return parent.empty() ? k : parent + "." + k;
}

nlohmann::json parse_json_checked(const std::string& text, const std::string& source) {
    if (auto ok = check_json_text(text, source); !ok) {
        json_fail(ok.error().message);
    }
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        // Syntax errors and numbers out of the double range: "parse error at line 1, column 2:
        // ..." without nlohmann's "[json.exception.parse_error.101]" code.
        json_fail(source + ": " + json_error_text(e.what()));
    }
}

namespace {

std::string list_keys(const std::vector<std::string>& keys) {
    std::string out;
    for (const std::string& k : keys) {
        out += out.empty() ? "" : ", ";
        out += k;
    }
    return out;
}

}  // namespace

void check_json_keys(const nlohmann::json& obj,
                     const std::string& path,
                     const std::vector<std::string>& allowed) {
    require_json_object(obj, path);
    for (auto it = obj.begin(); it != obj.end(); ++it) {
        if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end()) {
            json_fail(json_key_path(path, it.key()) +
                      ": unknown key (allowed here: " + list_keys(allowed) + ")");
        }
    }
}

void require_json_object(const nlohmann::json& j, const std::string& path) {
    if (!j.is_object()) {
        json_fail((path.empty() ? std::string("top level") : path) + ": expected an object, got " +
                  json_type(j));
    }
}

const nlohmann::json& json_member(const nlohmann::json& obj,
                                  const std::string& path,
                                  const char* key) {
    auto it = obj.find(key);
    if (it == obj.end()) {
        json_fail((path.empty() ? std::string("top level") : path) + ": missing key \"" + key +
                  "\"");
    }
    return *it;
}

std::string json_string_at(const nlohmann::json& j, const std::string& path) {
    if (!j.is_string()) {
        json_fail(path + ": expected a string, got " + json_type(j));
    }
    return j.get<std::string>();
}

double json_number_at(const nlohmann::json& j, const std::string& path) {
    if (!j.is_number()) {
        json_fail(path + ": expected a number, got " + json_type(j));
    }
    const double v = j.get<double>();
    if (!std::isfinite(v)) {
        json_fail(path + " = " + show_number(v) + ": must be finite");
    }
    return v;
}

JsonObject::JsonObject(const nlohmann::json& j, std::string path) : j_(j), path_(std::move(path)) {
    require_json_object(j_, path_);
}

void JsonObject::mark(const char* key) {
    if (std::find(asked_.begin(), asked_.end(), key) == asked_.end()) {
        asked_.emplace_back(key);
    }
}

bool JsonObject::has(const char* key) {
    mark(key);
    return j_.contains(key);
}

const nlohmann::json& JsonObject::raw(const char* key) {
    mark(key);
    return json_member(j_, path_, key);
}

const nlohmann::json* JsonObject::find(const char* key) {
    mark(key);
    auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
}

std::string JsonObject::string(const char* key, const std::string& fallback, std::size_t max_len) {
    const nlohmann::json* v = find(key);
    if (v == nullptr) {
        return fallback;
    }
    if (!v->is_string()) {
        json_fail(key_path(key) + ": expected a string, got " + json_type(*v));
    }
    std::string s = v->get<std::string>();
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

double JsonObject::number(
    const char* key, double fallback, double lo, double hi, const char* unit) {
    const nlohmann::json* v = find(key);
    if (v == nullptr) {
        return fallback;
    }
    if (!v->is_number()) {
        json_fail(key_path(key) + ": expected a number, got " + json_type(*v));
    }
    const double x = v->get<double>();
    if (!std::isfinite(x) || x < lo || x > hi) {
        json_fail(key_path(key) + " = " + show_number(x) + ": must be in [" + show_number(lo) +
                  ", " + show_number(hi) + "]" + (*unit ? std::string(" ") + unit : ""));
    }
    return x;
}

int JsonObject::integer(const char* key, int fallback, int lo, int hi) {
    const nlohmann::json* v = find(key);
    if (v == nullptr) {
        return fallback;
    }
    if (!v->is_number()) {
        json_fail(key_path(key) + ": expected a whole number, got " + json_type(*v));
    }
    const double x = v->get<double>();
    if (!std::isfinite(x) || x != std::floor(x) || x < lo || x > hi) {
        json_fail(key_path(key) + " = " + show_number(x) + ": must be a whole number in [" +
                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return static_cast<int>(x);
}

bool JsonObject::boolean(const char* key, bool fallback) {
    const nlohmann::json* v = find(key);
    if (v == nullptr) {
        return fallback;
    }
    if (!v->is_boolean()) {
        json_fail(key_path(key) + ": expected true or false, got " + json_type(*v));
    }
    return v->get<bool>();
}

void JsonObject::allow(std::initializer_list<const char*> keys) {
    for (const char* k : keys) {
        mark(k);
    }
}

void JsonObject::finish() const {
    check_json_keys(j_, path_, asked_);
}

}  // namespace gonio
