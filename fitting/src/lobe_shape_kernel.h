#pragma once

// The packet loop of lobe_shape_packets (fitting/lobe_shape_packets.h) for one instruction set;
// each copy of isa/lobe_shape.cpp instantiates it with its own compile flags.

#include <algorithm>
#include <cstddef>
#include <xsimd/xsimd.hpp>

#include "gonio/brdf/lobe_body.h"
#include "gonio/fitting/lobe_shape_packets.h"

namespace gonio::fitting::detail {

/// The lobe body's structure (brdf/lobe_body.h) of a kind.
inline brdf::Distribution kind_distribution(const LobeShapeKind& kind) {
    return kind.beckmann ? brdf::Distribution::kBeckmann : brdf::Distribution::kGgx;
}
inline brdf::Shadowing kind_shadowing(const LobeShapeKind& kind) {
    return kind.smith == 0   ? brdf::Shadowing::kNone
           : kind.smith == 1 ? brdf::Shadowing::kSmithCorrelated
                             : brdf::Shadowing::kSmithSeparable;
}

/// S = D G inv_4cc of one packet and, with Deriv, dS = dS/dalpha: the lobe body
/// (brdf/lobe_body.h) on the squares of an isotropic structure.
template <bool Deriv, class B>
GONIO_LOBE_INLINE B lobe_shape_packet(const LobeShapeKind& kind,
                                      double alpha,
                                      const B& hxy2,
                                      const B& hz2,
                                      const B& ti,
                                      const B& to,
                                      const B& inv_4cc,
                                      B* dS) {
    constexpr double kUnused = 0.0;
    const brdf::LobeShapeParams<double> p{
        kind_distribution(kind), kind_shadowing(kind), alpha, alpha, kUnused, kUnused, nullptr};
    brdf::LobeSquares<B> g;
    g.isotropic = true;
    g.hx2 = hxy2;
    g.hy2 = B(0.0);
    g.hz2 = hz2;
    g.wi.x2 = ti;
    g.wo.x2 = to;
    g.inv_4cc = inv_4cc;
    return brdf::lobe_shape<Deriv, brdf::SquaresForm::kTangents, B>(p, g, dS);
}

template <class Arch>
void lobe_shape_kernel(const LobeShapeKind& kind,
                       double alpha,
                       const LobeShapeInputs& in,
                       std::size_t n,
                       double* S,
                       double* dS) {
    using B = xsimd::batch<double, Arch>;
    constexpr std::size_t kW = B::size;
    const bool smith = kind.smith != 0;
    std::size_t i = 0;
    for (; i + kW <= n; i += kW) {
        const B ti = smith ? B::load_unaligned(in.tan2_i + i) : B(0.0);
        const B to = smith ? B::load_unaligned(in.tan2_o + i) : B(0.0);
        B ds;
        const B s = lobe_shape_packet<true>(kind,
                                            alpha,
                                            B::load_unaligned(in.hxy2 + i),
                                            B::load_unaligned(in.hz2 + i),
                                            ti,
                                            to,
                                            B::load_unaligned(in.inv_4cc + i),
                                            &ds);
        s.store_unaligned(S + i);
        ds.store_unaligned(dS + i);
    }
    if (i < n) {
        // The last partial packet, padded with h at the normal and both directions along it.
        alignas(64) double hxy2[kW] = {}, hz2[kW], ti[kW] = {}, to[kW] = {}, inv[kW] = {};
        std::fill(hz2, hz2 + kW, 1.0);
        const std::size_t m = n - i;
        std::copy(in.hxy2 + i, in.hxy2 + n, hxy2);
        std::copy(in.hz2 + i, in.hz2 + n, hz2);
        std::copy(in.inv_4cc + i, in.inv_4cc + n, inv);
        if (smith) {
            std::copy(in.tan2_i + i, in.tan2_i + n, ti);
            std::copy(in.tan2_o + i, in.tan2_o + n, to);
        }
        B ds;
        const B s = lobe_shape_packet<true>(kind,
                                            alpha,
                                            B::load_aligned(hxy2),
                                            B::load_aligned(hz2),
                                            B::load_aligned(ti),
                                            B::load_aligned(to),
                                            B::load_aligned(inv),
                                            &ds);
        alignas(64) double so[kW], dso[kW];
        s.store_aligned(so);
        ds.store_aligned(dso);
        std::copy(so, so + m, S + i);
        std::copy(dso, dso + m, dS + i);
    }
}

}  // namespace gonio::fitting::detail
