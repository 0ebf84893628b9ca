// Numerical stress: theta up to 89.999 degrees, alpha from 1e-4 to 1, eta from 1.0001 to 4, k up to
// 10, wi = wo, mirror pairs, directions exactly at the horizon. Every value and every Jet
// derivative must be finite and non-negative (values); the relative error against a long double
// evaluation of the same formulas is reported and bounded.

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {
namespace {

using Jet = ceres::Jet<double, 4>;
using LD = long double;

std::vector<Vec3d> stress_directions() {
    std::vector<Vec3d> out;
    const double deg = kPi / 180;
    for (double t : {0.0,
                     1e-8,
                     0.5 * deg,
                     30 * deg,
                     60 * deg,
                     85 * deg,
                     89.9 * deg,
                     89.99 * deg,
                     89.999 * deg}) {
        for (double p : {0.0, 0.3, 2.5}) {
            out.push_back(spherical_to_cartesian(t, p));
        }
    }
    // Exactly at the horizon.
    out.emplace_back(1.0, 0.0, 0.0);
    out.emplace_back(0.0, -1.0, 0.0);
    return out;
}

std::vector<Lobe<double>> stress_lobes() {
    std::vector<Lobe<double>> out;
    for (Distribution d :
         {Distribution::kGgx, Distribution::kBeckmann, Distribution::kBlinnPhong}) {
        for (double alpha : {1e-4, 1e-3, 0.01, 0.1, 0.5, 1.0}) {
            for (Shadowing s : {Shadowing::kSmithCorrelated,
                                Shadowing::kSmithSeparable,
                                Shadowing::kVGroove,
                                Shadowing::kNone}) {
                for (int f = 0; f < 5; ++f) {
                    Lobe<double> l;
                    l.distribution = d;
                    l.alpha_x = alpha;
                    l.alpha_y = alpha * 3;
                    l.anisotropic = f % 2 == 1;
                    // Blinn-Phong: the exponent that matches this alpha, 2/alpha^2 - 2, capped.
                    l.exponent = std::min(2 / (alpha * alpha) - 2 + 1e-3, 1e7);
                    l.shadowing = s;
                    switch (f) {
                        case 0:
                            l.fresnel.type = FresnelType::kSchlick;
                            l.fresnel.f0 = Rgbd(0.0, 0.04, 1.0);
                            break;
                        case 1:
                            l.fresnel.type = FresnelType::kDielectric;
                            l.fresnel.eta = 1.0001;
                            break;
                        case 2:
                            l.fresnel.type = FresnelType::kDielectric;
                            l.fresnel.eta = 4.0;
                            break;
                        case 3:
                            l.fresnel.type = FresnelType::kConductor;
                            l.fresnel.eta_rgb = Rgbd(0.05, 1.0001, 4.0);
                            l.fresnel.k = Rgbd(10.0, 0.0, 3.0);
                            break;
                        default:
                            l.fresnel.type = FresnelType::kNone;
                            break;
                    }
                    out.push_back(l);
                }
            }
        }
    }
    return out;
}

template <class To>
Model<To> cast_to(const ModelD& m) {
    return cast_model<To>(m, [](double v) { return To(v); });
}

TEST(ModelStress, FiniteNonNegativeAndCloseToLongDouble) {
    const auto dirs = stress_directions();
    double worst_rel = 0;
    std::string worst_where;
    std::size_t n_values = 0;
    for (const Lobe<double>& l : stress_lobes()) {
        ModelD m;
        m.diffuse = Rgbd(0.0, 0.5, 1.0);
        m.lobes = {l};
        const Model<LD> ml = cast_to<LD>(m);
        Model<Jet> mj = cast_to<Jet>(m);
        mj.lobes[0].alpha_x.v[0] = 1;
        mj.lobes[0].alpha_y.v[1] = 1;
        mj.lobes[0].exponent.v[1] = 1;
        mj.lobes[0].fresnel.eta.v[2] = 1;
        mj.lobes[0].fresnel.eta_rgb[0].v[2] = 1;
        mj.lobes[0].fresnel.k[2].v[3] = 1;
        mj.lobes[0].fresnel.f0[1].v[3] = 1;
        for (std::size_t a = 0; a < dirs.size(); ++a) {
            for (std::size_t b = 0; b < dirs.size() + 1; ++b) {
                const Vec3d& wi = dirs[a];
                // The last pair is the mirror configuration wo = reflect(wi) (wi = -wo reflected).
                const Vec3d wo = b < dirs.size() ? dirs[b] : reflect_z(wi);
                const Rgbd f = eval_model(m, wi, wo);
                const Rgb<LD> fl = eval_model(ml, Vec3<LD>(wi.cast<LD>()), Vec3<LD>(wo.cast<LD>()));
                const Rgb<Jet> fj =
                    eval_model(mj, Vec3<Jet>(wi.cast<Jet>()), Vec3<Jet>(wo.cast<Jet>()));
                for (int c = 0; c < 3; ++c) {
                    ++n_values;
                    ASSERT_TRUE(std::isfinite(f[c]) && f[c] >= 0)
                        << f[c] << " lobe " << to_string(l.distribution) << " alpha " << l.alpha_x
                        << " " << to_string(l.shadowing) << " " << to_string(l.fresnel.type)
                        << " wi " << wi.transpose() << " wo " << wo.transpose();
                    ASSERT_TRUE(std::isfinite(fj[c].a) && fj[c].v.allFinite())
                        << "Jet " << fj[c] << " lobe " << to_string(l.distribution) << " alpha "
                        << l.alpha_x << " " << to_string(l.shadowing) << " "
                        << to_string(l.fresnel.type) << " wi " << wi.transpose() << " wo "
                        << wo.transpose();
                    // Jet arithmetic rounds differently (division by reciprocal); Schlick's (1 -
                    // cos)^5 magnifies that near cos = 1 (1e-11 relative at 0.25 deg).
                    ASSERT_NEAR(fj[c].a, f[c], 1e-9 * f[c])
                        << to_string(l.distribution) << " alpha " << l.alpha_x << " "
                        << to_string(l.shadowing) << " " << to_string(l.fresnel.type) << " wi "
                        << wi.transpose() << " wo " << wo.transpose();
                    const LD ref = fl[c];
                    const double rel = static_cast<double>(std::fabs(static_cast<LD>(f[c]) - ref) /
                                                           (std::fabs(ref) + 1e-280L));
                    if (rel > worst_rel) {
                        worst_rel = rel;
                        worst_where = std::string(to_string(l.distribution)) + " alpha " +
                                      std::to_string(l.alpha_x) + " " + to_string(l.shadowing) +
                                      " " + to_string(l.fresnel.type);
                    }
                }
            }
        }
    }
    std::printf("stress: %zu values, worst relative error vs long double %.3g (%s)\n",
                n_values,
                worst_rel,
                worst_where.c_str());
    RecordProperty("worst_relative_error", std::to_string(worst_rel));
    EXPECT_LT(worst_rel, 1e-9) << worst_where;
}

TEST(ModelStress, WiEqualsWoAndMirrorAreFiniteForTheSharpestLobe) {
    ModelD m;
    m.has_diffuse = false;
    Lobe<double> l;
    l.alpha_x = l.alpha_y = 1e-4;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd::Constant(0.04);
    m.lobes = {l};
    const Vec3d wi = spherical_to_cartesian(0.5, 0.0);
    // Mirror: h = n, D = 1/(pi alpha^2) = 3.18e7.
    const Rgbd mirror = eval_model(m, wi, reflect_z(wi));
    const double F = 0.04 + 0.96 * std::pow(1 - std::cos(0.5), 5);
    const double lambda = (-1 + std::sqrt(1 + 1e-8 * std::pow(std::tan(0.5), 2))) / 2;
    const double expected =
        F / (kPi * 1e-8) / (1 + 2 * lambda) / (4 * std::cos(0.5) * std::cos(0.5));
    EXPECT_NEAR(mirror[0], expected, 1e-12 * expected);
    // wi = wo off the mirror: far tail, tiny but finite and >= 0.
    const Rgbd same = eval_model(m, wi, wi);
    EXPECT_TRUE(std::isfinite(same[0]));
    EXPECT_GE(same[0], 0.0);
    EXPECT_LT(same[0], 1e-6);
}

}  // namespace
}  // namespace gonio::brdf
