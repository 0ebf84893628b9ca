// lobe_shape_packets: the instruction set of log1p_packets, chosen once; SSE2 (every x86-64) here.

#include "gonio/fitting/lobe_shape_packets.h"

#include <cstring>

#include "gonio/fitting/vector_log.h"
#include "lobe_shape_kernel.h"

namespace gonio::fitting {

namespace {

/// 2: AVX-512, 1: AVX2 + FMA, 0: SSE2; the CPU test of vector_log.cpp.
int width_class() {
    static const int w = std::strcmp(log1p_packets_arch(), "avx512") == 0 ? 2
                         : std::strcmp(log1p_packets_arch(), "avx2") == 0 ? 1
                                                                          : 0;
    return w;
}

}  // namespace

void lobe_shape_packets(const LobeShapeKind& kind,
                        double alpha,
                        const LobeShapeInputs& in,
                        std::size_t n,
                        double* S,
                        double* dS) {
    switch (width_class()) {
        case 2:
            detail::lobe_shape_avx512(kind, alpha, in, n, S, dS);
            return;
        case 1:
            detail::lobe_shape_avx2(kind, alpha, in, n, S, dS);
            return;
        default:
            break;
    }
    detail::lobe_shape_kernel<xsimd::sse2>(kind, alpha, in, n, S, dS);
}

}  // namespace gonio::fitting
