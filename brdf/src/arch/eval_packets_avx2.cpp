// eval_model_packets on AVX2 with FMA: 4 doubles per packet.

#include "eval_packets_impl.h"

namespace gonio::brdf::arch {

void eval_model_packets_avx2(const ModelD& m,
                             std::size_t n,
                             const DirectionPairs& dirs,
                             double* const out[3]) {
    eval_model_packets_on<xsimd::fma3<xsimd::avx2>>(m, n, dirs, out);
}

}  // namespace gonio::brdf::arch
