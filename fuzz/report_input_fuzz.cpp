// Fuzz target for the inputs of `gonio report` and of a fit report: the same bytes are the
// campaign description, the run metadata and the fit report of a campaign folder, which
// report::build_report renders (no dataset, so no plots), and fitting::read_fit_report reads.
// Properties: no crash or unbounded recursion (a 100,000-deep document is in the corpus); a failure
// names the file and leaks no internals; a success writes report.html.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "fuzz_support.h"
#include "gonio/fitting/report.h"
#include "gonio/report/html_report.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    gonio::fuzz::TempDir dir;
    dir.write("campaign.json", data, size);
    dir.write("metadata.json", data, size);
    const std::string fit_report = dir.write("fit.report.json", data, size);
    gonio::Expected<gonio::report::ReportResult> r = gonio::report::build_report(dir.path());
    if (!r) {
        gonio::fuzz::check_message("report_input", r.error().message, ".json", data, size);
    } else {
        gonio::fuzz::require(std::filesystem::exists(r->html_path), "report_input", "report.html");
    }
    gonio::Expected<gonio::fitting::FitResult> f = gonio::fitting::read_fit_report(fit_report);
    if (!f) {
        gonio::fuzz::require(f.error().message.find("fit.report.json") != std::string::npos,
                             "report_input",
                             "fit report error names the file:",
                             f.error().message);
    }
    return 0;
}
