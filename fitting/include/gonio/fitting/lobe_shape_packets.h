#pragma once

// The shape S = D G / (4 cos_i cos_o) of an isotropic GGX or Beckmann lobe and its derivative
// dS/dalpha over arrays of precomputed sample quantities, on SIMD packets, for the closed-form
// derivatives of the fitting passes (prepared_samples.h). The formula bodies are brdf/'s
// (microfacet.h and their width derivatives in microfacet_derivatives.h), instantiated on
// xsimd packets.

#include <cstddef>

namespace gonio::fitting {

/// The per-sample quantities the shape takes, each an array of n doubles.
struct LobeShapeInputs {
    const double* hxy2 = nullptr;     ///< h_x^2 + h_y^2 of the half vector (in the lobe's frame).
    const double* hz2 = nullptr;      ///< h_z^2.
    const double* tan2_i = nullptr;   ///< tan^2 theta_i (unused without shadowing).
    const double* tan2_o = nullptr;   ///< tan^2 theta_o (unused without shadowing).
    const double* inv_4cc = nullptr;  ///< 1 / (4 cos_i cos_o).
};

/// Which D and which G.
struct LobeShapeKind {
    bool beckmann = false;  ///< Beckmann's D and Lambda, else GGX's.
    /// 0: no shadowing (G = 1), 1: height-correlated Smith, 2: separable Smith.
    int smith = 0;
};

/// S[k] and dS[k] = dS/dalpha of the isotropic lobe of width alpha at sample k, k < n. The
/// same values as the scalar formulas evaluated sample by sample: within the agreement of
/// packets and scalars stated in tests/fitting/unit_lobe_shape_packets_test.cpp. The widest
/// packets of this CPU (the instruction set of log1p_packets, vector_log.h); the last partial
/// packet is padded so that every sample goes through the same code.
void lobe_shape_packets(const LobeShapeKind& kind,
                        double alpha,
                        const LobeShapeInputs& in,
                        std::size_t n,
                        double* S,
                        double* dS);

}  // namespace gonio::fitting
