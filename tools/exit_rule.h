#pragma once

// The exit status rule of every command, as --help, the README and the operator guide state it
// (one sentence, kept identical in each place; a test compares them).

namespace gonio::tools {

inline constexpr const char* kExitRule =
    "Exit status: 0 success, 1 the work failed (the content of a file refused while the work "
    "reads it, a device fault, a fit that did not converge, a campaign paused or stopped), 2 "
    "usage error, found before any work starts (an unknown command or option, a bad option "
    "value, options that cannot go together, an input named on the command line that does not "
    "exist or cannot be read).";

}  // namespace gonio::tools
