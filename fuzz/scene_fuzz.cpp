// Fuzz target for the scene (region of interest) reader (acquisition::read_scene). Properties: a
// failure names the file and leaks no internals; a success holds unit directions above the
// horizon, ordered theta ranges and a finite margin.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/acquisition/plans/plan.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    namespace acq = gonio::acquisition;
    gonio::fuzz::TempDir dir;
    const std::string path = dir.write("scene.json", data, size);
    gonio::Expected<acq::Scene> sc = acq::read_scene(path);
    if (!sc) {
        gonio::fuzz::check_message("scene", sc.error().message, "scene.json", data, size);
        return 0;
    }
    gonio::fuzz::require(std::isfinite(sc->margin) && sc->margin >= 0, "scene", "finite margin");
    for (const auto& [wi, wo] : sc->pairs) {
        gonio::fuzz::require(std::abs(wi.norm() - 1) < 1e-9 && std::abs(wo.norm() - 1) < 1e-9 &&
                                 wi.z() > 0 && wo.z() > 0,
                             "scene",
                             "unit directions above the horizon");
    }
    if (sc->has_ranges) {
        gonio::fuzz::require(
            sc->theta_i_min <= sc->theta_i_max && sc->theta_r_min <= sc->theta_r_max,
            "scene",
            "ordered ranges");
    }
    return 0;
}
