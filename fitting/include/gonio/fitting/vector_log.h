#pragma once

// log(1 + x) over arrays on SIMD packets, for the log residual of the fitting passes
// (fitting/cost.h: g(x) = log(1 + x cos_i)).

#include <cstddef>

namespace gonio::fitting {

/// y[k] = log(1 + x[k]) for k < n (x and y may be the same array). xsimd's log1p on the packets
/// of gonio::packet_isa() (AVX-512: 8 doubles, AVX2 + FMA: 4, SSE2: 2; base/instruction_set.h),
/// the last partial packet padded, so that every element goes through the same code; std::log1p
/// in a build without packet kernels.
/// Accuracy: within 1 ulp of a correctly rounded log1p for x in [0, 1e300] (checked against
/// std::log1p on seeded grids over 1e-300 .. 1e300 and at 0, the smallest subnormal and 1 by
/// tests/fitting/unit_vector_log_test.cpp); x = 0 gives 0, x = +inf gives +inf, x < -1 or NaN
/// gives NaN (the fitting passes then report a non-finite residual).
void log1p_packets(const double* x, double* y, std::size_t n);

}  // namespace gonio::fitting
