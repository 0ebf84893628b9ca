// Fuzz target for a fit request over a dataset (batch::run_fit, the one entry point of `gonio fit`,
// manifests and gonio.fit()). The input's first line is the request in the manifest option syntax
// ("model=ggx;lobes=0;residual=cbrt"), the rest a dataset CSV. Properties: no signal and no
// sanitizer finding for any request and data; a refused request or dataset says why (naming the
// option or the file); a fit that ran gives finite error metrics or says it is not usable; the
// verdict is one of its three states and agrees with `usable`.
//
// Each input is kept small so that a run stays quick: at most 2 starts, 25 iterations, one thread,
// no template files (a model ending in .json would read the disk).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/base/strings.h"
#include "gonio/batch/fit_request.h"
#include "gonio/brdf/dataset.h"

namespace {

constexpr const char* kTarget = "fit_request";

/// The request of the first line, with the budget of one fuzz run; false when it is refused (the
/// refusal must name what it refuses).
bool parse_request(const std::string& line, gonio::batch::FitRequest& request) {
    auto s = gonio::batch::set_options(request, line);
    if (!s) {
        gonio::fuzz::require(!s.error().message.empty(), kTarget, "a refused option says why");
        return false;
    }
    if (request.is_template()) {
        return false;  // a file on disk: the fit_template target reads templates
    }
    request.starts = std::min(request.starts, 2);
    request.max_iterations = std::min(request.max_iterations, 25);
    request.threads = 1;
    return true;
}

void check_result(const gonio::batch::FitRun& run) {
    const gonio::fitting::FitResult& r = run.result;
    // One headline, in agreement with what it decides.
    gonio::fuzz::require(!r.goodness.headline.empty(), kTarget, "a verdict has a headline");
    gonio::fuzz::require(
        r.goodness.represents == (r.goodness.verdict != gonio::fitting::Verdict::kDoesNotRepresent),
        kTarget,
        "represents agrees with the verdict");
    gonio::fuzz::require(!r.usable() || r.goodness.represents, kTarget, "a usable fit represents");
    const bool good = r.goodness.verdict == gonio::fitting::Verdict::kRepresents;
    gonio::fuzz::require(good == r.goodness.suggestion.empty(),
                         kTarget,
                         "a misfit suggests something, a fit that represents nothing",
                         r.goodness.headline);
    if (r.usable()) {
        gonio::fuzz::require(r.metrics.log_rmse.allFinite() && r.metrics.rmse.allFinite(),
                             kTarget,
                             "a usable fit has finite metrics");
        for (const auto& p : r.parameters) {
            gonio::fuzz::require(
                std::isfinite(p.value), kTarget, "a usable fit's parameters are finite", p.name);
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size > (1u << 14)) {
        return 0;
    }
    const std::string text(reinterpret_cast<const char*>(data), size);
    const std::size_t nl = text.find('\n');
    if (nl == std::string::npos) {
        return 0;
    }
    gonio::batch::FitRequest request;
    if (!parse_request(text.substr(0, nl), request)) {
        return 0;
    }
    if (auto spec = gonio::batch::make_fit_spec(request); !spec) {
        gonio::fuzz::require(!spec.error().message.empty(), kTarget, "a refused request says why");
        return 0;
    }
    gonio::fuzz::TempDir dir;
    const std::string path = dir.write("data.csv", data + nl + 1, size - nl - 1);
    gonio::Expected<gonio::brdf::Dataset> d = gonio::brdf::read_dataset_csv(path);
    if (!d) {
        gonio::fuzz::check_message(kTarget, d.error().message, "data.csv", data, size);
        return 0;
    }
    gonio::Expected<gonio::batch::FitRun> run = gonio::batch::run_fit(*d, request);
    if (!run) {
        gonio::fuzz::require(!run.error().message.empty(), kTarget, "a refused fit says why");
        return 0;
    }
    check_result(*run);
    return 0;
}
