// eval_model against closed forms written out independently, the horizon rule, and derivatives
// through ceres::Jet against central finite differences.

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {
namespace {

Lobe<double> ggx_lobe(double alpha, Shadowing s, FresnelType f) {
    Lobe<double> l;
    l.distribution = Distribution::kGgx;
    l.alpha_x = l.alpha_y = alpha;
    l.shadowing = s;
    l.fresnel.type = f;
    l.fresnel.f0 = Rgbd(0.04, 0.5, 0.9);
    return l;
}

TEST(ModelEval, NormalIncidenceClosedForm) {
    // wi = wo = n: h = n, D = 1/(pi alpha^2), Lambda = 0 so G = 1, F = f0, cos_i = cos_o = 1.
    ModelD m;
    m.diffuse = Rgbd(0.2, 0.3, 0.4);
    m.lobes.push_back(ggx_lobe(0.25, Shadowing::kSmithCorrelated, FresnelType::kSchlick));
    const Vec3d n(0, 0, 1);
    const Rgbd f = eval_model(m, n, n);
    for (int c = 0; c < 3; ++c) {
        const double expected = m.diffuse[c] / kPi + m.lobes[0].fresnel.f0[c] / (4 * kPi * 0.0625);
        EXPECT_NEAR(f[c], expected, 1e-13 * expected);
    }
}

TEST(ModelEval, GeneralConfigurationMatchesWrittenOutFormula) {
    // GGX, height-correlated Smith, Schlick, written with trigonometry from the papers' forms.
    const double alpha = 0.3;
    const double theta_i = 0.6, phi_i = 0.2, theta_o = 0.9, phi_o = 2.8;
    const Vec3d wi = spherical_to_cartesian(theta_i, phi_i);
    const Vec3d wo = spherical_to_cartesian(theta_o, phi_o);
    const Vec3d h = (wi + wo).normalized();
    const double cos_h = h.z();
    const double tan2_h = (1 - cos_h * cos_h) / (cos_h * cos_h);
    const double D =
        1 / (kPi * alpha * alpha * std::pow(cos_h, 4) * std::pow(1 + tan2_h / (alpha * alpha), 2));
    auto Lambda = [&](double theta) {
        return (-1 + std::sqrt(1 + alpha * alpha * std::pow(std::tan(theta), 2))) / 2;
    };
    const double G = 1 / (1 + Lambda(theta_i) + Lambda(theta_o));
    const double c = wi.dot(h);
    const double F = 0.5 + 0.5 * std::pow(1 - c, 5);
    const double expected = 0.1 / kPi + F * D * G / (4 * std::cos(theta_i) * std::cos(theta_o));

    ModelD m;
    m.diffuse = Rgbd::Constant(0.1);
    Lobe<double> l = ggx_lobe(alpha, Shadowing::kSmithCorrelated, FresnelType::kSchlick);
    l.fresnel.f0 = Rgbd::Constant(0.5);
    m.lobes.push_back(l);
    EXPECT_NEAR(eval_model(m, wi, wo)[0], expected, 1e-13 * expected);
    // The lobe alone equals eval_lobe.
    EXPECT_NEAR(eval_lobe(l, wi, wo)[1], expected - 0.1 / kPi, 1e-13 * expected);
}

TEST(ModelEval, ZeroAtAndBelowTheHorizon) {
    ModelD m;
    m.diffuse = Rgbd::Constant(0.5);
    m.lobes.push_back(ggx_lobe(0.2, Shadowing::kNone, FresnelType::kNone));
    const Vec3d up = spherical_to_cartesian(0.3, 0.0);
    const Vec3d horizon(1, 0, 0);
    const Vec3d below = spherical_to_cartesian(1.7, 1.0);
    EXPECT_TRUE((eval_model(m, up, horizon) == 0).all());
    EXPECT_TRUE((eval_model(m, horizon, up) == 0).all());
    EXPECT_TRUE((eval_model(m, below, up) == 0).all());
    EXPECT_TRUE((eval_model(m, up, below) == 0).all());
    EXPECT_TRUE((eval_lobe(m.lobes[0], up, below) == 0).all());
    EXPECT_TRUE((eval_model(m, up, up) > 0).all());
}

TEST(ModelEval, AnalyticBrdfWrapsTheModel) {
    ModelD m;
    m.diffuse = Rgbd::Constant(0.5);
    Lobe<double> l = ggx_lobe(0.2, Shadowing::kSmithCorrelated, FresnelType::kSchlick);
    l.anisotropic = true;
    l.alpha_y = 0.4;
    m.lobes.push_back(l);
    const auto brdf = make_analytic_brdf(m);
    const Vec3d wi = spherical_to_cartesian(0.4, 0.1);
    const Vec3d wo = spherical_to_cartesian(0.5, 2.0);
    EXPECT_TRUE((brdf->eval(wi, wo) == eval_model(m, wi, wo)).all());
    EXPECT_FALSE(brdf->isotropic());
    m.lobes[0].alpha_y = 0.2;
    EXPECT_TRUE(make_analytic_brdf(m)->isotropic());
    EXPECT_NE(brdf->describe().find("ggx"), std::string::npos);
}

// ----- derivatives through Jets -----

constexpr int kN = 8;
using Jet = ceres::Jet<double, kN>;

/// A parameter of a lobe/model addressed by index, for seeding Jets and finite differences.
using Accessor = std::function<double&(ModelD&)>;

struct Param {
    const char* name;
    Accessor get;
};

Model<Jet> to_jets(const ModelD& m, const std::vector<Param>& params) {
    Model<Jet> mj = cast_model<Jet>(m, [](double v) { return Jet(v); });
    // Seed: rebuild from a copy where each parameter is tagged, by matching addresses.
    for (std::size_t p = 0; p < params.size(); ++p) {
        ModelD probe = m;
        double& slot = params[p].get(probe);
        const double saved = slot;
        slot = saved + 1.0;  // mark, then find which Jet field differs
        Model<Jet> marked = cast_model<Jet>(probe, [](double v) { return Jet(v); });
        auto seed = [&](Jet& a, const Jet& b) {
            if (a.a != b.a) {
                a.v[p] = 1.0;
            }
        };
        seed(mj.diffuse[0], marked.diffuse[0]);
        seed(mj.diffuse[1], marked.diffuse[1]);
        seed(mj.diffuse[2], marked.diffuse[2]);
        for (std::size_t i = 0; i < mj.lobes.size(); ++i) {
            Lobe<Jet>& a = mj.lobes[i];
            const Lobe<Jet>& b = marked.lobes[i];
            seed(a.alpha_x, b.alpha_x);
            seed(a.alpha_y, b.alpha_y);
            seed(a.exponent, b.exponent);
            seed(a.fresnel.eta, b.fresnel.eta);
            for (int c = 0; c < 3; ++c) {
                seed(a.fresnel.f0[c], b.fresnel.f0[c]);
                seed(a.fresnel.eta_rgb[c], b.fresnel.eta_rgb[c]);
                seed(a.fresnel.k[c], b.fresnel.k[c]);
                seed(a.scale[c], b.scale[c]);
            }
        }
    }
    return mj;
}

void expect_gradient_matches_finite_differences(const ModelD& m, const std::vector<Param>& params) {
    const Model<Jet> mj = to_jets(m, params);
    const double dirs[][4] = {
        {0.3, 0.0, 0.5, 3.0}, {1.2, 0.4, 0.2, 2.9}, {0.7, 1.0, 1.4, -2.0}, {0.0, 0.0, 0.0, 0.0}};
    for (const auto& d : dirs) {
        const Vec3d wi = spherical_to_cartesian(d[0], d[1]);
        const Vec3d wo = spherical_to_cartesian(d[2], d[3]);
        const Rgb<Jet> fj = eval_model(mj, Vec3<Jet>(wi.cast<Jet>()), Vec3<Jet>(wo.cast<Jet>()));
        const Rgbd f = eval_model(m, wi, wo);
        for (std::size_t p = 0; p < params.size(); ++p) {
            ModelD plus = m;
            ModelD minus = m;
            double& xp = params[p].get(plus);
            double& xm = params[p].get(minus);
            const double step = 1e-6 * std::max(1.0, std::abs(xp));
            xp += step;
            xm -= step;
            const Rgbd fd = (eval_model(plus, wi, wo) - eval_model(minus, wi, wo)) / (2 * step);
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(fj[c].a, f[c], 1e-14 * std::abs(f[c]));
                ASSERT_TRUE(std::isfinite(fj[c].v[p]));
                EXPECT_NEAR(fj[c].v[p], fd[c], 1e-6 * (std::abs(fd[c]) + std::abs(f[c]) + 1e-3))
                    << params[p].name << " channel " << c << " dirs " << d[0] << " " << d[1] << " "
                    << d[2] << " " << d[3];
            }
        }
    }
}

TEST(ModelEvalJet, GradientMatchesFiniteDifferencesGgxSchlick) {
    ModelD m;
    m.diffuse = Rgbd(0.2, 0.3, 0.4);
    Lobe<double> l = ggx_lobe(0.3, Shadowing::kSmithCorrelated, FresnelType::kSchlick);
    l.anisotropic = true;
    l.alpha_y = 0.15;
    l.scale = Rgbd(0.8, 1.0, 1.2);
    m.lobes.push_back(l);
    expect_gradient_matches_finite_differences(
        m,
        {{"diffuse[0]", [](ModelD& x) -> double& { return x.diffuse[0]; }},
         {"alpha_x", [](ModelD& x) -> double& { return x.lobes[0].alpha_x; }},
         {"alpha_y", [](ModelD& x) -> double& { return x.lobes[0].alpha_y; }},
         {"f0[1]", [](ModelD& x) -> double& { return x.lobes[0].fresnel.f0[1]; }},
         {"scale[2]", [](ModelD& x) -> double& { return x.lobes[0].scale[2]; }}});
}

TEST(ModelEvalJet, GradientMatchesFiniteDifferencesBeckmannConductorAndDielectric) {
    ModelD m;
    m.has_diffuse = false;
    Lobe<double> a = ggx_lobe(0.2, Shadowing::kSmithSeparable, FresnelType::kConductor);
    a.distribution = Distribution::kBeckmann;
    a.fresnel.eta_rgb = Rgbd(0.2, 1.0, 1.2);
    a.fresnel.k = Rgbd(3.6, 2.6, 2.3);
    Lobe<double> b = ggx_lobe(0.4, Shadowing::kVGroove, FresnelType::kDielectric);
    b.fresnel.eta = 1.5;
    Lobe<double> c = ggx_lobe(0.4, Shadowing::kSmithCorrelated, FresnelType::kSchlick);
    c.distribution = Distribution::kBlinnPhong;
    c.exponent = 30;
    m.lobes = {a, b, c};
    expect_gradient_matches_finite_differences(
        m,
        {{"beckmann alpha", [](ModelD& x) -> double& { return x.lobes[0].alpha_x; }},
         {"eta_rgb[0]", [](ModelD& x) -> double& { return x.lobes[0].fresnel.eta_rgb[0]; }},
         {"k[1]", [](ModelD& x) -> double& { return x.lobes[0].fresnel.k[1]; }},
         {"ggx alpha (v-groove)", [](ModelD& x) -> double& { return x.lobes[1].alpha_x; }},
         {"eta", [](ModelD& x) -> double& { return x.lobes[1].fresnel.eta; }},
         {"exponent", [](ModelD& x) -> double& { return x.lobes[2].exponent; }}});
}

}  // namespace
}  // namespace gonio::brdf
