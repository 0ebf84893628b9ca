// Fresnel terms against independent references: normal incidence ((n-1)/(n+1))^2, Brewster's angle,
// total internal reflection, the conductor formula with k = 0 against the dielectric one, and the
// conductor's normal-incidence reflectance ((n-1)^2 + k^2)/((n+1)^2 + k^2).

#include <gtest/gtest.h>

#include <cmath>

#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/ior.h"

namespace gonio::brdf {
namespace {

TEST(Fresnel, SchlickAndExactDielectricAgreeAtNormalIncidence) {
    for (double n : {1.0001, 1.333, 1.5, 1.6, 2.42, 4.0}) {
        const double r0 = std::pow((n - 1) / (n + 1), 2);
        EXPECT_NEAR(fresnel_dielectric(1.0, n), r0, 1e-15) << "n = " << n;
        EXPECT_NEAR(fresnel_schlick(1.0, r0), r0, 1e-15) << "n = " << n;
    }
}

TEST(Fresnel, SchlickIsOneAtGrazingAndF0AtNormal) {
    EXPECT_DOUBLE_EQ(fresnel_schlick(0.0, 0.04), 1.0);
    EXPECT_DOUBLE_EQ(fresnel_schlick(1.0, 0.04), 0.04);
    // (1 - 0.5)^5 = 1/32.
    EXPECT_DOUBLE_EQ(fresnel_schlick(0.5, 0.04), 0.04 + 0.96 / 32.0);
}

TEST(Fresnel, SchlickIsCloseToExactForDielectrics) {
    // The documented accuracy: absolute error < 0.025 up to 60 deg, < 0.07 everywhere, for eta in
    // [1.3, 1.8]; and much better near normal incidence (< 0.002 up to 30 deg for glass).
    for (double n : {1.3, 1.5, 1.8}) {
        const double r0 = std::pow((n - 1) / (n + 1), 2);
        for (double deg = 0; deg <= 90; deg += 0.5) {
            const double c = std::cos(deg * kPi / 180);
            const double err = std::abs(fresnel_schlick(c, r0) - fresnel_dielectric(c, n));
            EXPECT_LT(err, deg <= 60 ? 0.025 : 0.07) << "n " << n << " at " << deg << " deg";
            if (n == 1.5 && deg <= 30) {
                EXPECT_LT(err, 0.002) << deg << " deg";
            }
        }
    }
}

TEST(Fresnel, BrewsterAngleHasNoParallelReflection) {
    // At tan(theta_B) = n the p-polarised reflectance vanishes, so F = r_s^2 / 2 with
    // r_s = (cos_i - n cos_t)/(cos_i + n cos_t) and, at Brewster, theta_i + theta_t = 90 deg:
    // r_s = -cos(2 theta_B) ... = (1 - n^2)/(1 + n^2).
    for (double n : {1.333, 1.5, 2.42}) {
        const double theta_b = std::atan(n);
        const double rs = (1 - n * n) / (1 + n * n);
        EXPECT_NEAR(fresnel_dielectric(std::cos(theta_b), n), rs * rs / 2, 1e-14) << "n = " << n;
    }
}

TEST(Fresnel, TotalInternalReflectionBeyondCriticalAngle) {
    const double eta = 1.0 / 1.5;  // glass to air
    const double critical = std::asin(eta);
    EXPECT_EQ(fresnel_dielectric(std::cos(critical + 1e-6), eta), 1.0);
    EXPECT_EQ(fresnel_dielectric(std::cos(1.2), eta), 1.0);
    EXPECT_LT(fresnel_dielectric(std::cos(critical - 0.01), eta), 1.0);
    // Seen from the other side: cos_i < 0 swaps the media.
    EXPECT_DOUBLE_EQ(fresnel_dielectric(-std::cos(0.3), 1.5),
                     fresnel_dielectric(std::cos(0.3), eta));
}

TEST(Fresnel, DielectricIsOneAtGrazingAndZeroForIndexMatch) {
    EXPECT_NEAR(fresnel_dielectric(0.0, 1.5), 1.0, 1e-15);
    EXPECT_EQ(fresnel_dielectric(0.7, 1.0), 0.0);
}

TEST(Fresnel, ConductorWithZeroExtinctionEqualsDielectric) {
    for (double eta : {0.5, 0.9, 1.0001, 1.333, 1.5, 2.42, 4.0}) {
        for (int i = 0; i <= 100; ++i) {
            const double c = i / 100.0;
            EXPECT_NEAR(fresnel_conductor(c, eta, 0.0), fresnel_dielectric(c, eta), 1e-14)
                << "eta = " << eta << " cos = " << c;
        }
    }
}

TEST(Fresnel, ConductorNormalIncidenceClosedForm) {
    for (const IorEntry& e : ior_table()) {
        for (int ch = 0; ch < 3; ++ch) {
            const double n = e.eta[ch];
            const double k = e.k[ch];
            const double expected = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
            EXPECT_NEAR(fresnel_conductor(1.0, n, k), expected, 1e-14) << e.name << " ch " << ch;
        }
    }
}

TEST(Fresnel, ConductorIsOneAtGrazingAndWithinUnitInterval) {
    for (double k : {0.0, 0.5, 3.0, 10.0}) {
        for (double eta : {0.2, 1.0, 2.5}) {
            EXPECT_NEAR(fresnel_conductor(0.0, eta, k), 1.0, 1e-12);
            for (int i = 0; i <= 50; ++i) {
                const double f = fresnel_conductor(i / 50.0, eta, k);
                EXPECT_GE(f, 0.0);
                EXPECT_LE(f, 1.0 + 1e-15);
            }
        }
    }
}

TEST(Fresnel, MetalsFromTheTableReflectMoreThanGlass) {
    // Copper reflects red more than blue; silver above 0.9 at normal incidence in every channel
    // (a property of the tabulated constants, not of our formula).
    const IorEntry* cu = find_ior("copper");
    ASSERT_NE(cu, nullptr);
    EXPECT_GT(fresnel_conductor(1.0, cu->eta[0], cu->k[0]),
              fresnel_conductor(1.0, cu->eta[2], cu->k[2]));
    const IorEntry* ag = find_ior("silver");
    ASSERT_NE(ag, nullptr);
    for (int ch = 0; ch < 3; ++ch) {
        EXPECT_GT(fresnel_conductor(1.0, ag->eta[ch], ag->k[ch]), 0.85);
    }
    EXPECT_EQ(find_ior("unobtainium"), nullptr);
    EXPECT_NE(find_ior("diamond"), nullptr);
}

}  // namespace
}  // namespace gonio::brdf
