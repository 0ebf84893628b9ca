#pragma once

// The orientation of an anisotropic lobe on the sample: the lobe's own tangent frame (x_l, y_l, z)
// is the sample's frame (x, y, z) turned by the angle phi about the normal z, counter-clockwise
// seen from above (phi is Lobe::orientation_deg, the angle of the lobe's x axis from the sample's
// x axis, in degrees as in the model schema). A direction w given in the sample's frame has the
// lobe-frame components
//
//   x_l =  cos(phi) w_x + sin(phi) w_y,
//   y_l = -sin(phi) w_x + cos(phi) w_y,        z_l = w_z,
//
// the projections on the turned axes x_l = (cos phi, sin phi, 0) and y_l = (-sin phi, cos phi, 0).
// D and Smith's Lambda of an anisotropic distribution with slope parameters (alpha_x, alpha_y)
// along the lobe's axes are then those of microfacet.h at the lobe-frame components (E. Heitz,
// "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 3(2), 2014, sec.
// 5: the anisotropic D and Lambda are written in the tangent frame of the distribution; a rotation
// about the normal keeps z, the cosines and w . h).
//
// The lobe is unchanged by phi -> phi + 180 deg (D and Lambda depend on x_l^2, y_l^2 and x_l y_l
// only through their squares: the distribution is centrally symmetric) and by (alpha_x, alpha_y,
// phi) -> (alpha_y, alpha_x, phi + 90 deg) (turning the frame by a quarter turn exchanges the
// axes). An isotropic lobe (alpha_x = alpha_y) does not depend on phi.
//
// Every function is templated on the numeric type T (double, ceres::Jet, xsimd::batch; math.h);
// P is the parameter type (double for double and packets, the Jet for Jets). No degenerate case:
// a rotation is defined for every angle and keeps unit vectors unit.

#include <cmath>

#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// cos(phi) and sin(phi) of a lobe's orientation phi (radians), computed once per lobe and
/// evaluation.
template <class P>
struct LobeRotation {
    P cos_phi;
    P sin_phi;
};

/// The rotation of orientation phi_deg (degrees, any real value; the lobe has period 180 in it).
template <class P>
inline LobeRotation<P> lobe_rotation_deg(const P& phi_deg) {
    using std::cos;
    using std::sin;
    const P phi = phi_deg * (kPi / 180);
    return {cos(phi), sin(phi)};
}

/// The lobe-frame tangent components (x_l, y_l) of the sample-frame components (x, y) (see the
/// file comment): x_l = cos(phi) x + sin(phi) y, y_l = -sin(phi) x + cos(phi) y.
template <class T, class P>
inline void to_lobe_frame(const T& x, const T& y, const LobeRotation<P>& r, T& x_l, T& y_l) {
    const T c(r.cos_phi);
    const T s(r.sin_phi);
    x_l = c * x + s * y;
    y_l = c * y - s * x;
}

/// The sample-frame tangent components (x, y) of lobe-frame ones (the inverse rotation):
/// x = cos(phi) x_l - sin(phi) y_l, y = sin(phi) x_l + cos(phi) y_l.
template <class T, class P>
inline void from_lobe_frame(const T& x_l, const T& y_l, const LobeRotation<P>& r, T& x, T& y) {
    const T c(r.cos_phi);
    const T s(r.sin_phi);
    x = c * x_l - s * y_l;
    y = s * x_l + c * y_l;
}

/// The squared lobe-frame components from the squared and cross products of the sample-frame
/// components, xx = x^2, yy = y^2, xy = x y (what the fitting stores per sample, since phi may be
/// a fitted parameter):
///   x_l^2 = c^2 xx + 2 c s xy + s^2 yy,   y_l^2 = s^2 xx - 2 c s xy + c^2 yy,
/// with c = cos(phi), s = sin(phi). Both results are >= 0 up to rounding (they are squares);
/// rounding noise below zero is clamped so that D and Lambda never see a negative square.
template <class T, class P>
inline void lobe_frame_squares(
    const T& xx, const T& yy, const T& xy, const LobeRotation<P>& r, T& xx_l, T& yy_l) {
    const T c2 = T(r.cos_phi * r.cos_phi);
    const T s2 = T(r.sin_phi * r.sin_phi);
    const T cs2 = T(P(2) * r.cos_phi * r.sin_phi);
    const T a = c2 * xx + cs2 * xy + s2 * yy;
    const T b = s2 * xx - cs2 * xy + c2 * yy;
    // Branch of the mask: rounding noise of a square that is zero in exact arithmetic.
    xx_l = max_of(a, T(0));
    yy_l = max_of(b, T(0));
}

}  // namespace gonio::brdf
