// The one choice of the packet kernels' instruction set (instruction_set.h).

#include "gonio/base/instruction_set.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace gonio {

/// The compiler's CPU test: CPUID, and XGETBV for whether the operating system saves the wide
/// registers.
Isa processor_isa() {
#if GONIO_PACKET_KERNELS && (defined(__x86_64__) || defined(_M_X64))
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512cd") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("fma")) {
        return Isa::kAvx512;
    }
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
        return Isa::kAvx2;
    }
    return Isa::kSse2;
#else
    return Isa::kScalar;
#endif
}

namespace {

/// GONIO_PACKET_ISA, where set: the widest set allowed.
Isa allowed_isa() {
    const char* v = std::getenv("GONIO_PACKET_ISA");
    if (v == nullptr || *v == '\0') {
        return Isa::kAvx512;
    }
    for (Isa isa : {Isa::kScalar, Isa::kSse2, Isa::kAvx2, Isa::kAvx512}) {
        if (std::strcmp(v, isa_name(isa)) == 0) {
            return isa;
        }
    }
    std::fprintf(stderr, "gonio: GONIO_PACKET_ISA=%s: expected scalar, sse2, avx2 or avx512\n", v);
    std::exit(2);
}

}  // namespace

Isa packet_isa() {
    static const Isa isa = [] {
        const Isa cpu = processor_isa();
        const Isa allowed = allowed_isa();
        return static_cast<int>(allowed) < static_cast<int>(cpu) ? allowed : cpu;
    }();
    return isa;
}

const char* isa_name(Isa isa) {
    switch (isa) {
        case Isa::kSse2:
            return "sse2";
        case Isa::kAvx2:
            return "avx2";
        case Isa::kAvx512:
            return "avx512";
        case Isa::kScalar:
            break;
    }
    return "scalar";
}

}  // namespace gonio
