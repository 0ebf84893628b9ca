// log1p_packets on one instruction set: compiled once per set (gonio_add_isa_sources,
// cmake/GonioIsa.cmake), which names the set (GONIO_ISA) and its xsimd architecture
// (GONIO_ISA_ARCH); vector_log.cpp chooses.

#include "../vector_log_kernel.h"

namespace gonio::fitting::detail::GONIO_ISA {

void log1p(const double* x, double* y, std::size_t n) {
    log1p_kernel<GONIO_ISA_ARCH>(x, y, n);
}

}  // namespace gonio::fitting::detail::GONIO_ISA
