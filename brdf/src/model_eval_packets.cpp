// Run-time choice of the packet width for eval_model_packets (model_eval_packets.h).

#include "gonio/brdf/model_eval_packets.h"

#include <xsimd/xsimd.hpp>

#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {

namespace arch {

using EvalPackets = void (*)(const ModelD&, std::size_t, const DirectionPairs&, double* const[3]);

#if defined(GONIO_PACKETS_X86)
void eval_model_packets_avx512(const ModelD&, std::size_t, const DirectionPairs&, double* const[3]);
void eval_model_packets_avx2(const ModelD&, std::size_t, const DirectionPairs&, double* const[3]);
void eval_model_packets_sse2(const ModelD&, std::size_t, const DirectionPairs&, double* const[3]);
#else
void eval_model_packets_default(const ModelD&,
                                std::size_t,
                                const DirectionPairs&,
                                double* const[3]);
#endif

namespace {

struct Choice {
    EvalPackets eval;
    const char* name;
};

Choice choose() {
#if defined(GONIO_PACKETS_X86)
    // xsimd reads CPUID and XGETBV (the operating system must save the wide registers too).
    const auto isa = xsimd::available_architectures();
    if (isa.avx512bw) {
        return {&eval_model_packets_avx512, "avx512"};
    }
    if (isa.fma3_avx2) {
        return {&eval_model_packets_avx2, "avx2+fma"};
    }
    return {&eval_model_packets_sse2, "sse2"};
#else
    return {&eval_model_packets_default, "default"};
#endif
}

const Choice& chosen() {
    static const Choice c = choose();
    return c;
}

}  // namespace
}  // namespace arch

void eval_model_packets(const ModelD& m,
                        std::size_t n,
                        const DirectionPairs& dirs,
                        double* const out[3]) {
    for (const Lobe<double>& l : m.lobes) {
        if (l.distribution == Distribution::kStudentT ||
            l.distribution == Distribution::kTabulated) {
            // The Student-t Lambda's continued fraction iterates a data-dependent number of times,
            // and a table is looked up at each lane's value: lane by lane, through the same body.
            for (std::size_t k = 0; k < n; ++k) {
                double f[3];
                eval_model_lanes(m,
                                 Dir3<double>{dirs.wi_x[k], dirs.wi_y[k], dirs.wi_z[k]},
                                 Dir3<double>{dirs.wo_x[k], dirs.wo_y[k], dirs.wo_z[k]},
                                 f);
                for (int c = 0; c < 3; ++c) {
                    out[c][k] = f[c];
                }
            }
            return;
        }
    }
    arch::chosen().eval(m, n, dirs, out);
}

const char* packet_instruction_set() {
    return arch::chosen().name;
}

}  // namespace gonio::brdf
