// lobe_shape_packets on AVX-512 (compiled with -mavx512f -mavx512dq; called only where the CPU has
// both).

#include "lobe_shape_kernel.h"

namespace gonio::fitting::detail {

void lobe_shape_avx512(const LobeShapeKind& kind,
                       double alpha,
                       const LobeShapeInputs& in,
                       std::size_t n,
                       double* S,
                       double* dS) {
    lobe_shape_kernel<xsimd::avx512f>(kind, alpha, in, n, S, dS);
}

}  // namespace gonio::fitting::detail
