// The stratum coordinates on one instruction set: compiled once per set (gonio_add_isa_sources,
// cmake/GonioIsa.cmake), which names the set (GONIO_ISA) and its xsimd architecture
// (GONIO_ISA_ARCH); reduction.cpp chooses.

#include "../stratum_kernel.h"

namespace gonio::fitting::detail::GONIO_ISA {

void stratum(const StratumArrays& a, std::size_t n) {
    stratum_kernel<GONIO_ISA_ARCH>(a, n);
}

}  // namespace gonio::fitting::detail::GONIO_ISA
