// The stratum coordinates on AVX-512 (compiled with -mavx512f -mavx512dq; called only where the
// CPU has both).

#include "stratum_kernel.h"

namespace gonio::fitting::detail {

void stratum_avx512(const StratumArrays& a, std::size_t n) {
    stratum_kernel<xsimd::avx512f>(a, n);
}

}  // namespace gonio::fitting::detail
