// Fuzz target for the sample CSV reader (brdf::read_dataset_csv through its public API).
// Properties: a failure names the file and leaks no internals; a success gives samples with finite
// values and angles in their domains, and a rejected row names its line.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "fuzz_support.h"
#include "gonio/brdf/dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size > (1u << 20)) {
        return 0;
    }
    gonio::fuzz::TempDir dir;
    const std::string path = dir.write("input.csv", data, size);
    gonio::Expected<gonio::brdf::Dataset> d = gonio::brdf::read_dataset_csv(path);
    if (!d) {
        gonio::fuzz::check_message("csv", d.error().message, "input.csv", data, size);
        return 0;
    }
    for (const gonio::brdf::Sample& s : d->samples) {
        gonio::fuzz::require(std::isfinite(s.theta_i) && std::isfinite(s.theta_o) &&
                                 std::isfinite(s.phi_i) && std::isfinite(s.phi_o),
                             "csv",
                             "finite angles");
        gonio::fuzz::require(s.value.isFinite().all(), "csv", "finite values");
    }
    for (const gonio::brdf::RejectedRow& r : d->rejected) {
        gonio::fuzz::require(r.line >= 1 && !r.reason.empty(), "csv", "rejected rows say why");
    }
    return 0;
}
