#pragma once

// The stratum coordinates of stratified_reduce (fitting/reduction.h): one body for double (the
// scalar path, reduction.cpp) and for packets (each copy of isa/stratum.cpp instantiates the kernel
// with its own compile flags).
//
// Rusinkiewicz's half/difference angles (brdf/coords.h to_half_diff, the same definitions:
// theta_h = atan2(|h_xy|, h_z), d = R_y(-theta_h) R_z(-phi_h) wi, theta_d and phi_d its spherical
// angles) with the rotations written on the half vector's components, cos theta_h = h_z,
// sin theta_h = |h_xy|, (cos, sin) phi_h = h_xy / |h_xy|, instead of the sines and cosines of the
// angles: three arctangents and the directions' four sines and cosines per sample instead of four
// arctangents and six. Equal to the to_half_diff route to rounding (xsimd's sincos and atan2 are
// within a few ulp of the C library's).

#include <cstddef>
#include <xsimd/xsimd.hpp>

#include "gonio/brdf/math.h"

namespace gonio::fitting::detail {

/// Inputs and outputs of n samples, each an array of n doubles.
struct StratumArrays {
    const double* theta_i;
    const double* phi_i;
    const double* theta_o;
    const double* phi_o;
    double* c_h;  ///< sqrt(theta_h / (pi/2)), in [0, 1]
    double* c_d;  ///< theta_d / (pi/2), in [0, 1]
    double* c_p;  ///< phi_d folded to [0, pi), over pi, in [0, 1]
};

/// The stratum coordinates (ch, cd, cp) of the directions (theta_i, phi_i) and (theta_o, phi_o),
/// for T = double or a packet: ch = sqrt(theta_h / (pi/2)), cd = theta_d / (pi/2) and cp = phi_d
/// folded to [0, pi), over pi, each in [0, 1]. Each degenerate case is a mask of select.
template <class T>
void stratum_coords_body(const T& ti, const T& pi, const T& to, const T& po, T& ch, T& cd, T& cp) {
    using brdf::clamp_to;
    using brdf::select;
    using std::atan2;
    using std::sqrt;
    const T zero(0.0), one(1.0), pi_b(brdf::kPi);
    const auto [s_ti, c_ti] = brdf::sincos_of(ti);
    const auto [s_pi, c_pi] = brdf::sincos_of(pi);
    const auto [s_to, c_to] = brdf::sincos_of(to);
    const auto [s_po, c_po] = brdf::sincos_of(po);
    const T wi_x = s_ti * c_pi, wi_y = s_ti * s_pi, wi_z = c_ti;
    const T wo_x = s_to * c_po, wo_y = s_to * s_po, wo_z = c_to;
    T h_x = wi_x + wo_x, h_y = wi_y + wo_y, h_z = wi_z + wo_z;
    const T norm2 = h_x * h_x + h_y * h_y + h_z * h_z;
    // wi = -wo: the normal as h (to_half_diff's choice).
    const auto no_h = norm2 == zero;
    const T inv = one / sqrt(select(no_h, one, norm2));
    h_x = select(no_h, zero, h_x * inv);
    h_y = select(no_h, zero, h_y * inv);
    h_z = select(no_h, one, h_z * inv);
    const T rho = sqrt(h_x * h_x + h_y * h_y);
    // h at the pole: theta_h 0 (or pi), phi_h = 0.
    const auto pole = rho == zero;
    const T theta_h = select(pole, select(h_z >= zero, zero, pi_b), atan2(rho, h_z));
    const T safe_rho = select(pole, one, rho);
    const T cos_phi = select(pole, one, h_x / safe_rho);
    const T sin_phi = select(pole, zero, h_y / safe_rho);
    // R_z(-phi_h) wi, then R_y(-theta_h).
    const T u = cos_phi * wi_x + sin_phi * wi_y;
    const T d_x = h_z * u - rho * wi_z;
    const T d_y = cos_phi * wi_y - sin_phi * wi_x;
    const T d_z = rho * u + h_z * wi_z;
    const T rho_d2 = d_x * d_x + d_y * d_y;
    // d at the pole: theta_d 0 (or pi), phi_d = 0.
    const auto d_pole = rho_d2 == zero;
    const T theta_d = select(d_pole, select(d_z >= zero, zero, pi_b), atan2(sqrt(rho_d2), d_z));
    // phi_d in (-pi, pi] folded to [0, pi) by the reciprocity of the pair.
    T phi_d = select(d_pole, zero, atan2(d_y, d_x));
    phi_d = select(phi_d < zero, phi_d + pi_b, phi_d);
    phi_d = select(phi_d >= pi_b, phi_d - pi_b, phi_d);
    const T half_pi(brdf::kPi / 2);
    ch = sqrt(clamp_to(theta_h / half_pi, zero, one));
    cd = clamp_to(theta_d / half_pi, zero, one);
    cp = clamp_to(phi_d / pi_b, zero, one);
}

template <class Arch>
void stratum_kernel(const StratumArrays& a, std::size_t n) {
    using B = xsimd::batch<double, Arch>;
    constexpr std::size_t kW = B::size;
    std::size_t i = 0;
    B ch, cd, cp;
    for (; i + kW <= n; i += kW) {
        stratum_coords_body(B::load_unaligned(a.theta_i + i),
                            B::load_unaligned(a.phi_i + i),
                            B::load_unaligned(a.theta_o + i),
                            B::load_unaligned(a.phi_o + i),
                            ch,
                            cd,
                            cp);
        ch.store_unaligned(a.c_h + i);
        cd.store_unaligned(a.c_d + i);
        cp.store_unaligned(a.c_p + i);
    }
    if (i < n) {
        // The last partial packet, padded with normal incidence.
        alignas(64) double in[4][kW] = {};
        alignas(64) double out[3][kW] = {};
        for (std::size_t j = i; j < n; ++j) {
            in[0][j - i] = a.theta_i[j];
            in[1][j - i] = a.phi_i[j];
            in[2][j - i] = a.theta_o[j];
            in[3][j - i] = a.phi_o[j];
        }
        stratum_coords_body(B::load_aligned(in[0]),
                            B::load_aligned(in[1]),
                            B::load_aligned(in[2]),
                            B::load_aligned(in[3]),
                            ch,
                            cd,
                            cp);
        ch.store_aligned(out[0]);
        cd.store_aligned(out[1]);
        cp.store_aligned(out[2]);
        for (std::size_t j = i; j < n; ++j) {
            a.c_h[j] = out[0][j - i];
            a.c_d[j] = out[1][j - i];
            a.c_p[j] = out[2][j - i];
        }
    }
}

}  // namespace gonio::fitting::detail
