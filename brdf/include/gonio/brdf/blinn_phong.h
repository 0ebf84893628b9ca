#pragma once

// The normalised Blinn-Phong lobe, kept to compare with pre-PBR practice. It is used as a
// microfacet distribution D inside the same f = scale F D G / (4 cos_i cos_o) form as GGX and
// Beckmann, so its values compare directly with theirs.

#include <cmath>

#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// Normalised Blinn-Phong distribution  D(h) = (e + 2) / (2 pi) cos^e(theta_h).
/// Source: J. F. Blinn, "Models of Light Reflection for Computer Synthesized Pictures", SIGGRAPH
/// 1977 (the cos^e(theta_h) lobe); normalisation over projected area as in B. Walter et al.,
/// "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007, eq. 30:
/// integral of D(h) cos(theta_h) dh over the hemisphere = (e + 2)/(e + 2) = 1.
/// Inputs: h unit, exponent e > 0. Output in 1/sr. Edge behaviour: 0 for h_z <= 0.
template <class T>
inline T D_blinn_phong(const Vec3<T>& h, const T& exponent) {
    using std::pow;
    if (h.z() <= T(0)) {
        // Microfacet normals face outward only (and pow(0, e) would have an infinite log).
        return T(0);
    }
    return (exponent + T(2)) / T(2 * kPi) * pow(h.z(), exponent);
}

/// The Beckmann slope parameter whose distribution matches the Blinn-Phong one near the normal:
/// alpha = sqrt(2 / (e + 2))  (Walter et al. 2007, sec. 5.2). Used for the Smith Lambda of a
/// Blinn-Phong lobe, which has no closed form of its own; the resulting G is an approximation
/// (the two distributions agree to a few percent for e > 10 and differ in the far tail).
template <class T>
inline T blinn_phong_equivalent_alpha(const T& exponent) {
    using std::sqrt;
    return sqrt(T(2) / (exponent + T(2)));
}

}  // namespace gonio::brdf
