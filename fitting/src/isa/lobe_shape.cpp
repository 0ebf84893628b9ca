// lobe_shape_packets on one instruction set: compiled once per set (gonio_add_isa_sources,
// cmake/GonioIsa.cmake), which names the set (GONIO_ISA) and its xsimd architecture
// (GONIO_ISA_ARCH); lobe_shape_packets.cpp chooses.

#include "../lobe_shape_kernel.h"

namespace gonio::fitting::detail::GONIO_ISA {

void lobe_shape(const LobeShapeKind& kind,
                double alpha,
                const LobeShapeInputs& in,
                std::size_t n,
                double* S,
                double* dS) {
    lobe_shape_kernel<GONIO_ISA_ARCH>(kind, alpha, in, n, S, dS);
}

}  // namespace gonio::fitting::detail::GONIO_ISA
