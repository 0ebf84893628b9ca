#pragma once

// `gonio acquire --serve`: the live page's life around a campaign. It is bound before the
// campaign starts (an address that cannot be served stops the command before anything is
// written) and, once the campaign has ended, it keeps showing the final state, the final fit and
// the campaign's report until Ctrl-C.

#include <memory>
#include <string>

#include "gonio/base/error.h"
#include "gonio/report/live_server.h"

namespace gonio::tools {

/// Binds host:port (port 0: any free one) and prints "live page: URL". `kind` names the campaign
/// in the page's title until its folder is known ("campaign", "image campaign").
Expected<std::unique_ptr<report::LiveServer>> start_live_page(const std::string& host,
                                                              int port,
                                                              const std::string& kind,
                                                              const std::string& frame_note = {});

/// With a live page (nullptr: nothing): the campaign in `dir` has ended in `state`. Writes the
/// campaign's report (DIR/report.html), hands it and the state to the page, says so, and serves
/// until Ctrl-C (SIGINT) or SIGTERM.
void keep_live_page(report::LiveServer* live, const std::string& dir, const std::string& state);

}  // namespace gonio::tools
