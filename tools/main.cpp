// gonio: drive a gonioreflectometer, acquire BRDF datasets, fit analytic models.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <map>

#include "command.h"
#include "gonio/version.h"

namespace gonio::tools {

std::vector<CommandEntry>& command_registry() {
    static std::vector<CommandEntry> registry;
    return registry;
}

}  // namespace gonio::tools

int main(int argc, char** argv) {
    using gonio::tools::CommandEntry;
    CLI::App app{"gonio: gonioreflectometer control, BRDF acquisition and model fitting", "gonio"};
    app.set_version_flag("--version", std::string("gonio ") + GONIO_VERSION_STRING);
    app.require_subcommand(1);
    std::vector<CommandEntry> entries = gonio::tools::command_registry();
    std::sort(entries.begin(), entries.end(), [](const CommandEntry& a, const CommandEntry& b) {
        return std::string(a.name) < b.name;
    });
    std::map<std::string, gonio::tools::CommandRun> runs;
    for (const CommandEntry& e : entries) {
        runs[e.name] = e.setup(app);
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    for (CLI::App* sub : app.get_subcommands()) {
        auto it = runs.find(sub->get_name());
        if (it != runs.end() && it->second) {
            return it->second();
        }
    }
    std::fprintf(stderr, "gonio: no subcommand chosen (see gonio --help)\n");
    return 2;
}
