// log1p_packets on AVX-512 (compiled with -mavx512f -mavx512dq; called only where the CPU has
// both).

#include "vector_log_kernel.h"

namespace gonio::fitting::detail {

void log1p_avx512(const double* x, double* y, std::size_t n) {
    log1p_kernel<xsimd::avx512f>(x, y, n);
}

}  // namespace gonio::fitting::detail
