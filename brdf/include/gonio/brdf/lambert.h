#pragma once

// The Lambertian (perfectly diffuse) BRDF.

#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// f = rho / pi for both directions above the horizon (cos_i = wi.z > 0, cos_o = wo.z > 0), 0
/// otherwise; one channel.
/// Source: J. H. Lambert, "Photometria", 1760; the 1/pi makes the directional albedo equal rho:
/// integral over the hemisphere of (rho/pi) cos(theta_o) d(wo) = rho.
/// Inputs: rho in [0, 1] (albedo). Output in 1/sr.
template <class T>
inline T lambert_from_cosines(const T& rho, const T& cos_i, const T& cos_o) {
    const auto below = mask_or(cos_i <= T(0), cos_o <= T(0));
    // Branch of the mask: at or below the horizon, no reflection.
    return select(below, T(0), rho * T(kInvPi));
}

/// f = rho / pi per RGB channel for unit wi, wo (see lambert_from_cosines).
template <class T>
inline Rgb<T> lambert(const Rgb<T>& rho, const Vec3<T>& wi, const Vec3<T>& wo) {
    return Rgb<T>(lambert_from_cosines(rho[0], T(wi.z()), T(wo.z())),
                  lambert_from_cosines(rho[1], T(wi.z()), T(wo.z())),
                  lambert_from_cosines(rho[2], T(wi.z()), T(wo.z())));
}

}  // namespace gonio::brdf
