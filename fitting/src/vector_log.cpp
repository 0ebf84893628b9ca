// log1p_packets: the copy of the kernel for gonio::packet_isa(), else std::log1p element by
// element.

#include "gonio/fitting/vector_log.h"

#include <cmath>

#include "gonio/base/instruction_set.h"

namespace gonio::fitting {

namespace detail {
// One copy per instruction set: isa/vector_log.cpp.
GONIO_ISA_DECLARE(void log1p(const double* x, double* y, std::size_t n);)
}  // namespace detail

namespace {

using Log1p = void (*)(const double*, double*, std::size_t);

void log1p_scalar(const double* x, double* y, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        y[i] = std::log1p(x[i]);
    }
}

}  // namespace

void log1p_packets(const double* x, double* y, std::size_t n) {
    static const Log1p f = isa_kernel<Log1p>(&log1p_scalar, GONIO_ISA_KERNELS(detail, log1p));
    f(x, y, n);
}

}  // namespace gonio::fitting
