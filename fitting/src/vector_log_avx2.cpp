// log1p_packets on AVX2 + FMA (compiled with -mavx2 -mfma; called only where the CPU has both).

#include "vector_log_kernel.h"

namespace gonio::fitting::detail {

void log1p_avx2(const double* x, double* y, std::size_t n) {
    log1p_kernel<xsimd::fma3<xsimd::avx2>>(x, y, n);
}

}  // namespace gonio::fitting::detail
