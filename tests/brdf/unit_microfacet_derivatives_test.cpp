// The width derivatives of microfacet_derivatives.h against one-slot Jets of the formulas they
// differentiate (microfacet.h), on seeded grids that include the edges: h at the normal
// (theta_h = 0), grazing directions (tan^2 theta up to 1e18), alpha at the fit's bounds
// [1e-4, 1.5] and Beckmann's far tail and negligible-Lambda cut. Tolerance: a relative error of
// kRelative = 1e-12 of the Jet's derivative, or an absolute kAbsolute = 1e-300 (both zero). The
// packet instantiation is held to the scalar one: 4 ulp where only arithmetic and sqrt enter (the
// two forms group the same operations differently at most by contraction), and for exp and erfc
// (xsimd's instead of the C library's) a relative 1e-12 or, for Beckmann's Lambda derivative, an
// absolute 1e-14 of the derivative where exp(-a^2) is in the tail (see
// unit_packet_formulas_test.cpp).

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "gonio/brdf/microfacet_derivatives.h"

namespace gonio::brdf {
namespace {

using J = ceres::Jet<double, 1>;
using B = xsimd::batch<double>;
constexpr double kRelative = 1e-12;

bool close(double got, double want, double relative, double absolute = 1e-300) {
    const double diff = std::abs(got - want);
    return diff <= relative * std::abs(want) || diff <= absolute;
}

/// (h_x^2 + h_y^2, h_z^2) of half vectors from the normal to near the horizon.
std::vector<std::pair<double, double>> half_squares() {
    std::vector<std::pair<double, double>> out;
    for (double th : {0.0, 1e-8, 0.2, 0.7, 1.2, 1.5, kPi / 2 - 1e-6}) {
        out.emplace_back(std::sin(th) * std::sin(th), std::cos(th) * std::cos(th));
    }
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 40; ++k) {
        const double c = u(rng);
        out.emplace_back(1 - c * c, c * c);
    }
    return out;
}

/// tan^2 theta of directions from the normal to grazing.
std::vector<double> tan_squares() {
    std::vector<double> out = {0.0, 1e-12, 1e-3, 0.1, 1.0, 10.0, 1e4, 1e10, 1e18};
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 40; ++k) {
        const double c = std::max(u(rng), 1e-3);
        out.push_back((1 - c * c) / (c * c));
    }
    return out;
}

const double kDerivativeAlphas[] = {1e-4, 2e-3, 0.05, 0.3, 1.0, 1.5};

TEST(MicrofacetDerivatives, GgxDMatchesJet) {
    int checked = 0;
    for (const auto& [hxy2, hz2] : half_squares()) {
        for (double a : kDerivativeAlphas) {
            const J aj(a, 0);
            const J D = D_ggx_from_squares(J(hxy2), J(0.0), J(hz2), aj, aj);
            const double d = dD_ggx_dalpha_from_squares(hxy2, hz2, a, D.a);
            EXPECT_TRUE(close(d, D.v[0], kRelative))
                << hxy2 << " " << a << ": " << d << " vs " << D.v[0];
            ++checked;
        }
    }
    EXPECT_GT(checked, 250);
}

TEST(MicrofacetDerivatives, BeckmannDMatchesJetIncludingTheTail) {
    int tail = 0;
    for (const auto& [hxy2, hz2] : half_squares()) {
        for (double a : kDerivativeAlphas) {
            const J aj(a, 0);
            const J D = D_beckmann_from_squares(J(hxy2), J(0.0), J(hz2), aj, aj);
            const double d = dD_beckmann_dalpha_from_squares(hxy2, hz2, a, D.a);
            tail += D.a == 0;
            EXPECT_TRUE(close(d, D.v[0], kRelative))
                << hxy2 << " " << a << ": " << d << " vs " << D.v[0];
        }
    }
    // Small widths away from the normal reach the far tail.
    EXPECT_GT(tail, 10);
}

TEST(MicrofacetDerivatives, LambdasMatchJets) {
    for (double t2 : tan_squares()) {
        for (double a : kDerivativeAlphas) {
            const J aj(a, 0);
            const J a2 = aj * aj * J(t2);
            const J lg = lambda_ggx_from_a2(a2);
            const J lb = lambda_beckmann_from_a2(a2);
            EXPECT_TRUE(close(dlambda_ggx_dalpha_from_a2(a2.a, a), lg.v[0], kRelative))
                << t2 << " " << a;
            EXPECT_TRUE(close(dlambda_beckmann_dalpha_from_a2(a2.a, a), lb.v[0], kRelative))
                << t2 << " " << a << ": " << dlambda_beckmann_dalpha_from_a2(a2.a, a) << " vs "
                << lb.v[0];
        }
    }
}

TEST(MicrofacetDerivatives, SmithGFormsMatchJets) {
    for (double li : {0.0, 1e-9, 0.3, 2.0, 1e6}) {
        for (double lo : {0.0, 0.01, 1.5, 1e3}) {
            for (double dli : {0.0, 0.5, 3.0}) {
                const double dlo = 1.7;
                const J Li(li), Lo(lo);
                J Lij = Li, Loj = Lo;
                Lij.v[0] = dli;
                Loj.v[0] = dlo;
                const J gc = G_smith_correlated(Lij, Loj);
                const J gs = G_smith_separable(Lij, Loj);
                EXPECT_TRUE(close(dG_smith_correlated(gc.a, dli, dlo), gc.v[0], kRelative));
                EXPECT_TRUE(close(dG_smith_separable(gs.a, li, lo, dli, dlo), gs.v[0], kRelative));
            }
        }
    }
}

/// Every formula's packet instantiation against its scalar one, lane by lane.
TEST(MicrofacetDerivatives, PacketsMatchScalars) {
    constexpr std::size_t kW = B::size;
    const auto hs = half_squares();
    const auto ts = tan_squares();
    for (double a : kDerivativeAlphas) {
        for (std::size_t k = 0; k < hs.size(); k += kW) {
            alignas(64) double hx[kW], hz[kW], tv[kW], out[4][kW];
            for (std::size_t l = 0; l < kW; ++l) {
                const auto& p = hs[std::min(k + l, hs.size() - 1)];
                hx[l] = p.first;
                hz[l] = p.second;
                tv[l] = a * a * ts[std::min(k + l, ts.size() - 1)];
            }
            const B bx = B::load_aligned(hx), bz = B::load_aligned(hz), bt = B::load_aligned(tv);
            const B ba(a);
            dD_ggx_dalpha_from_squares(bx, bz, ba, D_ggx_from_squares(bx, B(0.0), bz, ba, ba))
                .store_aligned(out[0]);
            dD_beckmann_dalpha_from_squares(
                bx, bz, ba, D_beckmann_from_squares(bx, B(0.0), bz, ba, ba))
                .store_aligned(out[1]);
            dlambda_ggx_dalpha_from_a2(bt, ba).store_aligned(out[2]);
            dlambda_beckmann_dalpha_from_a2(bt, ba).store_aligned(out[3]);
            for (std::size_t l = 0; l < kW; ++l) {
                const double sg = dD_ggx_dalpha_from_squares(
                    hx[l], hz[l], a, D_ggx_from_squares(hx[l], 0.0, hz[l], a, a));
                const double sb = dD_beckmann_dalpha_from_squares(
                    hx[l], hz[l], a, D_beckmann_from_squares(hx[l], 0.0, hz[l], a, a));
                const double lg = dlambda_ggx_dalpha_from_a2(tv[l], a);
                const double lb = dlambda_beckmann_dalpha_from_a2(tv[l], a);
                EXPECT_TRUE(close(out[0][l], sg, 4 * 2.2e-16)) << out[0][l] << " vs " << sg;
                EXPECT_TRUE(close(out[1][l], sb, kRelative)) << out[1][l] << " vs " << sb;
                EXPECT_TRUE(close(out[2][l], lg, 4 * 2.2e-16)) << out[2][l] << " vs " << lg;
                EXPECT_TRUE(close(out[3][l], lb, kRelative, 1e-14)) << out[3][l] << " vs " << lb;
            }
        }
    }
}

}  // namespace
}  // namespace gonio::brdf
