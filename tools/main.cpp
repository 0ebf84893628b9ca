// gonio: drive a gonioreflectometer, acquire BRDF datasets, fit analytic models.
//
// Exit status of every command: 0 success, 1 failure of the work (bad input file, device fault,
// paused or interrupted campaign, ...), 2 usage error (unknown command or option, bad option
// value). CLI11's own codes (105, 106, 109, ...) are mapped onto these.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <map>

#include "command.h"
#include "gonio/base/edit_distance.h"
#include "gonio/base/limits.h"
#include "gonio/version.h"
#include "parse_errors.h"

namespace gonio::tools {

std::vector<CommandEntry>& command_registry() {
    static std::vector<CommandEntry> registry;
    return registry;
}

}  // namespace gonio::tools

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

}  // namespace

int main(int argc, char** argv) {
    using gonio::tools::CommandEntry;
    CLI::App app{"gonio: gonioreflectometer control, BRDF acquisition and model fitting", "gonio"};
    app.set_version_flag("--version", std::string("gonio ") + GONIO_VERSION_STRING);
    app.require_subcommand(1);
    // Options of gonio itself may also follow the command (gonio convert ... --max-memory 8G).
    app.fallthrough();
    std::string max_memory;
    app.add_option("--max-memory",
                   max_memory,
                   "memory budget of the command, e.g. 512M, 8G (default 2G); work that needs "
                   "more is refused before it starts");
    app.footer(
        "Exit status: 0 success, 1 the work failed (bad input, device fault, paused or "
        "interrupted campaign), 2 usage error (unknown command or option, bad option value).");
    std::vector<CommandEntry> entries = gonio::tools::command_registry();
    std::sort(entries.begin(), entries.end(), [](const CommandEntry& a, const CommandEntry& b) {
        return std::string(a.name) < b.name;
    });
    std::map<std::string, gonio::tools::CommandRun> runs;
    for (const CommandEntry& e : entries) {
        runs[e.name] = e.setup(app);
    }
    // The first word that is not an option must name a command.
    for (int i = 1; i < argc; ++i) {
        if (argv[i][0] == '-') {
            if (std::strcmp(argv[i], "--max-memory") == 0) {
                ++i;
            }
            continue;
        }
        if (runs.count(argv[i]) == 0) {
            std::string best;
            std::size_t best_d = 3;
            std::string all;
            for (const auto& [name, run] : runs) {
                all += all.empty() ? "" : ", ";
                all += name;
                const std::size_t d = gonio::edit_distance(argv[i], name);
                if (d < best_d) {
                    best_d = d;
                    best = name;
                }
            }
            std::fprintf(
                stderr,
                "gonio: unknown command \"%.64s\"%s%s%s (commands: %s; see gonio --help)\n",
                argv[i],
                best.empty() ? "" : "; did you mean \"",
                best.c_str(),
                best.empty() ? "" : "\"?",
                all.c_str());
            return kExitUsage;
        }
        break;
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e) == 0 ? 0 : kExitUsage;
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e) == 0 ? 0 : kExitUsage;
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e) == 0 ? 0 : kExitUsage;
    } catch (const CLI::ParseError& e) {
        return gonio::tools::report_parse_error(app, e);
    }
    if (!max_memory.empty()) {
        gonio::Expected<std::size_t> bytes = gonio::parse_byte_size(max_memory);
        if (!bytes) {
            std::fprintf(stderr, "gonio: --max-memory: %s\n", bytes.error().message.c_str());
            return kExitUsage;
        }
        gonio::set_max_memory_bytes(*bytes);
    }
    for (CLI::App* sub : app.get_subcommands()) {
        auto it = runs.find(sub->get_name());
        if (it != runs.end() && it->second) {
            const int status = it->second();
            // Commands return 0, 1 or 2; anything else is a failure of the work.
            return status == 0 || status == kExitUsage ? status : kExitFailure;
        }
    }
    std::fprintf(stderr, "gonio: no command given (see gonio --help)\n");
    return kExitUsage;
}
