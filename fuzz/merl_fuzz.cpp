// libFuzzer target for the MERL / .gtab reader. Properties checked on every input:
// - parse_merl() either fails with a message naming the input, or succeeds;
// - on success, encode_merl() reproduces the input byte for byte, the statistics are finite, and
//   lookups (nearest and trilinear) at a few directions are finite and non-negative or flagged.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "gonio/brdf/merl.h"
#include "gonio/brdf/table.h"

namespace {

void require(bool ok, const char* what) {
    if (!ok) {
        std::fprintf(stderr, "merl fuzz: property violated: %s\n", what);
        std::abort();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace gonio::brdf;
    for (MerlDims dims : {MerlDims::kMerlOnly, MerlDims::kAny}) {
        gonio::Expected<TabulatedBrdf> t = parse_merl(data, size, "input.gtab", dims);
        if (!t) {
            require(t.error().message.rfind("input.gtab: ", 0) == 0, "error names the input");
            continue;
        }
        const std::vector<std::uint8_t> again = encode_merl(*t);
        require(again.size() == size && std::memcmp(again.data(), data, size) == 0,
                "encode(parse(x)) == x");
        const TableStatistics s = t->compute_statistics();
        require(s.min.isFinite().all() && s.max.isFinite().all() && s.mean.isFinite().all(),
                "finite statistics");
        const Vec3d dirs[4] = {Vec3d(0, 0, 1),
                               spherical_to_cartesian(0.7, 0.2),
                               spherical_to_cartesian(1.5, 2.9),
                               spherical_to_cartesian(0.3, -1.0)};
        for (Interpolation mode : {Interpolation::kNearest, Interpolation::kTrilinear}) {
            t->set_interpolation(mode);
            for (const Vec3d& a : dirs) {
                for (const Vec3d& b : dirs) {
                    const TableLookup l = t->lookup(a, b);
                    require(l.value.isFinite().all(), "finite lookup");
                    require(l.valid || l.value.abs().maxCoeff() == 0, "invalid lookups are 0");
                }
            }
        }
    }
    return 0;
}
