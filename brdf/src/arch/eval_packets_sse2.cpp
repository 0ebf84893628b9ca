// eval_model_packets on SSE2, the x86-64 baseline: 2 doubles per packet.

#include "eval_packets_impl.h"

namespace gonio::brdf::arch {

void eval_model_packets_sse2(const ModelD& m,
                             std::size_t n,
                             const DirectionPairs& dirs,
                             double* const out[3]) {
    eval_model_packets_on<xsimd::sse2>(m, n, dirs, out);
}

}  // namespace gonio::brdf::arch
