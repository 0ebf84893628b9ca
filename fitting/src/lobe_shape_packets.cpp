// lobe_shape_packets: the copy of the kernel for gonio::packet_isa(), else the same shape body on
// double, sample by sample.

#include "gonio/fitting/lobe_shape_packets.h"

#include "gonio/base/instruction_set.h"
#include "lobe_shape_kernel.h"

namespace gonio::fitting {

namespace detail {
// One copy per instruction set: isa/lobe_shape.cpp.
GONIO_ISA_DECLARE(void lobe_shape(const LobeShapeKind& kind,
                                  double alpha,
                                  const LobeShapeInputs& in,
                                  std::size_t n,
                                  double* S,
                                  double* dS);)
}  // namespace detail

namespace {

using LobeShape =
    void (*)(const LobeShapeKind&, double, const LobeShapeInputs&, std::size_t, double*, double*);

void lobe_shape_scalar(const LobeShapeKind& kind,
                       double alpha,
                       const LobeShapeInputs& in,
                       std::size_t n,
                       double* S,
                       double* dS) {
    const bool smith = kind.smith != 0;
    for (std::size_t i = 0; i < n; ++i) {
        S[i] = detail::lobe_shape_packet<true>(kind,
                                               alpha,
                                               in.hxy2[i],
                                               in.hz2[i],
                                               smith ? in.tan2_i[i] : 0.0,
                                               smith ? in.tan2_o[i] : 0.0,
                                               in.inv_4cc[i],
                                               &dS[i]);
    }
}

}  // namespace

void lobe_shape_packets(const LobeShapeKind& kind,
                        double alpha,
                        const LobeShapeInputs& in,
                        std::size_t n,
                        double* S,
                        double* dS) {
    static const LobeShape f =
        isa_kernel<LobeShape>(&lobe_shape_scalar, GONIO_ISA_KERNELS(detail, lobe_shape));
    f(kind, alpha, in, n, S, dS);
}

}  // namespace gonio::fitting
