#pragma once

// `gonio fit --manifest M [--shard K/N] --out DIR`: the fits of one shard of a manifest, for job
// arrays of schedulers without Python (docs/scale-out.md). The logic lives in gonio::batch.

#include <string>
#include <utility>
#include <vector>

namespace gonio::tools {

/// Runs the entries of shard K/N (all entries without a shard) into out_dir and writes the shard's
/// summary CSV there. Each override (request key, value: the options given on the command line)
/// replaces that option in every entry. Exit status: 0 every entry fitted (a misfit included
/// unless `strict`) or already finished, 1 some entry failed or did not converge (or misfit under
/// `strict`), or the output folder cannot be made; 2 unreadable or invalid manifest, bad shard, an
/// override that is invalid or conflicts with an entry's model.
int run_fit_manifest(const std::string& manifest,
                     const std::string& shard,
                     const std::string& out_dir,
                     const std::vector<std::pair<std::string, std::string>>& overrides,
                     bool strict);

}  // namespace gonio::tools
