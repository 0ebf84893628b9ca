// normal_equation_packets and cost_packets: the instruction set of log1p_packets, chosen once;
// SSE2 (every x86-64) here.

#include "gonio/fitting/normal_equation_packets.h"

#include <cstring>

#include "gonio/fitting/vector_log.h"
#include "normal_equation_kernel.h"

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

void normal_equation_packets(const PacketModel& model,
                             const PacketInputs& in,
                             std::size_t begin,
                             std::size_t end,
                             int stride,
                             double* a,
                             double* b,
                             double* cost) {
    switch (width_class()) {
        case 2:
            detail::normal_equation_avx512(model, in, begin, end, stride, a, b, cost);
            return;
        case 1:
            detail::normal_equation_avx2(model, in, begin, end, stride, a, b, cost);
            return;
        default:
            break;
    }
    detail::normal_equation_kernel<xsimd::sse2>(model, in, begin, end, stride, a, b, cost);
}

double cost_packets(const PacketModel& model,
                    const PacketInputs& in,
                    std::size_t begin,
                    std::size_t end) {
    switch (width_class()) {
        case 2:
            return detail::cost_avx512(model, in, begin, end);
        case 1:
            return detail::cost_avx2(model, in, begin, end);
        default:
            break;
    }
    return detail::cost_kernel<xsimd::sse2>(model, in, begin, end);
}

}  // namespace gonio::fitting
