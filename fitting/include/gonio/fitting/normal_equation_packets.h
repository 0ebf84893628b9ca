#pragma once

// The fused pass of the log residual on SIMD packets: model values, residuals, their derivatives
// and the sums of the normal equations for a range of prepared samples, in structure-of-arrays
// form, for models whose every lobe is an isotropic GGX or Beckmann lobe with no or Smith
// shadowing and a Schlick or no Fresnel term (prepared_samples.h uses it for such structures).
//
// Per sample and channel c (fitting/cost.h, residual form kLog):
//   f_c = rho_c / pi + sum_l scale_lc F_lc S_l,   F = f0 + (1 - f0) x5 (Schlick) or 1,
//   r_c = s_c (log(1 + f_c cos_i) - g_d_c),        dr_c/df_c = s_c cos_i / (1 + f_c cos_i),
//   v_c,k = dr_c/df_c df_c/d(slot k)  (the table of prepared_samples.h analytic_parts),
// and the sums over the samples of r_c^2, r_c v_c and v_c v_c^T, per channel. The shapes S_l
// and dS_l/dalpha are brdf/'s formula bodies (lobe_shape_packets.h), the logarithm is xsimd's
// log1p (the accuracy stated in vector_log.h).
//
// Sums: each lane of a packet keeps its own partial sums in double; the lanes are added in lane
// order at the end of the range. The result depends on the range and on the packet width of the
// CPU (chosen once per process), never on how ranges are shared between threads.

#include <cstddef>

#include "gonio/brdf/model.h"
#include "gonio/fitting/lobe_shape_packets.h"

namespace gonio::fitting {

/// What a derivative slot is a derivative of.
enum class PacketSlot {
    kZero,     ///< Not a parameter of the model values (derivative 0).
    kDiffuse,  ///< rho_c: df_c = 1 / pi.
    kWidth,    ///< alpha of lobe l: scale_lc F_lc dS_l/dalpha.
    kScale,    ///< scale_lc: F_lc S_l.
    kF0,       ///< f0_lc of a Schlick lobe: scale_lc (1 - x5) S_l.
};

/// The model at the point of the pass, in the form the packets take.
struct PacketModel {
    static constexpr int kMaxLobes = 8;
    static constexpr int kMaxSlots = 16;
    int lobes = 0;
    LobeShapeKind kind[kMaxLobes];
    double alpha[kMaxLobes] = {};
    brdf::Fresnel<double> fresnel[kMaxLobes];  ///< Schlick's or none.
    double scale[kMaxLobes][3] = {};
    double diffuse[3] = {};  ///< rho_c / pi (0 without a diffuse term).
    int slots = 0;           ///< At most kMaxSlots.
    PacketSlot slot[kMaxSlots] = {};
    int slot_lobe[kMaxSlots] = {};
};

/// The prepared arrays (prepared_samples.h), each indexed by sample.
struct PacketInputs {
    const double* hxy2 = nullptr;
    const double* hz2 = nullptr;
    const double* tan2_i = nullptr;  ///< Needed when a lobe has Smith shadowing.
    const double* tan2_o = nullptr;
    const double* inv_4cc = nullptr;
    const double* x5 = nullptr;  ///< (1 - cos_d)^5; needed when a lobe has a Schlick term.
    const double* cos_i = nullptr;
    const double* g_d[3] = {};  ///< log(1 + d_c cos_i).
    const double* s[3] = {};    ///< The residual factors.
};

/// Sums over samples [begin, end) of the fused pass. `a` receives per channel c the K x K matrix
/// sum v_c v_c^T (column-major, a + c K K, its upper triangle filled; K = `stride` >= slots), `b`
/// per channel the K-vector sum r_c v_c (b + c K), `cost` the sum of r_c^2 over the channels.
/// Entries for slots beyond model.slots are 0. Non-finite residuals or derivatives make the sums
/// non-finite.
void normal_equation_packets(const PacketModel& model,
                             const PacketInputs& in,
                             std::size_t begin,
                             std::size_t end,
                             int stride,
                             double* a,
                             double* b,
                             double* cost);

/// The sum over samples [begin, end) of r_c^2 over the channels alone (no derivatives).
double cost_packets(const PacketModel& model,
                    const PacketInputs& in,
                    std::size_t begin,
                    std::size_t end);

}  // namespace gonio::fitting
