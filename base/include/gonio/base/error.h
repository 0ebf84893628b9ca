#pragma once

// Expected failures (files, devices, parsing, bad data, fits that did not converge) are returned as
// values. The message names the place and the rule, e.g. "data.csv:17: theta_i = -0.3 outside [0,
// pi/2]".

#include <string>
#include <tl/expected.hpp>
#include <utility>

namespace gonio {

/// An expected failure: a message that names the place (file:line, key path, axis and register) and
/// the rule.
struct Error {
    std::string message;
};

template <class T>
using Expected = tl::expected<T, Error>;

/// Builds the unexpected value of any Expected<T>.
inline tl::unexpected<Error> make_error(std::string message) {
    return tl::unexpected<Error>(Error{std::move(message)});
}

/// Prefixes the message of an error with a context ("rig.json: " + message).
inline Error with_context(const std::string& context, Error e) {
    e.message = context + ": " + e.message;
    return e;
}

}  // namespace gonio
