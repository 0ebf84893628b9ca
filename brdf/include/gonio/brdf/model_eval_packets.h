#pragma once

// The analytic model evaluated on many direction pairs at once: structure of arrays in, structure
// of arrays out, the pairs taken a SIMD packet at a time through the same formula bodies as
// eval_model (model_eval.h, eval_model_lanes with T = xsimd::batch<double>).
//
// The packet width is the instruction set of every packet kernel (gonio/base/instruction_set.h),
// chosen once at run time from what the processor offers: AVX-512 (8 doubles), AVX2 with FMA (4),
// or the x86-64 baseline SSE2 (2); each is its own copy of the kernel compiled for that set only
// (brdf/src/isa/, cmake/GonioIsa.cmake), so the binary runs on any x86-64 processor. A build without
// packet kernels (GONIO_PACKET_KERNELS=OFF, the default off x86-64) evaluates pair by pair through
// the scalar body.

#include <cstddef>

#include "gonio/brdf/brdf.h"
#include "gonio/brdf/model.h"

namespace gonio::brdf {

/// f(wi_k, wo_k) of the model for k in [0, n): out[c][k] is channel c in 1/sr, 0 where either
/// direction is at or below the horizon (the same values as eval_model up to the stated agreement
/// of packets and scalars: see tests/brdf/unit_packet_formulas_test.cpp). Runs on the calling
/// thread; no allocation.
void eval_model_packets(const ModelD& m,
                        std::size_t n,
                        const DirectionPairs& dirs,
                        double* const out[3]);

/// The instruction set eval_model_packets runs on: "avx512", "avx2", "sse2" or "scalar"
/// (gonio::isa_name of gonio::packet_isa()).
const char* packet_instruction_set();

}  // namespace gonio::brdf
