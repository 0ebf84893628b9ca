#pragma once

// `gonio fit --manifest M [--shard K/N] --out DIR`: the fits of one shard of a manifest, for job
// arrays of schedulers without Python (docs/scale-out.md). The logic lives in gonio::batch.

#include <string>

namespace gonio::tools {

/// Runs the entries of shard K/N (all entries without a shard) into out_dir and writes the shard's
/// summary CSV there. threads >= 0 (from --threads) replaces every entry's `threads` option. Exit
/// status: 0 every entry fitted (a misfit included unless `strict`) or already finished, 1 some
/// entry failed or did not converge (or misfit under `strict`), 2 unreadable manifest or bad
/// arguments.
int run_fit_manifest(const std::string& manifest,
                     const std::string& shard,
                     const std::string& out_dir,
                     int threads,
                     bool strict);

}  // namespace gonio::tools
