#pragma once

// Directions and their parameterisations. Conventions, fixed here for the whole project:
// - the local frame has z along the surface normal; x is the sample's reference direction (phi =
// 0);
// - wi points toward the light, wo toward the camera, both away from the surface, unit length;
// - theta is the polar angle from z in [0, pi], phi the azimuth from x toward y in (-pi, pi];
// - radians everywhere (degrees only at the user-facing edges, named *_deg).
//
// Every function is templated on the scalar so that Ceres Jets pass through; the conversions from
// Cartesian to angles use atan2, whose derivative is undefined at the pole (x = y = 0). Fits
// evaluate models on directions that are constants, so this only matters to callers that
// differentiate through directions.

#include <Eigen/Core>
#include <cmath>
#include <utility>

namespace gonio::brdf {

template <class T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
using Vec3d = Vec3<double>;

/// RGB triples (radiometric values per channel); component-wise arithmetic.
template <class T>
using Rgb = Eigen::Array<T, 3, 1>;
using Rgbd = Rgb<double>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvPi = 0.31830988618379067154;

/// A direction as polar angle theta in [0, pi] and azimuth phi in (-pi, pi], radians.
template <class T>
struct Spherical {
    T theta;
    T phi;
};

/// (sin theta cos phi, sin theta sin phi, cos theta): unit vector for any theta, phi.
template <class T>
Vec3<T> spherical_to_cartesian(const T& theta, const T& phi) {
    using std::cos;
    using std::sin;
    const T sin_theta = sin(theta);
    return Vec3<T>(sin_theta * cos(phi), sin_theta * sin(phi), cos(theta));
}

/// Inverse of spherical_to_cartesian for a unit (or any non-zero) vector. theta = atan2(|v_xy|,
/// v_z) keeps full relative precision near the pole and the horizon (acos would lose it near theta
/// = 0). At the pole (v_x = v_y = 0) phi is 0 by convention.
template <class T>
Spherical<T> cartesian_to_spherical(const Vec3<T>& v) {
    using std::atan2;
    using std::sqrt;
    const T rho2 = v.x() * v.x() + v.y() * v.y();
    if (rho2 == T(0)) {
        // Pole: azimuth undefined, pick 0 (and theta is 0 or pi).
        return {v.z() >= T(0) ? T(0) : T(kPi), T(0)};
    }
    return {atan2(sqrt(rho2), v.z()), atan2(v.y(), v.x())};
}

/// Rotation of v about z by angle a (right-handed).
template <class T>
Vec3<T> rotate_z(const Vec3<T>& v, const T& a) {
    using std::cos;
    using std::sin;
    const T c = cos(a);
    const T s = sin(a);
    return Vec3<T>(c * v.x() - s * v.y(), s * v.x() + c * v.y(), v.z());
}

/// Rotation of v about y by angle a (right-handed).
template <class T>
Vec3<T> rotate_y(const Vec3<T>& v, const T& a) {
    using std::cos;
    using std::sin;
    const T c = cos(a);
    const T s = sin(a);
    return Vec3<T>(c * v.x() + s * v.z(), v.y(), -s * v.x() + c * v.z());
}

/// Rusinkiewicz half/difference coordinates (S. Rusinkiewicz, "A New Change of Variables for
/// Efficient BRDF Representation", EGWR 1998, section 3): h = (wi + wo)/|wi + wo| in spherical
/// (theta_h, phi_h), and the difference vector d = R_y(-theta_h) R_z(-phi_h) wi in spherical
/// (theta_d, phi_d).
template <class T>
struct HalfDiff {
    T theta_h;
    T phi_h;
    T theta_d;
    T phi_d;
};

/// wi, wo unit vectors. Degenerate case wi = -wo (half vector undefined): h is taken as the normal
/// z, so theta_h = phi_h = 0 and d = wi.
template <class T>
HalfDiff<T> to_half_diff(const Vec3<T>& wi, const Vec3<T>& wo) {
    Vec3<T> h = wi + wo;
    const T norm2 = h.squaredNorm();
    if (norm2 == T(0)) {
        // wi = -wo: no half vector; choose the normal so the mapping stays defined.
        h = Vec3<T>(T(0), T(0), T(1));
    } else {
        using std::sqrt;
        h /= sqrt(norm2);
    }
    const Spherical<T> sh = cartesian_to_spherical(h);
    const Vec3<T> d = rotate_y(rotate_z(wi, T(-sh.phi)), T(-sh.theta));
    const Spherical<T> sd = cartesian_to_spherical(d);
    return {sh.theta, sh.phi, sd.theta, sd.phi};
}

/// Inverse of to_half_diff: wi = R_z(phi_h) R_y(theta_h) d, wo = 2 (wi . h) h - wi.
template <class T>
std::pair<Vec3<T>, Vec3<T>> from_half_diff(const HalfDiff<T>& hd) {
    const Vec3<T> d = spherical_to_cartesian(hd.theta_d, hd.phi_d);
    const Vec3<T> wi = rotate_z(rotate_y(d, hd.theta_h), hd.phi_h);
    const Vec3<T> h = spherical_to_cartesian(hd.theta_h, hd.phi_h);
    const Vec3<T> wo = T(2) * wi.dot(h) * h - wi;
    return {wi, wo};
}

/// The canonical isotropic parameterisation (theta_i, theta_r, delta_phi), delta_phi = phi_o -
/// phi_i. The specular (mirror) configuration has delta_phi = pi.
template <class T>
struct Canonical {
    T theta_i;
    T theta_r;
    T delta_phi;
};

/// Wraps an angle into (-pi, pi].
template <class T>
T wrap_pi(T a) {
    using std::floor;
    a = a - T(2 * kPi) * floor((a + T(kPi)) / T(2 * kPi));
    if (a <= T(-kPi)) {
        a += T(2 * kPi);
    }
    return a;
}

/// Folds (wi, wo) into canonical form. Isotropy: only |phi_o - phi_i| matters, so delta_phi is
/// folded into [0, pi]. Reciprocity (when fold_reciprocity): f(wi, wo) = f(wo, wi), so the pair is
/// ordered with theta_i <= theta_r.
template <class T>
Canonical<T> to_canonical(const Vec3<T>& wi, const Vec3<T>& wo, bool fold_reciprocity = true) {
    using std::abs;
    const Spherical<T> si = cartesian_to_spherical(wi);
    const Spherical<T> so = cartesian_to_spherical(wo);
    Canonical<T> c{si.theta, so.theta, abs(wrap_pi(T(so.phi - si.phi)))};
    if (fold_reciprocity && c.theta_r < c.theta_i) {
        std::swap(c.theta_i, c.theta_r);
    }
    return c;
}

/// A representative pair for a canonical triple: wi at phi = 0, wo at phi = delta_phi.
template <class T>
std::pair<Vec3<T>, Vec3<T>> from_canonical(const Canonical<T>& c) {
    return {spherical_to_cartesian(c.theta_i, T(0)),
            spherical_to_cartesian(c.theta_r, c.delta_phi)};
}

/// Mirror reflection of w about the normal z: (-x, -y, z).
template <class T>
Vec3<T> reflect_z(const Vec3<T>& w) {
    return Vec3<T>(-w.x(), -w.y(), w.z());
}

}  // namespace gonio::brdf
