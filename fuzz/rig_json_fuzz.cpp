// Fuzz target for the rig description reader (acquisition::parse_rig_config). Properties: a
// failure names the source and leaks no internals; a success has four axes with Modbus unit ids in
// [0, 247] and finite limits, min < max.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/acquisition/shared/rig_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    namespace acq = gonio::acquisition;
    const std::string text(reinterpret_cast<const char*>(data), size);
    gonio::Expected<acq::RigConfig> r = acq::parse_rig_config(text, "rig.json");
    if (!r) {
        gonio::fuzz::check_message("rig_json", r.error().message, "rig.json", data, size);
        return 0;
    }
    for (const auto& a : r->axes) {
        gonio::fuzz::require(a.unit >= 0 && a.unit <= 247, "rig_json", "unit id in [0, 247]");
        gonio::fuzz::require(std::isfinite(a.limits.min_deg) && std::isfinite(a.limits.max_deg) &&
                                 a.limits.min_deg < a.limits.max_deg,
                             "rig_json",
                             "finite limits, min < max");
    }
    return 0;
}
