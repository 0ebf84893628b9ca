#pragma once

// The body of eval_model_packets for one SIMD architecture; included by one translation unit per
// instruction set, each compiled with that set's flags and instantiating only packet types of its
// architecture.

#include <algorithm>
#include <cstddef>

#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"

namespace gonio::brdf::arch {

template <class Arch>
inline void eval_model_packets_on(const ModelD& m,
                                  std::size_t n,
                                  const DirectionPairs& d,
                                  double* const out[3]) {
    using B = xsimd::batch<double, Arch>;
    constexpr std::size_t kW = B::size;
    std::size_t k = 0;
    B f[3];
    for (; k + kW <= n; k += kW) {
        const Dir3<B> wi{B::load_unaligned(d.wi_x + k),
                         B::load_unaligned(d.wi_y + k),
                         B::load_unaligned(d.wi_z + k)};
        const Dir3<B> wo{B::load_unaligned(d.wo_x + k),
                         B::load_unaligned(d.wo_y + k),
                         B::load_unaligned(d.wo_z + k)};
        eval_model_lanes(m, wi, wo, f);
        for (int c = 0; c < 3; ++c) {
            f[c].store_unaligned(out[c] + k);
        }
    }
    if (k == n) {
        return;
    }
    // The last, partial packet: the spare lanes hold wi = wo = z (a regular configuration) and are
    // not stored.
    alignas(64) double lanes[6][kW];
    for (std::size_t l = 0; l < kW; ++l) {
        const bool used = k + l < n;
        lanes[0][l] = used ? d.wi_x[k + l] : 0.0;
        lanes[1][l] = used ? d.wi_y[k + l] : 0.0;
        lanes[2][l] = used ? d.wi_z[k + l] : 1.0;
        lanes[3][l] = used ? d.wo_x[k + l] : 0.0;
        lanes[4][l] = used ? d.wo_y[k + l] : 0.0;
        lanes[5][l] = used ? d.wo_z[k + l] : 1.0;
    }
    const Dir3<B> wi{
        B::load_aligned(lanes[0]), B::load_aligned(lanes[1]), B::load_aligned(lanes[2])};
    const Dir3<B> wo{
        B::load_aligned(lanes[3]), B::load_aligned(lanes[4]), B::load_aligned(lanes[5])};
    eval_model_lanes(m, wi, wo, f);
    alignas(64) double values[kW];
    for (int c = 0; c < 3; ++c) {
        f[c].store_aligned(values);
        std::copy(values, values + (n - k), out[c] + k);
    }
}

}  // namespace gonio::brdf::arch
