// lobe_shape_packets on AVX2 + FMA (compiled with -mavx2 -mfma; called only where the CPU has
// both).

#include "lobe_shape_kernel.h"

namespace gonio::fitting::detail {

void lobe_shape_avx2(const LobeShapeKind& kind,
                     double alpha,
                     const LobeShapeInputs& in,
                     std::size_t n,
                     double* S,
                     double* dS) {
    lobe_shape_kernel<xsimd::fma3<xsimd::avx2>>(kind, alpha, in, n, S, dS);
}

}  // namespace gonio::fitting::detail
