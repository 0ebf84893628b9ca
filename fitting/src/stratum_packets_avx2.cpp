// The stratum coordinates on AVX2 + FMA (compiled with -mavx2 -mfma; called only where the CPU
// has both).

#include "stratum_kernel.h"

namespace gonio::fitting::detail {

void stratum_avx2(const StratumArrays& a, std::size_t n) {
    stratum_kernel<xsimd::fma3<xsimd::avx2>>(a, n);
}

}  // namespace gonio::fitting::detail
