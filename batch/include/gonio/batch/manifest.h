#pragma once

// A manifest: many fits, one per line, run as one task each (docs/scale-out.md).
//
//   # comment lines and blank lines are skipped
//   input,model,options[,id]
//   tables/alum-bronze.binary,ggx,residual=log;max_samples=20000
//   scans/blue.csv,beckmann,,blue-beckmann
//
// `input` is a dataset CSV or a table (relative paths are taken from the manifest's folder),
// `model` a distribution name or a fit template *.json (relative likewise), `options` the
// FitRequest options "key=value;..." (may be empty), `id` the name of the results (default: the
// input's file name without extension). Ids must be unique and made of [A-Za-z0-9._-]. Fields
// hold no commas (no quoting).
//
// Results of entry `id` in the output folder: `id.json` (the fitted model) and `id.report.json`
// (the full report; also written when the solve did not converge), or `id.error.txt` when the fit
// could not run. An entry is finished when `id.json` and `id.report.json` exist: reruns skip it.

#include <cstddef>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/batch/fit_request.h"

namespace gonio::batch {

struct ManifestEntry {
    std::size_t index = 0;  ///< 0-based position among the entries.
    std::size_t line = 0;   ///< 1-based line in the manifest.
    std::string id;
    std::string input;  ///< Resolved path.
    FitRequest request;
};

/// Reads and checks a manifest (header, field counts, options, unique ids). Errors name the file,
/// the line and the field.
Expected<std::vector<ManifestEntry>> read_manifest(const std::string& path);

/// A shard "K/N": this task's number K in [0, N) of N tasks.
struct Shard {
    std::size_t k = 0;
    std::size_t n = 1;
};

/// Parses "K/N" (0 <= K < N). The error states the rule.
Expected<Shard> parse_shard(const std::string& text);

/// The entries of one shard: entry i belongs to shard i mod N (round robin, so that neighbouring
/// entries of similar cost spread over the tasks). The shards of 0..N-1 partition the manifest.
std::vector<ManifestEntry> select_shard(const std::vector<ManifestEntry>& entries,
                                        const Shard& shard);

/// The files of an entry's results.
std::string model_path(const std::string& out_dir, const std::string& id);
std::string report_path(const std::string& out_dir, const std::string& id);
std::string error_path(const std::string& out_dir, const std::string& id);

/// True when the entry's model and report both exist in out_dir.
bool entry_finished(const std::string& out_dir, const std::string& id);

enum class EntryStatus {
    kFitted,        ///< Converged; model and report written.
    kMisfit,        ///< Converged, but the model does not represent the data: model (with the
                    ///< verdict) and report written; a finding, not a failure, unless strict.
    kNotConverged,  ///< The solve ran but did not converge; report written, no model.
    kFailed,        ///< The fit could not run (unreadable input, bad spec); error file written.
    kSkipped,       ///< Already finished in out_dir; nothing done.
};

const char* to_string(EntryStatus s);

/// One row of a summary.
struct EntryOutcome {
    std::string id;
    std::string input;
    EntryStatus status = EntryStatus::kFailed;
    std::string message;  ///< The error, or the solver's termination message.
    double log_rmse = 0;  ///< Channel mean of the fit's log_rmse over all valid samples.
    double rel_rmse = 0;  ///< Channel mean of rel_rmse.
    int iterations = 0;
    double wall_time_s = 0;  ///< The fit's own time.
    std::size_t samples_used = 0;
};

/// Runs one entry into out_dir (created if missing) unless it is finished (then kSkipped, with
/// the metrics read back from its report). Never throws; failures are outcomes. A previous error
/// file of the entry is removed when the entry now fits.
EntryOutcome run_entry(const ManifestEntry& entry, const std::string& out_dir);

/// The header and one row of a summary CSV (id,input,status,log_rmse,rel_rmse,iterations,
/// wall_time_s,samples_used,message); the message has commas and newlines replaced by ';' and
/// ' '.
std::string summary_csv_header();
std::string summary_csv_row(const EntryOutcome& outcome);

/// Writes a summary CSV (through a temporary file and a rename).
Expected<void> write_summary_csv(const std::string& path, const std::vector<EntryOutcome>& rows);

}  // namespace gonio::batch
