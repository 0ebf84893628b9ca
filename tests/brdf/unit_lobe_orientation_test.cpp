// The orientation of anisotropic lobes (brdf/lobe_orientation.h, Lobe::orientation_deg): evaluation
// against an independent closed form (the anisotropic GGX D written with the turned axes, and the
// whole lobe at directions turned by hand with Eigen's rotation), the lobe's symmetries, Jets and
// packets through the same body, sampling, and the model file's orientation_deg.

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "brdf_test_util.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/sampling.h"

namespace gonio::brdf {
namespace {

double deg(double d) {
    return d * kPi / 180;
}

Lobe<double> aniso_lobe(Distribution d, double ax, double ay, double phi_deg) {
    Lobe<double> l;
    l.distribution = d;
    l.anisotropic = true;
    l.alpha_x = ax;
    l.alpha_y = ay;
    l.orientation_deg = phi_deg;
    l.gamma = 3.5;
    l.shadowing = Shadowing::kSmithCorrelated;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd(0.9, 0.6, 0.3);
    l.scale = Rgbd::Ones();
    return l;
}

/// Seeded directions above the horizon, including the normal and near-grazing ones.
std::vector<Vec3d> directions(std::uint64_t seed, int n) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Vec3d> out = {Vec3d(0, 0, 1), spherical_to_cartesian(deg(89.9), 0.3)};
    while (static_cast<int>(out.size()) < n) {
        out.push_back(spherical_to_cartesian(std::acos(u(rng)), 2 * kPi * u(rng)));
    }
    return out;
}

/// The turn about the normal by angle a (counter-clockwise seen from above), by Eigen.
Vec3d turned(const Vec3d& w, double a) {
    return Eigen::AngleAxisd(a, Vec3d::UnitZ()) * w;
}

// The anisotropic GGX D with the lobe's axes u = (cos phi, sin phi, 0), v = (-sin phi, cos phi,
// 0) written out (Trowbridge and Reitz 1975; Walter et al. 2007 eq. 33 with tangent axes u, v):
//   D(h) = 1 / (pi ax ay ((h.u / ax)^2 + (h.v / ay)^2 + h_z^2)^2).
TEST(LobeOrientation, GgxDMatchesTheClosedFormWithTurnedAxes) {
    for (double phi_deg : {0.0, 30.0, 90.0, 137.0, -20.0}) {
        const Lobe<double> l = aniso_lobe(Distribution::kGgx, 0.08, 0.3, phi_deg);
        const Vec3d u(std::cos(deg(phi_deg)), std::sin(deg(phi_deg)), 0);
        const Vec3d v(-std::sin(deg(phi_deg)), std::cos(deg(phi_deg)), 0);
        for (const Vec3d& h : directions(7, 200)) {
            const double s =
                std::pow(h.dot(u) / 0.08, 2) + std::pow(h.dot(v) / 0.3, 2) + h.z() * h.z();
            const double expected = 1 / (kPi * 0.08 * 0.3 * s * s);
            EXPECT_NEAR(lobe_D(l, h), expected, 1e-12 * expected) << "phi " << phi_deg;
        }
    }
}

// The lobe turned by phi at (wi, wo) is the unturned lobe at (R(-phi) wi, R(-phi) wo): the whole
// f (D, both Smith Lambdas, Fresnel, cosines) for every distribution and shadowing.
TEST(LobeOrientation, TurnedLobeEqualsTheUnturnedLobeAtDirectionsTurnedBack) {
    for (Distribution d : {Distribution::kGgx, Distribution::kBeckmann, Distribution::kStudentT}) {
        for (Shadowing sh :
             {Shadowing::kSmithCorrelated, Shadowing::kSmithSeparable, Shadowing::kVGroove}) {
            for (double phi_deg : {30.0, 75.0, 160.0}) {
                Lobe<double> l = aniso_lobe(d, 0.1, 0.4, phi_deg);
                l.shadowing = sh;
                Lobe<double> l0 = l;
                l0.orientation_deg = 0;
                const std::vector<Vec3d> dirs = directions(11, 40);
                for (const Vec3d& wi : dirs) {
                    for (const Vec3d& wo : dirs) {
                        const Rgbd f = eval_lobe(l, wi, wo);
                        const Rgbd f0 =
                            eval_lobe(l0, turned(wi, -deg(phi_deg)), turned(wo, -deg(phi_deg)));
                        for (int c = 0; c < 3; ++c) {
                            EXPECT_NEAR(f[c], f0[c], 1e-11 * std::max(1.0, f0[c]))
                                << to_string(d) << " " << to_string(sh) << " phi " << phi_deg;
                        }
                    }
                }
            }
        }
    }
}

// The lobe's symmetries: period 180 degrees, and a quarter turn with the slopes exchanged.
TEST(LobeOrientation, HalfTurnAndQuarterTurnWithSwappedSlopesGiveTheSameLobe) {
    const Lobe<double> l = aniso_lobe(Distribution::kGgx, 0.08, 0.3, 30);
    const Lobe<double> half = aniso_lobe(Distribution::kGgx, 0.08, 0.3, 210);
    const Lobe<double> quarter = aniso_lobe(Distribution::kGgx, 0.3, 0.08, 120);
    const Lobe<double> wrong = aniso_lobe(Distribution::kGgx, 0.08, 0.3, 120);
    double worst_wrong = 0;
    const std::vector<Vec3d> dirs = directions(3, 30);
    for (const Vec3d& wi : dirs) {
        for (const Vec3d& wo : dirs) {
            const double f = eval_lobe(l, wi, wo)[0];
            EXPECT_NEAR(eval_lobe(half, wi, wo)[0], f, 1e-11 * std::max(1.0, f));
            EXPECT_NEAR(eval_lobe(quarter, wi, wo)[0], f, 1e-11 * std::max(1.0, f));
            worst_wrong = std::max(worst_wrong, std::abs(eval_lobe(wrong, wi, wo)[0] - f));
        }
    }
    // The quarter turn without the exchange is another lobe.
    EXPECT_GT(worst_wrong, 0.1);
}

// An isotropic lobe does not depend on its orientation; an anisotropic lobe at alpha_x = alpha_y
// neither.
TEST(LobeOrientation, EqualSlopesDoNotDependOnTheTurn) {
    const Lobe<double> a = aniso_lobe(Distribution::kBeckmann, 0.2, 0.2, 0);
    const Lobe<double> b = aniso_lobe(Distribution::kBeckmann, 0.2, 0.2, 47);
    const std::vector<Vec3d> dirs = directions(5, 25);
    for (const Vec3d& wi : dirs) {
        for (const Vec3d& wo : dirs) {
            const double f = eval_lobe(a, wi, wo)[1];
            EXPECT_NEAR(eval_lobe(b, wi, wo)[1], f, 1e-12 * std::max(1.0, f));
        }
    }
}

// d f / d orientation through Jets (the same body) against a central difference of the double
// evaluation.
TEST(LobeOrientation, JetDerivativeMatchesCentralDifference) {
    using J = ceres::Jet<double, 1>;
    const Lobe<double> l = aniso_lobe(Distribution::kGgx, 0.1, 0.35, 25);
    Lobe<J> lj = cast_model<J>(Model<double>{false, Rgbd::Zero(), {l}}, [](double v) {
                     return J(v);
                 }).lobes[0];
    lj.orientation_deg = J(l.orientation_deg, 0);
    int checked = 0;
    const std::vector<Vec3d> dirs = directions(13, 20);
    for (const Vec3d& wi : dirs) {
        for (const Vec3d& wo : dirs) {
            const Vec3<J> wij(J(wi.x()), J(wi.y()), J(wi.z()));
            const Vec3<J> woj(J(wo.x()), J(wo.y()), J(wo.z()));
            const J f = eval_lobe(lj, wij, woj)[0];
            const double h = 1e-4;  // degrees
            Lobe<double> lp = l, lm = l;
            lp.orientation_deg += h;
            lm.orientation_deg -= h;
            const double fd = (eval_lobe(lp, wi, wo)[0] - eval_lobe(lm, wi, wo)[0]) / (2 * h);
            EXPECT_NEAR(f.v[0], fd, 1e-5 * std::max(1.0, std::abs(fd)));
            checked += std::abs(fd) > 1e-3;
        }
    }
    EXPECT_GT(checked, 50);
}

// Packets evaluate the turned lobe through the same body as the scalar code.
TEST(LobeOrientation, PacketsAgreeWithScalarsForTurnedLobes) {
    for (Distribution d : {Distribution::kGgx, Distribution::kBeckmann}) {
        ModelD m;
        m.diffuse = Rgbd(0.1, 0.2, 0.3);
        m.lobes.push_back(aniso_lobe(d, 0.08, 0.3, 30));
        m.lobes.push_back(aniso_lobe(d, 0.4, 0.15, 112));
        const std::vector<Vec3d> dirs = directions(17, 37);
        std::vector<double> c[6];
        for (const Vec3d& wi : dirs) {
            for (const Vec3d& wo : dirs) {
                const double v[6] = {wi.x(), wi.y(), wi.z(), wo.x(), wo.y(), wo.z()};
                for (int k = 0; k < 6; ++k) {
                    c[k].push_back(v[k]);
                }
            }
        }
        const std::size_t n = c[0].size();
        std::vector<double> out[3] = {
            std::vector<double>(n), std::vector<double>(n), std::vector<double>(n)};
        double* o[3] = {out[0].data(), out[1].data(), out[2].data()};
        eval_model_packets(
            m,
            n,
            {c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data(), c[5].data()},
            o);
        for (std::size_t k = 0; k < n; ++k) {
            const Rgbd f =
                eval_model(m, Vec3d(c[0][k], c[1][k], c[2][k]), Vec3d(c[3][k], c[4][k], c[5][k]));
            for (int ch = 0; ch < 3; ++ch) {
                // Beckmann's exp and erfc run through xsimd's functions on packets
                // (unit_packet_formulas_test.cpp states the agreement).
                EXPECT_NEAR(out[ch][k], f[ch], 1e-12 * std::max(1.0, f[ch])) << to_string(d);
            }
        }
    }
}

// Sampling a turned lobe: the drawn directions are those of the unturned lobe turned by phi, and
// the pdf is that of pdf_lobe.
TEST(LobeOrientation, SamplingTurnsWithTheLobe) {
    for (Distribution d : {Distribution::kGgx, Distribution::kBeckmann}) {
        const double phi = deg(40);
        Lobe<double> l = aniso_lobe(d, 0.05, 0.4, 40);
        Lobe<double> l0 = l;
        l0.orientation_deg = 0;
        const Vec3d wi = spherical_to_cartesian(deg(50), deg(70));
        std::mt19937_64 rng(21);
        std::uniform_real_distribution<double> u(0, 1);
        for (int k = 0; k < 200; ++k) {
            const double u1 = u(rng), u2 = u(rng);
            const DirectionSample s = sample_lobe(l, wi, u1, u2);
            const DirectionSample s0 = sample_lobe(l0, turned(wi, -phi), u1, u2);
            ASSERT_EQ(s.pdf > 0, s0.pdf > 0);
            if (s.pdf > 0) {
                EXPECT_NEAR((s.w - turned(s0.w, phi)).norm(), 0, 1e-12);
                EXPECT_NEAR(s.pdf, s0.pdf, 1e-10 * s0.pdf);
                EXPECT_NEAR(s.pdf, pdf_lobe(l, wi, s.w), 1e-10 * s.pdf);
            }
        }
    }
}

using test_util::error_of;

TEST(LobeOrientation, ModelFileRoundTripKeepsOrientation) {
    const auto m = parse_model_json(
        R"({"lobes":[{"distribution":"ggx","alpha_x":0.08,"alpha_y":0.3,"orientation_deg":30,
            "shadowing":"smith-correlated","fresnel":{"type":"none"}}]})",
        "m.json");
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_EQ(m->lobes[0].orientation_deg, 30);
    const std::string text = model_to_json(*m);
    EXPECT_NE(text.find("\"orientation_deg\": 30"), std::string::npos) << text;
    const auto back = parse_model_json(text, "back.json");
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->lobes[0].orientation_deg, 30);
    EXPECT_NE(describe_model(*back).find("orientation 30 deg"), std::string::npos);
    // An unturned lobe writes no orientation (files of earlier versions stay as they were).
    ModelD flat = *m;
    flat.lobes[0].orientation_deg = 0;
    EXPECT_EQ(model_to_json(flat).find("orientation"), std::string::npos);
}

TEST(LobeOrientation, ModelFileRefusesOrientationWhereItMeansNothing) {
    const std::string tail = R"("shadowing":"smith-correlated","fresnel":{"type":"none"})";
    EXPECT_EQ(error_of(R"({"lobes":[{"distribution":"ggx","alpha":0.1,"orientation_deg":30,)" +
                       tail + "}]}"),
              "model.json: lobes[0].orientation_deg: only for anisotropic lobes (\"alpha_x\" and "
              "\"alpha_y\"); an isotropic lobe does not depend on it");
    EXPECT_NE(
        error_of(R"({"lobes":[{"distribution":"blinn-phong","exponent":50,"orientation_deg":10}]})")
            .find("lobes[0].orientation_deg: only for anisotropic lobes"),
        std::string::npos);
    EXPECT_NE(error_of(R"({"lobes":[{"distribution":"ggx","alpha_x":0.1,"alpha_y":0.2,)"
                       R"("orientation_deg":400,)" +
                       tail + "}]}")
                  .find("lobes[0].orientation_deg = 400: must be in [-360, 360] degrees"),
              std::string::npos);
    EXPECT_NE(error_of(R"({"lobes":[{"distribution":"ggx","alpha_x":0.1,"alpha_y":0.2,)"
                       R"("orientation_deg":"30",)" +
                       tail + "}]}")
                  .find("lobes[0].orientation_deg"),
              std::string::npos);
}

}  // namespace
}  // namespace gonio::brdf
