// gonio fit --manifest: glue between the command line and gonio::batch.

#include "fit_manifest.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "gonio/batch/manifest.h"

namespace gonio::tools {

int run_fit_manifest(const std::string& manifest,
                     const std::string& shard_text,
                     const std::string& out_dir,
                     const std::vector<std::pair<std::string, std::string>>& overrides,
                     bool strict) {
    if (out_dir.empty()) {
        std::fprintf(stderr, "gonio fit: --manifest needs --out DIR (the results folder)\n");
        return 2;
    }
    batch::Shard shard;
    if (!shard_text.empty()) {
        auto s = batch::parse_shard(shard_text);
        if (!s) {
            std::fprintf(stderr, "gonio fit: --shard: %s\n", s.error().message.c_str());
            return 2;
        }
        shard = *s;
    }
    auto entries = batch::read_manifest(manifest);
    if (!entries) {
        std::fprintf(stderr, "gonio fit: %s\n", entries.error().message.c_str());
        return 2;
    }
    // The command line's options replace the entries' own: checked for every entry (not only
    // this shard's) so that all shards of a job array refuse the same manifest.
    for (batch::ManifestEntry& e : *entries) {
        for (const auto& [key, value] : overrides) {
            if (auto s = batch::set_option(e.request, key, value); !s) {
                std::fprintf(
                    stderr, "gonio fit: --%s: %s\n", key.c_str(), s.error().message.c_str());
                return 2;
            }
        }
        if (auto c = batch::find_conflict(e.request)) {
            std::string flag = c->option == "diffuse" ? "no-diffuse" : c->option;
            std::replace(flag.begin(), flag.end(), '_', '-');
            std::fprintf(stderr,
                         "gonio fit: --%s cannot be combined with %s line %zu, model %s: %s\n",
                         flag.c_str(),
                         manifest.c_str(),
                         e.line,
                         e.request.model.c_str(),
                         c->rule.c_str());
            return 2;
        }
    }
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) {
        std::fprintf(stderr,
                     "gonio fit: %s: cannot create the folder: %s\n",
                     out_dir.c_str(),
                     ec.message().c_str());
        return 1;
    }
    std::vector<batch::ManifestEntry> mine = batch::select_shard(*entries, shard);
    std::printf(
        "shard %zu/%zu: %zu of %zu entries\n", shard.k, shard.n, mine.size(), entries->size());
    std::vector<batch::EntryOutcome> rows;
    std::size_t bad = 0;
    for (std::size_t i = 0; i < mine.size(); ++i) {
        batch::EntryOutcome o = batch::run_entry(mine[i], out_dir);
        // A misfit is a finding (model and verdict written), a failure only under --strict.
        const bool ok = o.status == batch::EntryStatus::kFitted ||
                        o.status == batch::EntryStatus::kSkipped ||
                        (o.status == batch::EntryStatus::kMisfit && !strict);
        bad += ok ? 0 : 1;
        std::printf("[%zu/%zu] %s: %s%s%s\n",
                    i + 1,
                    mine.size(),
                    o.id.c_str(),
                    batch::to_string(o.status),
                    o.message.empty() ? "" : ": ",
                    o.message.c_str());
        std::fflush(stdout);
        rows.push_back(std::move(o));
    }
    const std::string summary =
        (std::filesystem::path(out_dir) /
         ("summary.shard-" + std::to_string(shard.k) + "-of-" + std::to_string(shard.n) + ".csv"))
            .string();
    auto w = batch::write_summary_csv(summary, rows);
    if (!w) {
        std::fprintf(stderr, "gonio fit: %s\n", w.error().message.c_str());
        return 1;
    }
    std::printf("wrote %s (%zu failed)\n", summary.c_str(), bad);
    return bad == 0 ? 0 : 1;
}

}  // namespace gonio::tools
