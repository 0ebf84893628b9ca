#pragma once

// The packet loop of lobe_shape_packets (fitting/lobe_shape_packets.h) for one instruction set;
// each copy of isa/lobe_shape.cpp instantiates it with its own compile flags.

#include <algorithm>
#include <cstddef>
#include <xsimd/xsimd.hpp>

#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/microfacet_derivatives.h"
#include "gonio/fitting/lobe_shape_packets.h"

namespace gonio::fitting::detail {

/// S = D G inv_4cc and dS/dalpha = (dD G + D dG) inv_4cc of one packet.
template <class B>
inline void lobe_shape_packet(const LobeShapeKind& kind,
                              const B& alpha,
                              const B& hxy2,
                              const B& hz2,
                              const B& ti,
                              const B& to,
                              const B& inv_4cc,
                              B& S,
                              B& dS) {
    const B zero(0.0);
    B D, dD;
    if (kind.beckmann) {
        D = brdf::D_beckmann_from_squares(hxy2, zero, hz2, alpha, alpha);
        dD = brdf::dD_beckmann_dalpha_from_squares(hxy2, hz2, alpha, D);
    } else {
        D = brdf::D_ggx_from_squares(hxy2, zero, hz2, alpha, alpha);
        dD = brdf::dD_ggx_dalpha_from_squares(hxy2, hz2, alpha, D);
    }
    B G(1.0), dG(0.0);
    if (kind.smith != 0) {
        const B a2i = alpha * alpha * ti;
        const B a2o = alpha * alpha * to;
        B li, lo, dli, dlo;
        if (kind.beckmann) {
            li = brdf::lambda_beckmann_from_a2(a2i);
            lo = brdf::lambda_beckmann_from_a2(a2o);
            dli = brdf::dlambda_beckmann_dalpha_from_a2(a2i, alpha);
            dlo = brdf::dlambda_beckmann_dalpha_from_a2(a2o, alpha);
        } else {
            li = brdf::lambda_ggx_from_a2(a2i);
            lo = brdf::lambda_ggx_from_a2(a2o);
            dli = brdf::dlambda_ggx_dalpha_from_a2(a2i, alpha);
            dlo = brdf::dlambda_ggx_dalpha_from_a2(a2o, alpha);
        }
        if (kind.smith == 1) {
            G = brdf::G_smith_correlated(li, lo);
            dG = brdf::dG_smith_correlated(G, dli, dlo);
        } else {
            G = brdf::G_smith_separable(li, lo);
            dG = brdf::dG_smith_separable(G, li, lo, dli, dlo);
        }
    }
    S = D * G * inv_4cc;
    dS = (dD * G + D * dG) * inv_4cc;
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
    const B a(alpha);
    const bool smith = kind.smith != 0;
    std::size_t i = 0;
    for (; i + kW <= n; i += kW) {
        const B ti = smith ? B::load_unaligned(in.tan2_i + i) : B(0.0);
        const B to = smith ? B::load_unaligned(in.tan2_o + i) : B(0.0);
        B s, ds;
        lobe_shape_packet(kind,
                          a,
                          B::load_unaligned(in.hxy2 + i),
                          B::load_unaligned(in.hz2 + i),
                          ti,
                          to,
                          B::load_unaligned(in.inv_4cc + i),
                          s,
                          ds);
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
        B s, ds;
        lobe_shape_packet(kind,
                          a,
                          B::load_aligned(hxy2),
                          B::load_aligned(hz2),
                          B::load_aligned(ti),
                          B::load_aligned(to),
                          B::load_aligned(inv),
                          s,
                          ds);
        alignas(64) double so[kW], dso[kW];
        s.store_aligned(so);
        ds.store_aligned(dso);
        std::copy(so, so + m, S + i);
        std::copy(dso, dso + m, dS + i);
    }
}

}  // namespace gonio::fitting::detail
