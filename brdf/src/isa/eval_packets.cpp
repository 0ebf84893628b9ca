// eval_model_packets on one instruction set: compiled once per set (gonio_add_isa_sources,
// cmake/GonioIsa.cmake), which names the set (GONIO_ISA) and its xsimd architecture
// (GONIO_ISA_ARCH).

#include "eval_packets_impl.h"

namespace gonio::brdf::arch::GONIO_ISA {

void eval_model_packets(const ModelD& m,
                        std::size_t n,
                        const DirectionPairs& dirs,
                        double* const out[3]) {
    eval_model_packets_on<GONIO_ISA_ARCH>(m, n, dirs, out);
}

}  // namespace gonio::brdf::arch::GONIO_ISA
