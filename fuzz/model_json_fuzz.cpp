// Fuzz target for the model JSON reader (brdf::parse_model_json). Properties: a failure names the
// source and leaks no internals; a success stays within the documented limits, writes back to JSON
// that reads again to the same model, and evaluates to finite, non-negative values.

#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/base/limits.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_json.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace gonio::brdf;
    const std::string text(reinterpret_cast<const char*>(data), size);
    gonio::Expected<ModelD> m = parse_model_json(text, "model.json");
    if (!m) {
        gonio::fuzz::check_message("model_json", m.error().message, "model.json", data, size);
        return 0;
    }
    gonio::fuzz::require(m->lobes.size() <= gonio::kMaxModelLobes, "model_json", "lobe limit");
    gonio::Expected<ModelD> again = parse_model_json(model_to_json(*m), "again.json");
    gonio::fuzz::require(
        static_cast<bool>(again), "model_json", "written model reads back:", model_to_json(*m));
    gonio::fuzz::require(model_to_json(*again) == model_to_json(*m), "model_json", "round trip");
    const Vec3d dirs[3] = {
        Vec3d(0, 0, 1), spherical_to_cartesian(0.7, 0.2), spherical_to_cartesian(1.4, 2.9)};
    for (const Vec3d& a : dirs) {
        for (const Vec3d& b : dirs) {
            const Rgbd f = eval_model(*m, a, b);
            gonio::fuzz::require(
                f.isFinite().all() && (f >= 0).all(), "model_json", "finite, non-negative value");
        }
    }
    return 0;
}
