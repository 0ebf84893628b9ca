// eval_model_packets on the compiler's default xsimd architecture (processors other than x86-64).

#include "eval_packets_impl.h"

namespace gonio::brdf::arch {

void eval_model_packets_default(const ModelD& m,
                                std::size_t n,
                                const DirectionPairs& dirs,
                                double* const out[3]) {
    eval_model_packets_on<xsimd::default_arch>(m, n, dirs, out);
}

}  // namespace gonio::brdf::arch
