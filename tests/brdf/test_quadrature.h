#pragma once

// Quadrature over the hemisphere for the tests: midpoint rule in s and phi with theta = (pi/2) s^3,
// so that steps are finest near the normal where sharp distributions peak. Independent of the
// library's own albedo quadrature (which integrates over the half vector of a BRDF).

#include <cmath>

#include "gonio/brdf/coords.h"

namespace gonio::brdf::testing {

/// Integral over the upper hemisphere of g(w) dw (dw = sin(theta) dtheta dphi).
template <class G>
double integrate_hemisphere(G g, int n_theta = 1000, int n_phi = 400) {
    double sum = 0;
    const double ds = 1.0 / n_theta;
    const double dphi = 2.0 * kPi / n_phi;
    for (int i = 0; i < n_theta; ++i) {
        const double s = (i + 0.5) * ds;
        const double theta = 0.5 * kPi * s * s * s;
        const double dtheta = 1.5 * kPi * s * s * ds;
        const double sin_t = std::sin(theta);
        const double cos_t = std::cos(theta);
        double ring = 0;
        for (int j = 0; j < n_phi; ++j) {
            const double phi = (j + 0.5) * dphi;
            ring += g(Vec3d(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t));
        }
        sum += ring * sin_t * dtheta * dphi;
    }
    return sum;
}

}  // namespace gonio::brdf::testing
