#pragma once

// Pure geometry of the standard four-axis gonioreflectometer layout (two arms, tilt, spin). It
// lives in brdf/ so that both the acquisition planner and the simulated rig compute the same
// directions.
//
// World frame W (right-handed):
// - both arms rotate about W_z in the horizontal arm plane z = 0. The light arm at angle a_L points
//   from the sample toward the lamp along l = (cos a_L, sin a_L, 0); the detector arm at a_D along
//   v = (cos a_D, sin a_D, 0). Arm angles are measured from W_x toward W_y.
// - the sample at rest (tilt = spin = 0) has its normal (local z) along W_x, its reference
//   direction (local x, phi = 0) along W_y and its local y along W_z. As a matrix whose columns are
//   the local axes written in W: B0 = [W_y | W_z | W_x].
// - the sample orientation is B(t, s) = R_y(t) * B0 * R_z(s): first a spin s about the sample's own
//   normal (rotates the sample in its plane; changes phi only), then a tilt t about W_y (a
//   horizontal axis perpendicular to the normal at rest), which takes the normal out of the arm
//   plane: n(t) = (cos t, 0, -sin t). With t != 0 the plane of incidence no longer contains the
//   normal, which is what makes out-of-plane configurations (delta_phi != pi) reachable.
// - a world direction w is seen in the sample frame as B^T w, so wi = B^T l, wo = B^T v. Written
// out
//   before the spin: u(a) = (sin a, sin t cos a, cos t cos a), then wi = R_z(-s) u(a_L).
//   In particular cos theta_i = cos t cos a_L.
//
// Inverse: the arms can only place wi and wo in the arm plane, which in the sample frame is the
// great circle with normal m = R_z(-s) (0, cos t, -sin t). A target pair (wi, wo) fixes that plane
// up to its sign: m = +-(wi x wo)/|wi x wo|, giving two solutions (sigma = +1, -1) per target; spin
// adds the 2 pi periodicity that the caller resolves against the axis limits. The angle between the
// arms equals the angle between wi and wo (rotations preserve angles), so the detector's blind zone
// |a_L - a_D| < blind angle is a property of the target alone.
//
// Radians throughout. Axis positions in degrees on the wire are the same angles in degrees.

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <utility>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// Positions of the four axes, radians: light arm, detector arm, sample tilt, sample spin.
template <class T>
struct RigPose {
    T light = T(0);
    T detector = T(0);
    T tilt = T(0);
    T spin = T(0);
};
using RigPosed = RigPose<double>;

/// Direction of an arm at angle a in the world frame: (cos a, sin a, 0).
template <class T>
Vec3<T> arm_direction(const T& a) {
    using std::cos;
    using std::sin;
    return Vec3<T>(cos(a), sin(a), T(0));
}

/// The sample normal in the world frame for tilt t: R_y(t) W_x = (cos t, 0, -sin t).
template <class T>
Vec3<T> sample_normal_world(const T& tilt) {
    using std::cos;
    using std::sin;
    return Vec3<T>(cos(tilt), T(0), -sin(tilt));
}

/// World -> sample frame: B(t, s)^T w = R_z(-s) B0^T R_y(-t) w, with B0^T (x, y, z) = (y, z, x).
template <class T>
Vec3<T> world_to_sample(const Vec3<T>& w, const T& tilt, const T& spin) {
    const Vec3<T> r = rotate_y(w, T(-tilt));
    const Vec3<T> b0t(r.y(), r.z(), r.x());
    return rotate_z(b0t, T(-spin));
}

/// Sample -> world frame: B(t, s) u = R_y(t) B0 R_z(s) u, with B0 (x, y, z) = (z, x, y).
template <class T>
Vec3<T> sample_to_world(const Vec3<T>& u, const T& tilt, const T& spin) {
    const Vec3<T> r = rotate_z(u, spin);
    const Vec3<T> b0(r.z(), r.x(), r.y());
    return rotate_y(b0, tilt);
}

/// Forward kinematics: (wi, wo) in the sample frame for a pose. Unit vectors; either may lie below
/// the sample's horizon (z <= 0) when the pose puts an arm behind the sample: callers check.
template <class T>
std::pair<Vec3<T>, Vec3<T>> rig_forward(const RigPose<T>& p) {
    return {world_to_sample(arm_direction(p.light), p.tilt, p.spin),
            world_to_sample(arm_direction(p.detector), p.tilt, p.spin)};
}

/// Angle between the two arms, folded into [0, pi]: the quantity the blind zone constrains.
inline double arm_separation(double light, double detector) {
    return std::abs(wrap_pi(detector - light));
}

/// Angle between two unit vectors, computed with atan2(|a x b|, a . b) (accurate near 0 and pi).
inline double angle_between(const Vec3d& a, const Vec3d& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// The two inverse-kinematics solutions for a target pair (wi, wo) of unit vectors in the sample
/// frame, all angles wrapped into (-pi, pi]. Solution k uses the arm-plane normal sigma * m with
/// sigma = +1 (k = 0) or -1 (k = 1) and m = (wi x wo)/|wi x wo|:
///   tilt  t = atan2(-sigma m_z, |m_xy|)                     (so |t| <= pi/2),
///   spin  s = sigma pi/2 - atan2(m_y, m_x)                   (turns sigma m_xy onto +y),
///   arm   a = atan2(u_x, u_y sin t + u_z cos t), u = R_z(s) w (from u(a) above).
/// Degenerate case wi parallel to wo (retro-reflection, |wi x wo| < 1e-12): the plane is not fixed
/// by the target; the plane through wi and the sample normal is used (or, with wi along the normal
/// too, the plane x = 0, i.e. m = (1, 0, 0)). Such targets lie in any positive blind zone anyway.
inline std::array<RigPosed, 2> rig_inverse(const Vec3d& wi, const Vec3d& wo) {
    Vec3d m = wi.cross(wo);
    double norm = m.norm();
    if (norm < 1e-12) {
        // wi and wo parallel: pick the plane containing wi and the normal.
        m = wi.cross(Vec3d(0, 0, 1));
        norm = m.norm();
        if (norm < 1e-12) {
            // wi along the normal as well: any vertical plane will do.
            m = Vec3d(1, 0, 0);
            norm = 1;
        }
    }
    m /= norm;
    const double rho = std::hypot(m.x(), m.y());
    std::array<RigPosed, 2> out;
    for (int k = 0; k < 2; ++k) {
        const double sigma = k == 0 ? 1.0 : -1.0;
        RigPosed p;
        p.tilt = std::atan2(-sigma * m.z(), rho);
        // When m is the normal itself (rho = 0, plane = the sample surface) atan2(0, 0) = 0 is as
        // good as any spin; such a target has both directions on the horizon.
        p.spin = wrap_pi(sigma * kPi / 2 - std::atan2(m.y(), m.x()));
        const double st = std::sin(p.tilt);
        const double ct = std::cos(p.tilt);
        const Vec3d ui = rotate_z(wi, p.spin);
        const Vec3d uo = rotate_z(wo, p.spin);
        p.light = std::atan2(ui.x(), ui.y() * st + ui.z() * ct);
        p.detector = std::atan2(uo.x(), uo.y() * st + uo.z() * ct);
        out[k] = p;
    }
    return out;
}

}  // namespace gonio::brdf
