// normal_equation_packets and cost_packets on one instruction set: compiled once per set
// (gonio_add_isa_sources, cmake/GonioIsa.cmake), which names the set (GONIO_ISA) and its xsimd
// architecture (GONIO_ISA_ARCH); normal_equation_packets.cpp chooses.

#include "../normal_equation_kernel.h"

namespace gonio::fitting::detail::GONIO_ISA {

void normal_equation(const PacketModel& m,
                     const PacketInputs& in,
                     std::size_t begin,
                     std::size_t end,
                     int stride,
                     double* a,
                     double* b,
                     double* cost) {
    normal_equation_kernel<GONIO_ISA_ARCH>(m, in, begin, end, stride, a, b, cost);
}

double cost(const PacketModel& m, const PacketInputs& in, std::size_t begin, std::size_t end) {
    return cost_kernel<GONIO_ISA_ARCH>(m, in, begin, end);
}

}  // namespace gonio::fitting::detail::GONIO_ISA
