// log1p_packets: the widest instruction set of this CPU, chosen once; SSE2 (every x86-64) here.

#include "gonio/fitting/vector_log.h"

#include "vector_log_kernel.h"

namespace gonio::fitting {

namespace {

enum class LogArch {
    kSse2,    ///< Baseline x86-64: 2 doubles per packet.
    kAvx2,    ///< AVX2 + FMA: 4 doubles per packet.
    kAvx512,  ///< AVX-512 F + DQ: 8 doubles per packet.
};

/// The compiler's CPU test (it also checks that the operating system saves the wide registers).
LogArch detect() {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq")) {
        return LogArch::kAvx512;
    }
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
        return LogArch::kAvx2;
    }
    return LogArch::kSse2;
}

LogArch arch() {
    static const LogArch a = detect();
    return a;
}

}  // namespace

void log1p_packets(const double* x, double* y, std::size_t n) {
    switch (arch()) {
        case LogArch::kAvx512:
            detail::log1p_avx512(x, y, n);
            return;
        case LogArch::kAvx2:
            detail::log1p_avx2(x, y, n);
            return;
        case LogArch::kSse2:
            break;
    }
    detail::log1p_kernel<xsimd::sse2>(x, y, n);
}

const char* log1p_packets_arch() {
    switch (arch()) {
        case LogArch::kAvx512:
            return "avx512";
        case LogArch::kAvx2:
            return "avx2";
        case LogArch::kSse2:
            break;
    }
    return "sse2";
}

}  // namespace gonio::fitting
