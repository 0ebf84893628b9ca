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
//
// A folder holding a fit and its report but no campaign (gonio fit FILE --out DIR/fit.json) gives
// the page of that fit: titled "gonio fit report: FILE", its plots drawn from the data file
// fit.report.json names (as named, else beside the fit), without the calibration and run-history
// sections of a campaign.
//
// The page is built in stages, each a function of html_report.cpp: read the inputs (descriptions,
// samples, table, fit), draw the missing pictures, then write the head, the result, the pictures,
// calibration and drift, the run history, the run-time table and the raw descriptions with the
// notes.

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
