#pragma once

// Checks of command-line values shared by the commands. A value that fails is a usage error
// (exit status 2, see main.cpp): the message names the option, the value and the allowed range.

#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <string>

#include "gonio/base/limits.h"

namespace gonio::tools {

namespace detail {

/// A finite number whose rule `ok` states; `rule` says it as people write it ("> 0",
/// "in [0.001, 1]").
inline CLI::Validator finite_where(std::function<bool(double)> ok, const std::string& rule) {
    return CLI::Validator(
        [ok, rule](std::string& text) -> std::string {
            char* end = nullptr;
            errno = 0;
            const double v = std::strtod(text.c_str(), &end);
            if (end == text.c_str() || *end != '\0') {
                return "\"" + text.substr(0, 64) + "\" is not a number";
            }
            if (!std::isfinite(v) || errno == ERANGE) {
                return text.substr(0, 64) + " is not a finite number; it must be " + rule;
            }
            if (!ok(v)) {
                return show_number(v) + ": must be " + rule;
            }
            return {};
        },
        rule);
}

}  // namespace detail

/// A finite number in [lo, hi] (NaN and infinities refused; CLI::Range lets NaN through).
inline CLI::Validator finite_in(double lo, double hi, const std::string& unit = "") {
    return detail::finite_where(
        [lo, hi](double v) { return v >= lo && v <= hi; },
        "in [" + show_number(lo) + ", " + show_number(hi) + "]" + (unit.empty() ? "" : " " + unit));
}

/// A finite number > lo.
inline CLI::Validator finite_above(double lo) {
    return detail::finite_where([lo](double v) { return v > lo; }, "> " + show_number(lo));
}

/// A finite number >= lo.
inline CLI::Validator finite_at_least(double lo) {
    return detail::finite_where([lo](double v) { return v >= lo; }, ">= " + show_number(lo));
}

/// A whole number >= lo (no upper bound beyond the type's).
inline CLI::Validator integer_at_least(long long lo) {
    const std::string rule = ">= " + std::to_string(lo);
    return CLI::Validator(
        [lo, rule](std::string& text) -> std::string {
            char* end = nullptr;
            errno = 0;
            const long long v = std::strtoll(text.c_str(), &end, 10);
            if (end == text.c_str() || *end != '\0') {
                return "\"" + text.substr(0, 64) + "\" is not a whole number";
            }
            if (errno == ERANGE || v < lo || v > std::numeric_limits<int>::max()) {
                return text.substr(0, 64) + ": must be a whole number " + rule;
            }
            return {};
        },
        rule);
}

/// A whole number in [lo, hi].
inline CLI::Validator integer_in(long long lo, long long hi) {
    const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return CLI::Validator(
        [lo, hi, range](std::string& text) -> std::string {
            char* end = nullptr;
            errno = 0;
            const long long v = std::strtoll(text.c_str(), &end, 10);
            if (end == text.c_str() || *end != '\0') {
                return "\"" + text.substr(0, 64) + "\" is not a whole number";
            }
            if (errno == ERANGE || v < lo || v > hi) {
                return text.substr(0, 64) + " is outside " + range;
            }
            return {};
        },
        "in " + range);
}

/// What an input named on the command line must be.
enum class InputKind {
    kFile,    ///< a file to read (a BRDF argument's material:NAME and "-", standard input, pass)
    kFolder,  ///< a folder to read (a campaign folder)
};

/// An input named on the command line (a dataset, a model, a table, a description, a campaign
/// folder): one that does not exist or cannot be read is a usage error, exit status 2 before any
/// work, with the path and why. What its content holds is the work's to judge (exit status 1).
inline CLI::Validator readable_input(InputKind kind = InputKind::kFile) {
    return CLI::Validator(
        [kind](std::string& path) -> std::string {
            if (kind == InputKind::kFile && (path == "-" || path.rfind("material:", 0) == 0)) {
                return {};
            }
            // Worded as the readers word it (PATH: cannot open: REASON), so that the command line
            // and Python say the same.
            struct stat st {};
            if (path.empty()) {
                return "empty path (an input named on the command line must exist)";
            }
            if (::stat(path.c_str(), &st) != 0) {
                return path + ": cannot open: " + std::strerror(errno);
            }
            const bool folder = S_ISDIR(st.st_mode);
            if (kind == InputKind::kFile && folder) {
                return path + ": is a folder, not a file";
            }
            if (kind == InputKind::kFolder && !folder) {
                return path + ": not a folder";
            }
            if (::access(path.c_str(), folder ? (R_OK | X_OK) : R_OK) != 0) {
                return path + ": cannot open: " + std::strerror(errno);
            }
            return {};
        },
        "");
}

/// Prints "gonio CMD: MESSAGE" and returns the usage-error status 2.
inline int usage_error(const char* command, const std::string& message) {
    std::fprintf(stderr, "gonio %s: %s\n", command, message.c_str());
    return 2;
}

}  // namespace gonio::tools
