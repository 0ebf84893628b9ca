#pragma once

// The stratum coordinates of stratified_reduce (fitting/reduction.h) on packets for one
// instruction set; each stratum_packets*.cpp instantiates it with its own compile flags.
//
// The formulas are those of the scalar stratum_coords_of (reduction.cpp): the directions from
// their angles, the half vector h, theta_h = atan2(|h_xy|, h_z), d = R_y(-theta_h) R_z(-phi_h) wi
// with the rotations written on h's components, theta_d and phi_d (folded to [0, pi)) its
// spherical angles; xsimd's sincos and atan2 (within a few ulp of the C library's) instead of
// the scalar calls.

#include <cstddef>
#include <xsimd/xsimd.hpp>

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

template <class B>
void stratum_packet(const B& ti, const B& pi, const B& to, const B& po, B& ch, B& cd, B& cp) {
    constexpr double kPi = 3.14159265358979323846;
    const B zero(0.0), one(1.0), pi_b(kPi);
    const auto [s_ti, c_ti] = xsimd::sincos(ti);
    const auto [s_pi, c_pi] = xsimd::sincos(pi);
    const auto [s_to, c_to] = xsimd::sincos(to);
    const auto [s_po, c_po] = xsimd::sincos(po);
    const B wi_x = s_ti * c_pi, wi_y = s_ti * s_pi, wi_z = c_ti;
    const B wo_x = s_to * c_po, wo_y = s_to * s_po, wo_z = c_to;
    B h_x = wi_x + wo_x, h_y = wi_y + wo_y, h_z = wi_z + wo_z;
    const B norm2 = h_x * h_x + h_y * h_y + h_z * h_z;
    // wi = -wo: the normal as h (to_half_diff's choice).
    const auto no_h = norm2 == zero;
    const B inv = one / xsimd::sqrt(xsimd::select(no_h, one, norm2));
    h_x = xsimd::select(no_h, zero, h_x * inv);
    h_y = xsimd::select(no_h, zero, h_y * inv);
    h_z = xsimd::select(no_h, one, h_z * inv);
    const B rho = xsimd::sqrt(h_x * h_x + h_y * h_y);
    const auto pole = rho == zero;
    const B theta_h =
        xsimd::select(pole, xsimd::select(h_z >= zero, zero, pi_b), xsimd::atan2(rho, h_z));
    const B safe_rho = xsimd::select(pole, one, rho);
    const B cos_phi = xsimd::select(pole, one, h_x / safe_rho);
    const B sin_phi = xsimd::select(pole, zero, h_y / safe_rho);
    const B u = cos_phi * wi_x + sin_phi * wi_y;
    const B d_x = h_z * u - rho * wi_z;
    const B d_y = cos_phi * wi_y - sin_phi * wi_x;
    const B d_z = rho * u + h_z * wi_z;
    const B rho_d2 = d_x * d_x + d_y * d_y;
    const auto d_pole = rho_d2 == zero;
    const B theta_d = xsimd::select(
        d_pole, xsimd::select(d_z >= zero, zero, pi_b), xsimd::atan2(xsimd::sqrt(rho_d2), d_z));
    B phi_d = xsimd::select(d_pole, zero, xsimd::atan2(d_y, d_x));
    phi_d = xsimd::select(phi_d < zero, phi_d + pi_b, phi_d);
    phi_d = xsimd::select(phi_d >= pi_b, phi_d - pi_b, phi_d);
    const B half_pi(kPi / 2);
    ch = xsimd::sqrt(xsimd::min(xsimd::max(theta_h / half_pi, zero), one));
    cd = xsimd::min(xsimd::max(theta_d / half_pi, zero), one);
    cp = xsimd::min(xsimd::max(phi_d / pi_b, zero), one);
}

template <class Arch>
void stratum_kernel(const StratumArrays& a, std::size_t n) {
    using B = xsimd::batch<double, Arch>;
    constexpr std::size_t kW = B::size;
    std::size_t i = 0;
    B ch, cd, cp;
    for (; i + kW <= n; i += kW) {
        stratum_packet(B::load_unaligned(a.theta_i + i),
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
        stratum_packet(B::load_aligned(in[0]),
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

void stratum_avx512(const StratumArrays& a, std::size_t n);
void stratum_avx2(const StratumArrays& a, std::size_t n);

}  // namespace gonio::fitting::detail
