#pragma once

// Fit reports on disk. A fit writes two files: `fit.json`, the model alone in the model schema
// (brdf/model_json.h, readable by `gonio eval`), and `fit.report.json`:
//   {"model": {...}, "parameters": [{"name", "value", "sigma" (or null), "free", "identifiable",
//    "at_bound" ("lower", "upper" or null)}], "not_identifiable": [...], "at_bounds": [...],
//    "vanished_lobes": ["lobes[0]", ...], "metrics": {"rmse": [r,g,b], "rel_rmse": [...],
//    "log_rmse": [...], "bands": [{"theta_h_deg": [lo, hi], "count", "mean_log": [r,g,b],
//    "log_rmse": [r,g,b]}]}, "goodness": {"represents", "reduced_chi_square" (or null),
//    "warnings": [...], "suggestion"}, "covariance": "method", "samples": {"input", "valid",
//    "used", "rejected", "reference", "saturated", "rejected_lines": [first 100]}, "residual":
//    "log", "loss": "none", "solver": {"iterations" (all stages), "stages": [{"name", "samples",
//    "iterations", "termination", "time_s", "final_cost"}], "termination", "message",
//    "converged", "usable", "wall_time_s", ...}, "data": "path", "ground_truth": {...}
//    (optional)}

#include <string>

#include "gonio/base/error.h"
#include "gonio/fitting/fit.h"

namespace gonio::fitting {

/// "fit.json" -> "fit.report.json"; a path without ".json" gets ".report.json" appended.
std::string report_path_for(const std::string& model_path);

/// The report as JSON text.
std::string fit_report_json(const FitResult& result);

/// Writes the model file and the report file (each through a temporary file and a rename). Refuses
/// (error) to write the model file of a result that is not usable; the report is written anyway so
/// that the failure can be inspected.
Expected<void> write_fit_report(const std::string& model_path, const FitResult& result);

/// Reads a report written by write_fit_report (at most kMaxJsonBytes), strictly: an unknown key, a
/// wrong type or a missing required field is an error naming the file and the key path.
Expected<FitResult> read_fit_report(const std::string& report_path);

/// The same for report text already in memory; `name` is the file name used in messages.
Expected<FitResult> parse_fit_report(const std::string& text, const std::string& name);

/// A human-readable summary (several lines), as `gonio fit` prints it.
std::string format_summary(const FitResult& result);

}  // namespace gonio::fitting
