#pragma once

// Each subcommand lives in its own cmd_<name>.cpp and registers itself:
//   GONIO_COMMAND(eval) { auto* cmd = app.add_subcommand("eval", "..."); ...; return [=] { return
//   run(); }; }
// The body receives `CLI::App& app` and returns the function to run when the subcommand is chosen;
// that function returns the process exit status. Business logic stays in the modules; this is glue
// only.

#include <functional>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace gonio::tools {

using CommandRun = std::function<int()>;
using CommandSetup = CommandRun (*)(CLI::App& app);

struct CommandEntry {
    const char* name;
    CommandSetup setup;
};

std::vector<CommandEntry>& command_registry();

struct CommandRegistrar {
    CommandRegistrar(const char* name, CommandSetup setup) {
        command_registry().push_back({name, setup});
    }
};

}  // namespace gonio::tools

#define GONIO_COMMAND(name)                                                                    \
    static ::gonio::tools::CommandRun gonio_setup_##name(CLI::App& app);                       \
    static const ::gonio::tools::CommandRegistrar gonio_registrar_##name(#name,                \
                                                                         &gonio_setup_##name); \
    static ::gonio::tools::CommandRun gonio_setup_##name(CLI::App& app)
