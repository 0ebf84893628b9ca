#pragma once

// Small numeric helpers shared by the formulas of brdf/. Every helper is templated on the scalar
// so that Ceres Jets pass through (unqualified calls find the Jet overloads by argument-dependent
// lookup).

#include <cmath>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// x * x.
template <class T>
inline T sqr(const T& x) {
    return x * x;
}

/// x^5 by three multiplications (Schlick's factor).
template <class T>
inline T pow5(const T& x) {
    const T x2 = x * x;
    return x2 * x2 * x;
}

/// sqrt(max(x, 0)). Rounding noise can make an argument that is zero in exact arithmetic slightly
/// negative (1 - cos^2 at cos = 1); it is clamped to zero. At x <= 0 the result is an exact zero
/// with a zero derivative, which keeps Jet derivatives finite where sqrt'(0) would be infinite.
template <class T>
inline T safe_sqrt(const T& x) {
    using std::sqrt;
    if (x <= T(0)) {
        // Degenerate: zero (or rounding noise below it); no infinite derivative.
        return T(0);
    }
    return sqrt(x);
}

/// min(a, b) and max(a, b) by comparison of values; the derivative is that of the chosen argument.
template <class T>
inline T min_of(const T& a, const T& b) {
    return b < a ? b : a;
}
template <class T>
inline T max_of(const T& a, const T& b) {
    return a < b ? b : a;
}

/// Clamp x into [lo, hi].
template <class T>
inline T clamp_to(const T& x, const T& lo, const T& hi) {
    return x < lo ? lo : (hi < x ? hi : x);
}

/// The value part of a scalar: the double itself, or a Jet's .a. Used only for branch decisions
/// and for messages, never inside a differentiated expression.
inline double value_of(double x) {
    return x;
}
inline long double value_of(long double x) {
    return x;
}
template <class J>
inline auto value_of(const J& x) -> decltype(value_of(x.a)) {
    return value_of(x.a);
}

}  // namespace gonio::brdf
