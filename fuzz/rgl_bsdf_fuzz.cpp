// libFuzzer target for the RGL material reader (tensor file codec and RglBsdf). Properties checked
// on every input:
// - parse_tensor_file() and RglBsdf::from_tensor() either fail with a short message naming the
//   input, or succeed;
// - a parsed file encodes and parses again to the same fields;
// - an accepted material evaluates to finite, non-negative values at a few direction pairs and
//   its nodes are unit directions with finite factors.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/tensor_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace gonio::brdf;
    using gonio::fuzz::require;
    const char* target = "rgl_bsdf";
    gonio::Expected<TensorFile> file = parse_tensor_file(data, size, "input.bsdf");
    if (!file) {
        gonio::fuzz::check_message(target, file.error().message, "input.bsdf");
        return 0;
    }
    const std::string again = encode_tensor_file(*file);
    gonio::Expected<TensorFile> reparsed = parse_tensor_file(
        reinterpret_cast<const std::uint8_t*>(again.data()), again.size(), "again.bsdf");
    require(reparsed.has_value(), target, "encode(parse(x)) parses");
    require(reparsed->fields.size() == file->fields.size(), target, "same field count");
    for (std::size_t k = 0; k < file->fields.size(); ++k) {
        const TensorField& a = file->fields[k];
        const TensorField& b = reparsed->fields[k];
        require(a.name == b.name && a.dtype == b.dtype && a.shape == b.shape && a.data == b.data,
                target,
                "round trip keeps the field",
                a.name);
    }
    gonio::Expected<RglBsdf> bsdf = RglBsdf::from_tensor(*file, "input.bsdf");
    if (!bsdf) {
        gonio::fuzz::check_message(target, bsdf.error().message, "input.bsdf");
        return 0;
    }
    for (double ti : {0.0, 0.3, 1.2, 1.5}) {
        for (double to : {0.0, 0.5, 1.4}) {
            const Rgbd f =
                bsdf->eval(spherical_to_cartesian(ti, 0.2), spherical_to_cartesian(to, 2.9));
            require(f.allFinite() && (f >= 0.0).all(), target, "finite non-negative f_r");
        }
    }
    // Node lists of files with huge grids are bounded by the file size (every node is a stored
    // value), so walking them is linear in the input.
    for (const RglNode& n : bsdf->nodes()) {
        require(std::abs(n.wo.norm() - 1.0) < 1e-6 && std::isfinite(n.factor), target, "node");
    }
    return 0;
}
