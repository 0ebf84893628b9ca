// normal_equation_packets and cost_packets: the copies of the kernel for gonio::packet_isa().
// A build without packet kernels has none: PreparedSamples then takes its per-sample passes
// (prepared_samples.cpp) and never calls these.

#include "gonio/fitting/normal_equation_packets.h"

#include "gonio/base/check.h"
#include "gonio/base/instruction_set.h"

namespace gonio::fitting {

namespace detail {
// One copy per instruction set: isa/normal_equation.cpp.
GONIO_ISA_DECLARE(
    void normal_equation(const PacketModel& m,
                         const PacketInputs& in,
                         std::size_t begin,
                         std::size_t end,
                         int stride,
                         double* a,
                         double* b,
                         double* cost);
    double cost(const PacketModel& m, const PacketInputs& in, std::size_t begin, std::size_t end);)
}  // namespace detail

namespace {

using NormalEquation = void (*)(const PacketModel&,
                                const PacketInputs&,
                                std::size_t,
                                std::size_t,
                                int,
                                double*,
                                double*,
                                double*);
using Cost = double (*)(const PacketModel&, const PacketInputs&, std::size_t, std::size_t);

void no_normal_equation(const PacketModel&,
                        const PacketInputs&,
                        std::size_t,
                        std::size_t,
                        int,
                        double*,
                        double*,
                        double*) {
    GONIO_CHECK_MSG(false, "normal_equation_packets in a build without packet kernels");
}

double no_cost(const PacketModel&, const PacketInputs&, std::size_t, std::size_t) {
    GONIO_CHECK_MSG(false, "cost_packets in a build without packet kernels");
    return 0.0;
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
    static const NormalEquation f =
        isa_kernel<NormalEquation>(&no_normal_equation, GONIO_ISA_KERNELS(detail, normal_equation));
    f(model, in, begin, end, stride, a, b, cost);
}

double cost_packets(const PacketModel& model,
                    const PacketInputs& in,
                    std::size_t begin,
                    std::size_t end) {
    static const Cost f = isa_kernel<Cost>(&no_cost, GONIO_ISA_KERNELS(detail, cost));
    return f(model, in, begin, end);
}

}  // namespace gonio::fitting
