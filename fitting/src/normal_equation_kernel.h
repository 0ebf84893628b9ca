#pragma once

// The packet loop of normal_equation_packets and cost_packets (fitting/normal_equation_packets.h)
// for one instruction set; each copy of isa/normal_equation.cpp instantiates it with its own compile
// flags.

#include <algorithm>
#include <cstddef>
#include <xsimd/xsimd.hpp>

#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/math.h"
#include "gonio/fitting/normal_equation_packets.h"
#include "lobe_shape_kernel.h"

namespace gonio::fitting::detail {

/// The per-lane sums of one range: K slots, Deriv: with the normal equations.
template <class B, int K>
struct PacketSums {
    static constexpr int kPairs = K * (K + 1) / 2;
    B a[3][kPairs];
    B b[3][K];
    B cost;
};

/// One packet of samples starting at index i of `in`: adds its terms to `sums`.
template <class B, int K, bool Deriv>
inline void fused_packet(const PacketModel& m,
                         const PacketInputs& in,
                         std::size_t i,
                         PacketSums<B, K>& sums) {
    constexpr int kMaxLobes = PacketModel::kMaxLobes;
    const B hxy2 = B::load_unaligned(in.hxy2 + i);
    const B hz2 = B::load_unaligned(in.hz2 + i);
    const B ti = in.tan2_i != nullptr ? B::load_unaligned(in.tan2_i + i) : B(0.0);
    const B to = in.tan2_o != nullptr ? B::load_unaligned(in.tan2_o + i) : B(0.0);
    const B inv = B::load_unaligned(in.inv_4cc + i);
    const B x5 = in.x5 != nullptr ? B::load_unaligned(in.x5 + i) : B(0.0);
    const B ci = B::load_unaligned(in.cos_i + i);
    B S[kMaxLobes], dS[kMaxLobes];
    for (int l = 0; l < m.lobes; ++l) {
        S[l] = lobe_shape_packet<Deriv>(m.kind[l], m.alpha[l], hxy2, hz2, ti, to, inv, &dS[l]);
    }
    brdf::FresnelGeometry<B> fg;
    fg.x5 = x5;
    const B one(1.0);
    for (int c = 0; c < 3; ++c) {
        // f_c and each lobe's F_lc, in the order of prepared_samples.cpp's per-sample sum.
        B F[kMaxLobes];
        B f(m.diffuse[c]);
        for (int l = 0; l < m.lobes; ++l) {
            F[l] = brdf::lobe_F<B>(m.fresnel[l], c, fg);
            f += B(m.scale[l][c]) * F[l] * S[l];
        }
        const B arg = f * ci;
        const B s = B::load_unaligned(in.s[c] + i);
        const B r = s * (xsimd::log1p(arg) - B::load_unaligned(in.g_d[c] + i));
        sums.cost += r * r;
        if (!Deriv) {
            continue;
        }
        const B dr = s * ci / (one + arg);
        B v[K];
        for (int k = 0; k < K; ++k) {
            const int l = m.slot_lobe[k];
            switch (m.slot[k]) {
                case PacketSlot::kDiffuse:
                    v[k] = B(brdf::kInvPi) * dr;
                    break;
                case PacketSlot::kWidth:
                    v[k] = B(m.scale[l][c]) * F[l] * dS[l] * dr;
                    break;
                case PacketSlot::kScale:
                    v[k] = F[l] * S[l] * dr;
                    break;
                case PacketSlot::kF0:
                    v[k] = B(m.scale[l][c]) * (one - x5) * S[l] * dr;
                    break;
                case PacketSlot::kZero:
                default:
                    v[k] = B(0.0);
                    break;
            }
        }
        int pair = 0;
        for (int q = 0; q < K; ++q) {
            for (int p = 0; p <= q; ++p) {
                sums.a[c][pair++] += v[p] * v[q];
            }
            sums.b[c][q] += r * v[q];
        }
    }
}

template <class B>
inline double lane_sum(const B& x) {
    alignas(64) double lanes[B::size];
    x.store_aligned(lanes);
    double s = 0;
    for (std::size_t k = 0; k < B::size; ++k) {
        s += lanes[k];
    }
    return s;
}

/// Samples ahead of the packet in work whose arrays are asked for (about 1 KB per array: 13
/// streams are more than the hardware prefetcher follows far enough ahead).
constexpr std::size_t kPrefetch = 128;

inline void prefetch_one(const double* p, std::size_t i) {
    if (p != nullptr) {
        __builtin_prefetch(p + i, 0, 0);
    }
}

/// Every array's line at sample i (one line of 8 doubles per array).
inline void prefetch_packet(const PacketInputs& in, std::size_t i) {
    if (i % 8 != 0) {
        return;
    }
    prefetch_one(in.hxy2, i);
    prefetch_one(in.hz2, i);
    prefetch_one(in.tan2_i, i);
    prefetch_one(in.tan2_o, i);
    prefetch_one(in.inv_4cc, i);
    prefetch_one(in.x5, i);
    prefetch_one(in.cos_i, i);
    for (int c = 0; c < 3; ++c) {
        prefetch_one(in.g_d[c], i);
        prefetch_one(in.s[c], i);
    }
}

/// The packets of [begin, end): whole packets from the arrays, the last partial one from a
/// padded copy whose extra lanes contribute exact zeros (s = 0, cos_i = 0, 1 / (4 cos cos) = 0,
/// h along the normal).
template <class B, int K, bool Deriv>
void fused_range(const PacketModel& m,
                 const PacketInputs& in,
                 std::size_t begin,
                 std::size_t end,
                 PacketSums<B, K>& sums) {
    constexpr std::size_t kW = B::size;
    std::size_t i = begin;
    for (; i + kW <= end; i += kW) {
        if (i + kPrefetch < end) {
            prefetch_packet(in, i + kPrefetch);
        }
        fused_packet<B, K, Deriv>(m, in, i, sums);
    }
    if (i < end) {
        const std::size_t n = end - i;
        alignas(64) double hxy2[kW] = {}, hz2[kW], ti[kW] = {}, to[kW] = {}, inv[kW] = {},
                           x5[kW] = {}, ci[kW] = {}, gd[3][kW] = {}, s[3][kW] = {};
        std::fill(hz2, hz2 + kW, 1.0);
        std::copy(in.hxy2 + i, in.hxy2 + end, hxy2);
        std::copy(in.hz2 + i, in.hz2 + end, hz2);
        std::copy(in.inv_4cc + i, in.inv_4cc + end, inv);
        std::copy(in.cos_i + i, in.cos_i + end, ci);
        PacketInputs pad;
        pad.hxy2 = hxy2;
        pad.hz2 = hz2;
        pad.inv_4cc = inv;
        pad.cos_i = ci;
        if (in.tan2_i != nullptr) {
            std::copy(in.tan2_i + i, in.tan2_i + end, ti);
            std::copy(in.tan2_o + i, in.tan2_o + end, to);
            pad.tan2_i = ti;
            pad.tan2_o = to;
        }
        if (in.x5 != nullptr) {
            std::copy(in.x5 + i, in.x5 + end, x5);
            pad.x5 = x5;
        }
        for (int c = 0; c < 3; ++c) {
            std::copy(in.g_d[c] + i, in.g_d[c] + i + n, gd[c]);
            std::copy(in.s[c] + i, in.s[c] + i + n, s[c]);
            pad.g_d[c] = gd[c];
            pad.s[c] = s[c];
        }
        fused_packet<B, K, Deriv>(m, pad, 0, sums);
    }
}

template <class Arch, int K>
void normal_equation_kernel_k(const PacketModel& m,
                              const PacketInputs& in,
                              std::size_t begin,
                              std::size_t end,
                              int stride,
                              double* a,
                              double* b,
                              double* cost) {
    using B = xsimd::batch<double, Arch>;
    PacketSums<B, K> sums;
    for (int c = 0; c < 3; ++c) {
        for (int p = 0; p < PacketSums<B, K>::kPairs; ++p) {
            sums.a[c][p] = B(0.0);
        }
        for (int k = 0; k < K; ++k) {
            sums.b[c][k] = B(0.0);
        }
    }
    sums.cost = B(0.0);
    fused_range<B, K, true>(m, in, begin, end, sums);
    for (int c = 0; c < 3; ++c) {
        double* ac = a + c * stride * stride;
        std::fill(ac, ac + stride * stride, 0.0);
        int pair = 0;
        for (int q = 0; q < K; ++q) {
            for (int p = 0; p <= q; ++p) {
                ac[q * stride + p] = lane_sum(sums.a[c][pair++]);
            }
        }
        double* bc = b + c * stride;
        std::fill(bc, bc + stride, 0.0);
        for (int k = 0; k < K; ++k) {
            bc[k] = lane_sum(sums.b[c][k]);
        }
    }
    *cost = lane_sum(sums.cost);
}

template <class Arch>
void normal_equation_kernel(const PacketModel& m,
                            const PacketInputs& in,
                            std::size_t begin,
                            std::size_t end,
                            int stride,
                            double* a,
                            double* b,
                            double* cost) {
    if (m.slots <= 4) {
        normal_equation_kernel_k<Arch, 4>(m, in, begin, end, stride, a, b, cost);
    } else if (m.slots <= 8) {
        normal_equation_kernel_k<Arch, 8>(m, in, begin, end, stride, a, b, cost);
    } else {
        normal_equation_kernel_k<Arch, 16>(m, in, begin, end, stride, a, b, cost);
    }
}

template <class Arch>
double cost_kernel(const PacketModel& m,
                   const PacketInputs& in,
                   std::size_t begin,
                   std::size_t end) {
    using B = xsimd::batch<double, Arch>;
    PacketSums<B, 1> sums;
    sums.cost = B(0.0);
    fused_range<B, 1, false>(m, in, begin, end, sums);
    return lane_sum(sums.cost);
}

}  // namespace gonio::fitting::detail
