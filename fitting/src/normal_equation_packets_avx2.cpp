// normal_equation_packets and cost_packets on AVX2 + FMA (compiled with -mavx2 -mfma; called
// only where the CPU has both).

#include "normal_equation_kernel.h"

namespace gonio::fitting::detail {

void normal_equation_avx2(const PacketModel& m,
                          const PacketInputs& in,
                          std::size_t begin,
                          std::size_t end,
                          int stride,
                          double* a,
                          double* b,
                          double* cost) {
    normal_equation_kernel<xsimd::avx2>(m, in, begin, end, stride, a, b, cost);
}

double cost_avx2(const PacketModel& m, const PacketInputs& in, std::size_t begin, std::size_t end) {
    return cost_kernel<xsimd::avx2>(m, in, begin, end);
}

}  // namespace gonio::fitting::detail
