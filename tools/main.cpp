// gonio: drive a gonioreflectometer, acquire BRDF datasets, fit analytic models.
//
// Exit status of every command: exit_rule.h (0 success, 1 the work failed, 2 usage error found
// before any work, an input named on the command line that cannot be read included). CLI11's own
// codes (105, 106, 109, ...) are mapped onto these.
//
// This file is the main of two executables: gonio (GONIO_LAUNCHER defined) with the commands that
// need no device, camera or image library, and gonio-full with every command. gonio hands the
// commands of full_commands.h to gonio-full (see there).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "build_info.h"
#include "command.h"
#include "exit_rule.h"
#include "gonio/base/edit_distance.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/limits.h"
#include "gonio/version.h"
#include "parse_errors.h"

#if defined(GONIO_LAUNCHER)
#include <unistd.h>

#include <cerrno>

#include "full_commands.h"
#include "install_layout.h"
#endif

namespace gonio::tools {

std::vector<CommandEntry>& command_registry() {
    static std::vector<CommandEntry> registry;
    return registry;
}

}  // namespace gonio::tools

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

#if defined(GONIO_LAUNCHER)
/// The folder of this executable, or empty.
std::string own_dir() {
    char self[4096];
    const ssize_t len = readlink("/proc/self/exe", self, sizeof self - 1);
    if (len <= 0) {
        return {};
    }
    self[len] = '\0';
    std::string dir(self);
    dir.erase(dir.find_last_of('/'));
    return dir;
}

/// Replaces this process by gonio-full with the same arguments: the one beside this executable,
/// else the install's (libexec/gonio, then bin, relative to this executable's folder). Returns
/// only on failure, with the exit status to use.
int run_full(char** argv) {
    const std::string dir = own_dir();
    std::vector<std::string> tried;
    if (dir.empty()) {
        tried.push_back("gonio-full");
    } else {
        tried.push_back(dir + "/gonio-full");
        for (const char* relative : gonio::kInstalledFullDirs) {
            tried.push_back(dir + "/" + relative + "/gonio-full");
        }
    }
    std::string list;
    for (const std::string& path : tried) {
        if (access(path.c_str(), X_OK) == 0) {
            execv(path.c_str(), argv);
            std::fprintf(stderr,
                         "gonio: cannot run %s (it serves the device, camera and image commands): "
                         "%s\n",
                         path.c_str(),
                         std::strerror(errno));
            return kExitFailure;
        }
        list += (list.empty() ? "" : ", ") + path;
    }
    std::fprintf(stderr,
                 "gonio: gonio-full (it serves the device, camera and image commands) not found "
                 "(tried %s)\n",
                 list.c_str());
    return kExitFailure;
}

bool is_full_command(const char* name) {
    for (const gonio::tools::FullCommand& c : gonio::tools::kFullCommands) {
        if (std::strcmp(c.name, name) == 0) {
            return true;
        }
    }
    return false;
}
#endif

using Runs = std::map<std::string, gonio::tools::CommandRun>;

/// Every command in name order: the registered ones (set up here) and, in gonio, those run by
/// gonio-full (listed in --help and known to the suggestions).
Runs set_up_commands(CLI::App& app) {
    using gonio::tools::CommandEntry;
    struct Listed {
        std::string name;
        const CommandEntry* entry;
        const char* description;
    };
    std::vector<Listed> listed;
    for (const CommandEntry& e : gonio::tools::command_registry()) {
        listed.push_back({e.name, &e, nullptr});
    }
#if defined(GONIO_LAUNCHER)
    for (const gonio::tools::FullCommand& c : gonio::tools::kFullCommands) {
        listed.push_back({c.name, nullptr, c.description});
    }
#endif
    std::sort(listed.begin(), listed.end(), [](const Listed& a, const Listed& b) {
        return a.name < b.name;
    });
    Runs runs;
    for (const Listed& l : listed) {
        if (l.entry != nullptr) {
            runs[l.name] = l.entry->setup(app);
        } else {
            app.add_subcommand(l.name, l.description);
            runs[l.name] = {};
        }
    }
    return runs;
}

/// An unknown command: said with the nearest known one (within 2 edits) and the list.
int unknown_command(const char* word, const Runs& runs) {
    std::string best;
    std::size_t best_d = 3;
    std::string all;
    for (const auto& [name, run] : runs) {
        all += all.empty() ? "" : ", ";
        all += name;
        const std::size_t d = gonio::edit_distance(word, name);
        if (d < best_d) {
            best_d = d;
            best = name;
        }
    }
    std::fprintf(stderr,
                 "gonio: unknown command \"%.64s\"%s%s%s (commands: %s; see gonio --help)\n",
                 word,
                 best.empty() ? "" : "; did you mean \"",
                 best.c_str(),
                 best.empty() ? "" : "\"?",
                 all.c_str());
    return kExitUsage;
}

/// The first word that is not an option must name a command: the exit code when it does not
/// (or, in gonio, when gonio-full ran it), -1 to go on.
int check_first_word(int argc, char** argv, const Runs& runs) {
    for (int i = 1; i < argc; ++i) {
        if (argv[i][0] == '-') {
            if (std::strcmp(argv[i], "--max-memory") == 0) {
                ++i;
            }
            continue;
        }
        if (runs.count(argv[i]) == 0) {
            return unknown_command(argv[i], runs);
        }
#if defined(GONIO_LAUNCHER)
        if (is_full_command(argv[i])) {
            return run_full(argv);
        }
#endif
        break;
    }
    return -1;
}

/// CLI11's parse: the exit code for help, version and parse errors, -1 to go on.
int parse_command_line(CLI::App& app, int argc, char** argv) {
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
    return -1;
}

/// Runs the command given; commands return 0, 1 or 2, anything else is a failure of the work.
int run_command(CLI::App& app, const Runs& runs) {
    for (CLI::App* sub : app.get_subcommands()) {
        auto it = runs.find(sub->get_name());
        if (it != runs.end() && it->second) {
            const int status = it->second();
            return status == 0 || status == kExitUsage ? status : kExitFailure;
        }
    }
    std::fprintf(stderr, "gonio: no command given (see gonio --help)\n");
    return kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
    // Freed buffers stay with the process and its first heap pages are huge (huge_pages.h): a
    // command allocates and frees the same large buffers many times over, and ends soon anyway.
    gonio::keep_heap_for_batch_work();
    CLI::App app{"gonio: gonioreflectometer control, BRDF acquisition and model fitting", "gonio"};
    app.set_version_flag(
        "--version", std::string("gonio ") + GONIO_VERSION_STRING + " (" + GONIO_COMMIT_TEXT + ")");
    app.require_subcommand(1);
    // Options of gonio itself may also follow the command (gonio convert ... --max-memory 8G).
    app.fallthrough();
    std::string max_memory;
    app.add_option("--max-memory",
                   max_memory,
                   "memory budget of the command, e.g. 512M, 8G (default 2G); work that needs "
                   "more is refused before it starts");
    app.footer(gonio::tools::kExitRule);
    const Runs runs = set_up_commands(app);
    if (const int rc = check_first_word(argc, argv, runs); rc >= 0) {
        return rc;
    }
    if (const int rc = parse_command_line(app, argc, argv); rc >= 0) {
        return rc;
    }
    if (!max_memory.empty()) {
        gonio::Expected<std::size_t> bytes = gonio::parse_byte_size(max_memory);
        if (!bytes) {
            std::fprintf(stderr, "gonio: --max-memory: %s\n", bytes.error().message.c_str());
            return kExitUsage;
        }
        gonio::set_max_memory_bytes(*bytes);
    }
    return run_command(app, runs);
}
