#pragma once

// The normalised Blinn-Phong lobe, kept to compare with pre-PBR practice. It is used as a
// microfacet distribution D inside the same f = scale F D G / (4 cos_i cos_o) form as GGX and
// Beckmann, so its values compare directly with theirs.

#include <cmath>
#include <limits>

#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// The normalised Blinn-Phong distribution (D_blinn_phong below) from log(cos(theta_h)), finite
/// (callers that precompute it for many exponents mask cos^e = 0 themselves).
template <class T>
inline T D_blinn_phong_from_log_cos(const T& log_cos_h, const T& exponent) {
    using std::exp;
    return (exponent + T(2)) / T(2 * kPi) * exp(exponent * log_cos_h);
}

/// log cos(theta_h) of a unit h from hxy2 = h_x^2 + h_y^2 and h_z, as log1p(-hxy2 / (1 + h_z))
/// (1 - cos = sin^2 / (1 + cos): no cancellation near the normal). Edge behaviour: -infinity for
/// h_z <= 0 and where 1 - cos rounds to 1 or above (cos^e underflows there).
template <class T>
inline T log_cos_theta_h(const T& hxy2, const T& h_z) {
    using std::log1p;
    const T one_minus_cos = hxy2 / (T(1) + h_z);
    const auto underflow = mask_or(h_z <= T(0), one_minus_cos >= T(1));
    // The masked lanes evaluate log1p(0) and are replaced by -infinity below.
    const T log_cos = log1p(-select(underflow, T(0), one_minus_cos));
    // Branch of the mask: below the horizon or cos^e underflowing.
    return select(underflow, T(-std::numeric_limits<double>::infinity()), log_cos);
}

/// Normalised Blinn-Phong distribution  D(h) = (e + 2) / (2 pi) cos^e(theta_h).
/// Source: J. F. Blinn, "Models of Light Reflection for Computer Synthesized Pictures", SIGGRAPH
/// 1977 (the cos^e(theta_h) lobe); normalisation over projected area as in B. Walter et al.,
/// "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007, eq. 30:
/// integral of D(h) cos(theta_h) dh over the hemisphere = (e + 2)/(e + 2) = 1.
/// Inputs: h unit, exponent e > 0. Output in 1/sr. Edge behaviour: 0 for h_z <= 0.
/// cos^e is evaluated as exp(e log1p(-(h_x^2 + h_y^2)/(1 + h_z))), using 1 - cos = sin^2/(1 + cos):
/// with pow(h_z, e) the rounding of h_z would be multiplied by e (1e-9 relative at e = 1e7).
template <class T>
inline T D_blinn_phong(const Vec3<T>& h, const T& exponent) {
    const T log_cos = log_cos_theta_h(h.x() * h.x() + h.y() * h.y(), h.z());
    const auto underflow = !(log_cos > T(-std::numeric_limits<double>::infinity()));
    if (all_of(underflow)) {
        // Below the horizon (microfacet normals face outward only) or cos^e underflowing.
        return T(0);
    }
    // Branch of the mask: below the horizon or cos^e underflowing, D = 0.
    return select(
        underflow, T(0), D_blinn_phong_from_log_cos(select(underflow, T(0), log_cos), exponent));
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
