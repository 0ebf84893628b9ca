#pragma once

// The packet loop of log1p_packets (fitting/vector_log.h) for one instruction set; each
// copy of isa/vector_log.cpp instantiates it with its own compile flags.

#include <algorithm>
#include <cstddef>
#include <xsimd/xsimd.hpp>

namespace gonio::fitting::detail {

template <class Arch>
void log1p_kernel(const double* x, double* y, std::size_t n) {
    using B = xsimd::batch<double, Arch>;
    constexpr std::size_t kW = B::size;
    std::size_t i = 0;
    for (; i + kW <= n; i += kW) {
        xsimd::log1p(B::load_unaligned(x + i)).store_unaligned(y + i);
    }
    if (i < n) {
        // The last partial packet, padded with zeros.
        alignas(64) double tail[kW] = {};
        std::copy(x + i, x + n, tail);
        xsimd::log1p(B::load_unaligned(tail)).store_unaligned(tail);
        std::copy(tail, tail + (n - i), y + i);
    }
}

}  // namespace gonio::fitting::detail
