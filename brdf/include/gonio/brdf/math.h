#pragma once

// Small numeric helpers shared by the formulas of brdf/. Every helper is templated on the numeric
// type T and valid for the three kinds the formulas run on:
//   - double (and long double),
//   - ceres::Jet<double, N> (unqualified calls find the Jet overloads by argument-dependent
//   lookup),
//   - xsimd::batch<double, Arch>, a packet of lanes evaluated together.
//
// A formula that must run on packets has no data-dependent `if`: it computes the mask of each
// degenerate case (a comparison: bool for double and Jets, xsimd::batch_bool for packets) and
// merges the regular and the degenerate value with select(mask, a, b). For double and Jets,
// select is the conditional operator, so only the chosen value is returned and a Jet's derivative
// is that of the chosen expression. Arguments that would leave the domain of a function (sqrt of a
// negative, division by zero) are replaced inside the masked lanes before the call, so no lane
// computes NaN or an infinite derivative, even in a value that select discards.
//
// all_of(mask) is true when every lane is in the degenerate case; formulas return early then, which
// for double and Jets is the ordinary early exit and skips the regular computation.

#include <cmath>
#include <type_traits>
#include <utility>
#include <xsimd/xsimd.hpp>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// 1 / sqrt(pi).
constexpr double kInvSqrtPi = 0.56418958354775628695;

/// The mask type of T: bool for double and Jets, xsimd::batch_bool for packets.
template <class T>
struct MaskOf {
    using type = bool;
};
template <class T, class A>
struct MaskOf<xsimd::batch<T, A>> {
    using type = xsimd::batch_bool<T, A>;
};
template <class T>
using Mask = typename MaskOf<T>::type;

/// True for xsimd packets.
template <class T>
struct IsPacket : std::false_type {};
template <class T, class A>
struct IsPacket<xsimd::batch<T, A>> : std::true_type {};

/// mask ? a : b, lane by lane for packets. An unqualified call on packets inside gonio::brdf also
/// finds xsimd::select by argument-dependent lookup; that overload is the more specialised one and
/// is chosen, the generic packet overload here serves qualified calls (brdf::select) from other
/// namespaces.
template <class T>
inline T select(bool mask, const T& a, const T& b) {
    return mask ? a : b;
}
template <class M, class B, class = std::enable_if_t<IsPacket<B>::value>>
inline B select(const M& mask, const B& a, const B& b) {
    return xsimd::select(mask, a, b);
}

/// Every lane of the mask set (the mask itself for double and Jets).
inline bool all_of(bool mask) {
    return mask;
}
template <class T, class A>
inline bool all_of(const xsimd::batch_bool<T, A>& mask) {
    return xsimd::all(mask);
}

/// Some lane of the mask set.
inline bool any_of(bool mask) {
    return mask;
}
template <class T, class A>
inline bool any_of(const xsimd::batch_bool<T, A>& mask) {
    return xsimd::any(mask);
}

/// Lane-wise or / and of two masks.
inline bool mask_or(bool a, bool b) {
    return a || b;
}
template <class T, class A>
inline xsimd::batch_bool<T, A> mask_or(const xsimd::batch_bool<T, A>& a,
                                       const xsimd::batch_bool<T, A>& b) {
    return a || b;
}
inline bool mask_and(bool a, bool b) {
    return a && b;
}
template <class T, class A>
inline xsimd::batch_bool<T, A> mask_and(const xsimd::batch_bool<T, A>& a,
                                        const xsimd::batch_bool<T, A>& b) {
    return a && b;
}

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

/// min(a, b) and max(a, b) by comparison of values; the derivative is that of the chosen argument.
template <class T>
inline T min_of(const T& a, const T& b) {
    return select(b < a, b, a);
}
template <class T>
inline T max_of(const T& a, const T& b) {
    return select(a < b, b, a);
}

/// Clamp x into [lo, hi].
template <class T>
inline T clamp_to(const T& x, const T& lo, const T& hi) {
    return min_of(max_of(x, lo), hi);
}

/// sqrt(max(x, 0)). Rounding noise can make an argument that is zero in exact arithmetic slightly
/// negative (1 - cos^2 at cos = 1); it is clamped to zero. At x <= 0 the result is an exact zero
/// with a zero derivative, which keeps Jet derivatives finite where sqrt'(0) would be infinite.
template <class T>
inline T safe_sqrt(const T& x) {
    using std::sqrt;
    const auto nonpositive = x <= T(0);
    if (all_of(nonpositive)) {
        // Degenerate: zero (or rounding noise below it); no infinite derivative.
        return T(0);
    }
    // The masked lanes take sqrt(1) so that no lane evaluates sqrt at or below 0.
    return select(nonpositive, T(0), sqrt(select(nonpositive, T(1), x)));
}

/// (sin x, cos x): one call of xsimd's sincos on packets (one range reduction for both), the two
/// library calls for double and Jets.
template <class T>
inline std::pair<T, T> sincos_of(const T& x) {
    using std::cos;
    using std::sin;
    return {sin(x), cos(x)};
}
template <class T, class A>
inline std::pair<xsimd::batch<T, A>, xsimd::batch<T, A>> sincos_of(const xsimd::batch<T, A>& x) {
    return xsimd::sincos(x);
}

/// acos(clamp(x, -1, 1)). Rounding noise can push a cosine slightly beyond +-1; it is clamped.
/// At |x| >= 1 the result is 0 or pi with a zero derivative, which keeps Jet derivatives finite
/// where acos'(+-1) would be infinite.
template <class T>
inline T safe_acos(const T& x) {
    using std::acos;
    const auto at_one = x >= T(1);
    const auto at_minus_one = x <= T(-1);
    const auto edge = mask_or(at_one, at_minus_one);
    if (all_of(edge)) {
        // Degenerate: the end points of the domain.
        return select(at_one, T(0), T(kPi));
    }
    // The masked lanes take acos(0) so that no lane evaluates acos at +-1.
    const T inner = acos(select(edge, T(0), x));
    return select(at_one, T(0), select(at_minus_one, T(kPi), inner));
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
