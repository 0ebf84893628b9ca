// eval_model_packets on AVX-512 (F, CD, DQ, BW): 8 doubles per packet.

#include "eval_packets_impl.h"

namespace gonio::brdf::arch {

void eval_model_packets_avx512(const ModelD& m,
                               std::size_t n,
                               const DirectionPairs& dirs,
                               double* const out[3]) {
    eval_model_packets_on<xsimd::avx512bw>(m, n, dirs, out);
}

}  // namespace gonio::brdf::arch
