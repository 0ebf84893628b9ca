#pragma once

// The path of an exposure taken while the arms move (fly scans, docs/rig-time.md).
//
// A goniometer arm turns about a fixed axis perpendicular to it, so while it cruises at constant
// speed its direction runs along a great circle at constant angular speed; in the sample's frame
// (tilt and spin standing) it is still a great circle. An exposure from t = 0 to t = T therefore
// sees the directions
//   w(t) = slerp(w_start, w_end, t / T),   slerp(a, b, u) = (sin((1 - u) g) a + sin(u g) b) / sin g
// with g the angle between a and b (Shoemake, "Animating rotation with quaternion curves",
// SIGGRAPH 1985). The camera integrates the radiance f(wi, wo) E cos(theta_i) over the exposure;
// the value a campaign writes divides the mean rate by E cos(theta_i) at mid-exposure, so a swept
// sample measures
//   v = (1/T) int_0^T f(wi(t), wo(t)) cos(theta_i(t)) dt / cos(theta_i(T/2)).
// The mean is taken by composite Gauss-Legendre quadrature along the path (Abramowitz and Stegun,
// "Handbook of Mathematical Functions", 25.4.29): the path is cut into equal pieces no longer than
// a given angle, each integrated with n nodes (exact for polynomials of degree 2n - 1 in t).

#include <utility>
#include <vector>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// Gauss-Legendre nodes x[k] and weights w[k] on [0, 1] (the weights sum to 1), n in [1, 64].
void gauss_legendre_unit(int n, double* x, double* w);

/// The direction a fraction u of the way along the great-circle arc from a to b (unit vectors; a
/// and b nearly equal: a linear blend renormalised). Opposite directions have no unique arc and
/// are refused by the callers (exposure_path_nodes).
Vec3d slerp_direction(const Vec3d& a, const Vec3d& b, double u);

/// One node of an exposure's mean: the directions there and the weight (the weights sum to 1).
struct PathNode {
    Vec3d wi;
    Vec3d wo;
    double weight = 0;
};

/// Nodes of the mean over an exposure whose directions run from (wi0, wo0) to (wi1, wo1): the
/// longer of the two arcs cut into ceil(arc / max_piece_rad) pieces (at least 1, at most
/// max_pieces), each with `per_piece` Gauss-Legendre nodes.
std::vector<PathNode> exposure_path_nodes(const Vec3d& wi0,
                                          const Vec3d& wo0,
                                          const Vec3d& wi1,
                                          const Vec3d& wo1,
                                          double max_piece_rad,
                                          int per_piece,
                                          int max_pieces = 4096);

/// What a swept sample measures (see above): sum_k weight_k f(wi_k, wo_k) cos_i_k / cos_i_mid, for
/// any numeric type T of the values f returns (double, a Ceres Jet, ...): the one body of the
/// exposure mean. `f(wi, wo)` returns Rgb<T>.
template <class T, class F>
Rgb<T> exposure_path_mean(const std::vector<PathNode>& nodes, double cos_i_mid, const F& f) {
    Rgb<T> sum = Rgb<T>::Constant(T(0));
    for (const PathNode& n : nodes) {
        sum += f(n.wi, n.wo) * T(n.weight * n.wi.z() / cos_i_mid);
    }
    return sum;
}

}  // namespace gonio::brdf
