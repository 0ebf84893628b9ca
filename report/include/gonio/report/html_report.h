#pragma once

// The campaign report: one self-contained HTML page (images embedded as base64 PNG data URIs, no
// external file referenced) for a campaign folder.
//
// Inputs read from DIR (each optional; what is missing is said on the page): dataset.csv (samples),
// campaign.json (metadata sidecar, read tolerantly: every key is shown, calibration and drift
// records in their own section), fit.json (the fitted model), fit.report.json (parameters with
// uncertainties, metrics, sample counts, solver summary), plots/*.png, previews/*.png and
// bench/runtime_vs_error.csv. Missing plots (when there is a dataset) and previews (when there is a
// fit) are generated into plots/ and previews/ first; the coverage plot is always drawn from the
// dataset. Output: DIR/report.html.

#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/report/plot.h"
#include "gonio/report/preview.h"

namespace gonio::report {

struct ReportOptions {
    PlotOptions plot;
    PreviewOptions preview;
    bool regenerate = false;  ///< redraw plots and previews even when PNG files exist
    /// Add Blender's render of the exported fit beside the previews (blender_report.h).
    bool blender = false;
};

struct ReportResult {
    std::string html_path;
    std::vector<std::string> generated;  ///< pictures written while building the report
    std::vector<std::string> notes;      ///< inputs that were missing or unreadable
};

/// Builds DIR/report.html. Error when DIR is not a folder, when it holds neither dataset.csv nor
/// campaign.json nor fit.json, or when a file cannot be written.
Expected<ReportResult> build_report(const std::string& dir, const ReportOptions& options = {});

/// Escapes &, <, >, " and ' for HTML (and XML) text and attribute values.
std::string html_escape(const std::string& s);

}  // namespace gonio::report
