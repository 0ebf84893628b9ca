#pragma once

// The instruction set of the packet kernels (the formulas on SIMD packets: brdf's evaluation,
// fitting's passes), chosen once per process for all of them: the widest set that this processor
// and its operating system run among those the build compiled kernels for (cmake/GonioIsa.cmake:
// AVX-512, AVX2 + FMA and SSE2 on x86-64; none with GONIO_PACKET_KERNELS=OFF, the default on
// other processors, where every dispatcher takes its scalar path).
//
// The environment variable GONIO_PACKET_ISA (scalar, sse2, avx2 or avx512) lowers the choice, e.g.
// to run the narrower kernels on a wide processor; a set wider than the processor's is not taken,
// and any other value stops the process with exit status 2, naming it.

#include <array>

namespace gonio {

/// Narrowest first: kScalar is the formula bodies on double, one lane at a time.
enum class Isa { kScalar, kSse2, kAvx2, kAvx512 };

/// The set of every packet kernel of this process: processor_isa(), lowered by
/// GONIO_PACKET_ISA where set; chosen once.
Isa packet_isa();

/// The widest set among the build's kernels that this processor and its operating system run
/// (kScalar in a build without packet kernels); tested at each call.
Isa processor_isa();

/// "scalar", "sse2", "avx2" or "avx512".
const char* isa_name(Isa isa);

/// The function for packet_isa(): `scalar` or kernels[sse2, avx2, avx512]. A dispatcher keeps it
/// in a function-local static and declares its kernels' copies with GONIO_ISA_DECLARE.
template <class Fn>
Fn isa_kernel(Fn scalar, const std::array<Fn, 3>& kernels) {
    const Isa isa = packet_isa();
    return isa == Isa::kScalar ? scalar : kernels[static_cast<int>(isa) - 1];
}

}  // namespace gonio

// In a dispatching source of a target with kernel files (gonio_add_isa_sources, which defines
// GONIO_PACKET_KERNELS): GONIO_ISA_DECLARE(declarations) declares the copies of a kernel file in
// the namespaces sse2, avx2 and avx512, and GONIO_ISA_KERNELS(ns, f) lists &ns::sse2::f,
// &ns::avx2::f, &ns::avx512::f for isa_kernel. Without packet kernels nothing is declared and the
// list is empty (packet_isa() is then kScalar).
#if defined(GONIO_PACKET_KERNELS) && GONIO_PACKET_KERNELS
#define GONIO_ISA_DECLARE(...) \
    namespace sse2 {           \
    __VA_ARGS__                \
    }                          \
    namespace avx2 {           \
    __VA_ARGS__                \
    }                          \
    namespace avx512 {         \
    __VA_ARGS__                \
    }
#define GONIO_ISA_KERNELS(ns, f) \
    { &ns::sse2::f, &ns::avx2::f, &ns::avx512::f }
#else
#define GONIO_ISA_DECLARE(...)
#define GONIO_ISA_KERNELS(ns, f) \
    {}
#endif
