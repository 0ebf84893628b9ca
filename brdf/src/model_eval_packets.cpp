// The run-time choice of eval_model_packets (model_eval_packets.h): the copy of the packet kernel
// for the instruction set of gonio::packet_isa(), else lane by lane through the scalar body.

#include "gonio/brdf/model_eval_packets.h"

#include "gonio/base/instruction_set.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {

namespace arch {

// One copy per instruction set: isa/eval_packets.cpp.
GONIO_ISA_DECLARE(void eval_model_packets(const ModelD& m,
                                          std::size_t n,
                                          const DirectionPairs& dirs,
                                          double* const out[3]);)

using EvalPackets = void (*)(const ModelD&, std::size_t, const DirectionPairs&, double* const[3]);

namespace {

/// The scalar body, one pair at a time.
void eval_model_scalar(const ModelD& m,
                       std::size_t n,
                       const DirectionPairs& dirs,
                       double* const out[3]) {
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
}

EvalPackets chosen() {
    static const EvalPackets f =
        isa_kernel<EvalPackets>(&eval_model_scalar, GONIO_ISA_KERNELS(arch, eval_model_packets));
    return f;
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
            arch::eval_model_scalar(m, n, dirs, out);
            return;
        }
    }
    arch::chosen()(m, n, dirs, out);
}

const char* packet_instruction_set() {
    return isa_name(packet_isa());
}

}  // namespace gonio::brdf
