#pragma once

// Command-line errors as the commands print them: "gonio CMD: MESSAGE", with a suggestion for a
// mistyped option ("--modle: unknown option; did you mean --model?").

#include <CLI/CLI.hpp>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/base/edit_distance.h"

namespace gonio::tools {

/// The deepest subcommand the parser entered, and its name path ("camera capture").
inline CLI::App* deepest_command(CLI::App& app, std::string& path) {
    CLI::App* at = &app;
    for (;;) {
        std::vector<CLI::App*> subs = at->get_subcommands();
        if (subs.empty()) {
            return at;
        }
        at = subs.front();
        path += path.empty() ? at->get_name() : " " + at->get_name();
    }
}

/// The closest option name of `command` (and of its parents) to `typed`, or "" when none is near.
inline std::string closest_option(CLI::App* command, const std::string& typed) {
    std::string name = typed.substr(0, typed.find('='));
    std::string best;
    std::size_t best_d = name.size() <= 4 ? 2 : 3;
    for (CLI::App* at = command; at != nullptr; at = at->get_parent()) {
        for (const CLI::Option* o : at->get_options()) {
            for (const std::string& l : o->get_lnames()) {
                const std::size_t d = edit_distance(name, "--" + l);
                if (d < best_d) {
                    best_d = d;
                    best = "--" + l;
                }
            }
        }
    }
    return best;
}

/// Prints a parse error of `app` with the command's name and, for unexpected arguments, the
/// closest option; returns the usage-error status 2.
inline int report_parse_error(CLI::App& app, const CLI::ParseError& e) {
    std::string path;
    CLI::App* command = deepest_command(app, path);
    const std::string prefix = path.empty() ? "gonio: " : "gonio " + path + ": ";
    std::string message = e.what();
    if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
        const std::string::size_type colon = message.find(": ");
        std::vector<std::string> args;
        if (colon != std::string::npos) {
            std::istringstream words(message.substr(colon + 2));
            for (std::string w; words >> w;) {
                args.push_back(w);
            }
        }
        // An unknown option's value is unexpected too: name the options alone when there are any.
        bool any_option = false;
        for (const std::string& a : args) {
            any_option = any_option || (!a.empty() && a[0] == '-');
        }
        message.clear();
        for (const std::string& a : args) {
            if (any_option && (a.empty() || a[0] != '-')) {
                continue;
            }
            message += message.empty() ? "" : "; ";
            const std::string shown = a.substr(0, 64);
            if (!a.empty() && a[0] == '-') {
                message += shown + ": unknown option";
                const std::string near = closest_option(command, a);
                if (!near.empty()) {
                    message += "; did you mean " + near + "?";
                }
            } else {
                message += "\"" + shown + "\": unexpected argument";
            }
        }
    }
    std::fprintf(stderr,
                 "%s%s (see gonio %s%s--help)\n",
                 prefix.c_str(),
                 message.c_str(),
                 path.c_str(),
                 path.empty() ? "" : " ");
    return 2;
}

}  // namespace gonio::tools
