#pragma once

// The Lambertian (perfectly diffuse) BRDF.

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// f = rho / pi for both directions above the horizon, 0 otherwise.
/// Source: J. H. Lambert, "Photometria", 1760; the 1/pi makes the directional albedo equal rho:
/// integral over the hemisphere of (rho/pi) cos(theta_o) d(wo) = rho.
/// Inputs: rho in [0, 1] per channel (albedo), wi, wo unit. Output in 1/sr.
template <class T>
inline Rgb<T> lambert(const Rgb<T>& rho, const Vec3<T>& wi, const Vec3<T>& wo) {
    if (wi.z() <= T(0) || wo.z() <= T(0)) {
        // At or below the horizon: no reflection.
        return Rgb<T>::Zero();
    }
    return rho * T(kInvPi);
}

}  // namespace gonio::brdf
