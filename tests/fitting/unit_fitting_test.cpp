// Residual forms and their derivatives, the stratified reduction, specs and reports.

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "fit_test_util.h"
#include "gonio/brdf/model_json.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/reduction.h"
#include "gonio/fitting/report.h"
#include "stratum_kernel.h"

namespace gonio::fitting {
namespace {

using brdf::Rgbd;
using brdf::Sample;
using testing::deg;

Sample sample(double ti, double pi, double to, double po, Rgbd v) {
    Sample s;
    s.theta_i = ti;
    s.phi_i = pi;
    s.theta_o = to;
    s.phi_o = po;
    s.value = v;
    return s;
}

TEST(Residual, FormsMatchTheirDefinitions) {
    const double m = 0.7, d = 0.5, c = 0.6, fl = 1e-3;
    EXPECT_DOUBLE_EQ(channel_residual(ResidualForm::kAbsolute, m, d, c, fl), 0.2);
    EXPECT_DOUBLE_EQ(channel_residual(ResidualForm::kRelative, m, d, c, fl), 0.2 / 0.501);
    EXPECT_DOUBLE_EQ(channel_residual(ResidualForm::kLog, m, d, c, fl),
                     std::log(1.42) - std::log(1.3));
    EXPECT_DOUBLE_EQ(channel_residual(ResidualForm::kCosine, m, d, c, fl), 0.2 * 0.6);
    EXPECT_NEAR(channel_residual(ResidualForm::kCubeRoot, m, d, c, fl),
                std::pow(0.700001, 1.0 / 3) - std::pow(0.500001, 1.0 / 3),
                1e-15);
}

/// The batched cost's residuals equal channel_residual() of eval_model, weight and sigma applied.
TEST(Residual, BatchCostMatchesScalarResidualWithWeightAndSigma) {
    FitSpec spec = *make_fit_spec(ModelOptions{});
    auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
    std::vector<Sample> samples = {sample(0.3, 0, 0.4, 3.0, Rgbd(0.5, 0.6, 0.7)),
                                   sample(1.2, 1, 0.1, 2.0, Rgbd(0.1, 0.0, 2.0))};
    samples[1].weight = 4;
    samples[1].sigma = Rgbd(0.1, 0.2, 0.0);
    const std::vector<double> x = map->values_of(spec.model);
    const brdf::ModelD model = map->model<double>(x.data());
    for (ResidualForm form : {ResidualForm::kAbsolute,
                              ResidualForm::kRelative,
                              ResidualForm::kLog,
                              ResidualForm::kCosine,
                              ResidualForm::kCubeRoot}) {
        CostOptions co;
        co.residual = form;
        auto cost = make_batch_cost(map, samples, co);
        std::vector<double> r(6);
        const double* p[] = {x.data()};
        ASSERT_TRUE(cost->Evaluate(p, r.data(), nullptr));
        for (int i = 0; i < 2; ++i) {
            const Sample& s = samples[i];
            const Rgbd f = brdf::eval_model(model, s.wi(), s.wo());
            for (int c = 0; c < 3; ++c) {
                double expect = std::sqrt(s.weight) *
                                channel_residual(form, f[c], s.value[c], s.wi().z(), 1e-3);
                if (s.sigma[c] > 0) {
                    // Normalised by the first-order sigma of the residual, g'(d) sigma:
                    // g = identity (absolute, relative, cosine), log(1 + x cos_i), cbrt(x + 1e-6).
                    const double d = s.value[c];
                    const double ci = s.wi().z();
                    double g_diff = f[c] - d;
                    double dg = 1;
                    if (form == ResidualForm::kLog) {
                        g_diff = std::log(1 + f[c] * ci) - std::log(1 + d * ci);
                        dg = ci / (1 + d * ci);
                    } else if (form == ResidualForm::kCubeRoot) {
                        g_diff = std::cbrt(f[c] + 1e-6) - std::cbrt(d + 1e-6);
                        dg = 1 / (3 * std::pow(d + 1e-6, 2.0 / 3.0));
                    }
                    expect = std::sqrt(s.weight) * g_diff / (dg * s.sigma[c]);
                }
                EXPECT_NEAR(r[3 * i + c], expect, 1e-6 * std::abs(expect) + 1e-12)
                    << to_string(form) << " sample " << i << " channel " << c;
            }
        }
    }
}

/// ceres::GradientChecker of the automatic derivatives against central differences, for every
/// residual form and model structure, at ordinary points and at edges (normal incidence, exact
/// mirror direction, near grazing, narrow lobe, parameters at their bounds).
TEST(Residual, GradientCheckerPassesForEveryFormAtOrdinaryAndEdgePoints) {
    struct Point {
        const char* label;
        ModelOptions mo;
        double alpha;
        double diffuse;
        double f0;
    };
    ModelOptions ggx;
    ModelOptions beck = ggx;
    beck.distribution = brdf::Distribution::kBeckmann;
    beck.anisotropic = true;
    ModelOptions diel = ggx;
    diel.fresnel = brdf::FresnelType::kDielectric;
    diel.fresnel_rgb = false;
    ModelOptions cond = ggx;
    cond.fresnel = brdf::FresnelType::kConductor;
    ModelOptions bp = ggx;
    bp.distribution = brdf::Distribution::kBlinnPhong;
    ModelOptions scalar_f0 = ggx;
    scalar_f0.fresnel_rgb = false;
    scalar_f0.shadowing = brdf::Shadowing::kVGroove;
    const std::vector<Point> points = {
        {"ggx ordinary", ggx, 0.3, 0.4, 0.05},
        {"ggx narrow, diffuse and f0 near their lower bound", ggx, 0.02, 1e-3, 1e-3},
        {"ggx f0 at its upper bound", ggx, 0.1, 0.2, 1.0},
        {"beckmann anisotropic", beck, 0.2, 0.3, 0.1},
        {"dielectric", diel, 0.25, 0.1, 0.04},
        {"conductor", cond, 0.15, 0.05, 0.04},
        {"blinn-phong", bp, 0.1, 0.3, 0.05},
        {"scalar f0 v-groove", scalar_f0, 0.3, 0.2, 0.3},
    };
    // Directions: ordinary, normal incidence, exact mirror, near grazing both ways, backscatter.
    const std::vector<Sample> samples = {
        sample(deg(30), 0, deg(40), deg(170), Rgbd(0.3, 0.4, 0.5)),
        sample(0.0, 0, deg(20), deg(90), Rgbd(0.1, 0.1, 0.1)),
        sample(deg(45), 0.3, deg(45), 0.3 + brdf::kPi, Rgbd(2.0, 1.5, 1.0)),
        sample(deg(88), 0, deg(87), deg(180), Rgbd(5.0, 4.0, 3.0)),
        sample(deg(60), 1.0, deg(60), 1.0, Rgbd(0.0, 0.0, 0.0)),
    };
    for (const Point& pt : points) {
        FitSpec spec = *make_fit_spec(pt.mo);
        brdf::Lobe<double>& l = spec.model.lobes[0];
        l.alpha_x = pt.alpha;
        l.alpha_y = 1.5 * pt.alpha;
        l.exponent = 2 / (pt.alpha * pt.alpha) - 2;
        l.fresnel.f0 = Rgbd::Constant(pt.f0);
        l.fresnel.eta_rgb = Rgbd(0.2, 0.5, 1.3);
        l.fresnel.k = Rgbd(3.5, 2.4, 1.8);
        l.scale = Rgbd(1.0, 0.9, 0.8);
        spec.model.diffuse = Rgbd::Constant(pt.diffuse);
        auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
        std::vector<double> x = map->values_of(spec.model);
        for (ResidualForm form : {ResidualForm::kAbsolute,
                                  ResidualForm::kRelative,
                                  ResidualForm::kLog,
                                  ResidualForm::kCosine,
                                  ResidualForm::kCubeRoot}) {
            for (const Sample& s : samples) {
                SCOPED_TRACE(std::string(pt.label) + ", " + to_string(form) + ", theta_i " +
                             std::to_string(s.theta_i));
                CostOptions co;
                co.residual = form;
                auto cost = make_batch_cost(map, {s}, co);
                ceres::NumericDiffOptions nd;
                // Ridders extrapolation from a small first step (the default 1e-2 relative step
                // spans too much of a narrow lobe or of the steep cube root near 0).
                nd.ridders_relative_initial_step_size = 1e-6;
                const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
                ceres::GradientChecker checker(cost.get(), no_manifolds, nd);
                ceres::GradientChecker::ProbeResults results;
                const double* p[] = {x.data()};
                const bool ok = checker.Probe(p, 1e-4, &results);
                EXPECT_TRUE(ok) << results.error_log;
                for (int k = 0; k < map->size(); ++k) {
                    for (int c = 0; c < 3; ++c) {
                        ASSERT_TRUE(std::isfinite(results.jacobians[0](c, k)));
                    }
                }
            }
        }
    }
}

TEST(Reduction, KeepsTheBudgetAndPreservesEachStratumsWeight) {
    const auto grid = testing::measurement_grid();
    std::vector<Sample> all;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 20000; ++i) {
        all.push_back(sample(
            u(rng) * 1.5, u(rng) * 6 - 3, u(rng) * 1.5, u(rng) * 6 - 3, Rgbd::Constant(u(rng))));
    }
    const std::vector<Sample> kept = stratified_reduce(all, 2000, 3);
    EXPECT_GE(kept.size(), 1900u);
    EXPECT_LE(kept.size(), 2100u);
    // Total weight equals the input count (each stratum's n / m weights sum to n).
    double w = 0;
    double weighted_value = 0;
    double full_value = 0;
    for (const Sample& s : kept) {
        w += s.weight;
        weighted_value += s.weight * s.value[0];
    }
    for (const Sample& s : all) {
        full_value += s.value[0];
    }
    EXPECT_NEAR(w, 20000.0, 1e-6);
    // The weighted sum estimates the full sum (uniform values: standard error about 1 %).
    EXPECT_NEAR(weighted_value / full_value, 1.0, 0.05);
    // Deterministic with the seed; another seed picks other samples.
    const std::vector<Sample> again = stratified_reduce(all, 2000, 3);
    ASSERT_EQ(again.size(), kept.size());
    for (std::size_t i = 0; i < kept.size(); ++i) {
        ASSERT_EQ(again[i].theta_i, kept[i].theta_i);
    }
    const std::vector<Sample> other = stratified_reduce(all, 2000, 4);
    int same = 0;
    for (std::size_t i = 0; i < std::min(other.size(), kept.size()); ++i) {
        same += other[i].theta_i == kept[i].theta_i;
    }
    EXPECT_LT(same, static_cast<int>(kept.size()) / 2);
    // No reduction when the budget covers everything.
    EXPECT_EQ(stratified_reduce(all, 0, 1).size(), all.size());
    EXPECT_EQ(stratified_reduce(all, 50000, 1).size(), all.size());
}

TEST(Reduction, StratumCoordinatesAreTheHalfDifferenceAngles) {
    // The coordinates are computed from the half vector's components on packets, not through
    // brdf::to_half_diff's rotations by the angles: both agree to rounding on random pairs and on
    // the edges (normal incidence, the mirror direction, theta_h = 0 with wi = wo, grazing, phi
    // across the wrap, phi_d at 0 and pi).
    std::vector<Sample> all;
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double kHalfPi = brdf::kPi / 2;
    for (int i = 0; i < 5000; ++i) {
        all.push_back(sample(u(rng) * kHalfPi * 0.999,
                             u(rng) * 12 - 6,
                             u(rng) * kHalfPi * 0.999,
                             u(rng) * 12 - 6,
                             Rgbd::Ones()));
    }
    for (double t : {0.0, 1e-9, 0.3, 1.2, kHalfPi - 1e-6}) {
        for (double p : {0.0, 1e-12, 1.0, brdf::kPi, -brdf::kPi, 2 * brdf::kPi - 1e-12}) {
            all.push_back(sample(t, p, t, p, Rgbd::Ones()));              // wi = wo
            all.push_back(sample(t, p, t, p + brdf::kPi, Rgbd::Ones()));  // mirror
            all.push_back(sample(t, p, 0.4, p + 0.5, Rgbd::Ones()));
            all.push_back(sample(0.0, 0.0, t, p, Rgbd::Ones()));  // normal incidence
        }
    }
    // An odd count: the packets' last partial one too.
    all.push_back(sample(0.7, 2.0, 0.2, -1.0, Rgbd::Ones()));
    const std::vector<StratumCoords> coords = stratum_coordinates(all);
    ASSERT_EQ(coords.size(), all.size());
    for (std::size_t i = 0; i < all.size(); ++i) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(all[i].wi(), all[i].wo());
        // The angles back from the coordinates (theta_h under a square root, which would
        // magnify rounding near 0).
        const double theta_h = coords[i][0] * coords[i][0] * kHalfPi;
        const double theta_d = coords[i][1] * kHalfPi;
        EXPECT_NEAR(theta_h, hd.theta_h, 1e-9) << "sample " << i;
        EXPECT_NEAR(theta_d, hd.theta_d, 1e-9) << "sample " << i;
        if (hd.theta_h < 1e-4 || hd.theta_d < 1e-4 || hd.theta_d > kHalfPi - 1e-4) {
            // Near a pole of h or d the azimuths are rounding noise (the mirror direction,
            // wi = wo) or ill-conditioned.
            continue;
        }
        double phi_d = std::fmod(hd.phi_d, brdf::kPi);
        if (phi_d < 0) {
            phi_d += brdf::kPi;
        }
        // phi_d folded: 0 and pi are the same place (rounding may put one on either side).
        const double dp = std::abs(coords[i][2] * brdf::kPi - phi_d);
        EXPECT_LT(std::min(dp, brdf::kPi - dp), 1e-9) << "sample " << i;
    }
}

TEST(Reduction, StratumCoordinatesOfDoubleAndOfPacketsAgree) {
    // One body (stratum_kernel.h) for double, the path of a build without packet kernels, and for the
    // packets that stratum_coordinates uses here: on a seeded grid with the edges (normal
    // incidence, grazing, wi = wo, mirror, azimuths at and beyond +-pi) the two agree to 1e-10.
    // xsimd's sincos and atan2 are within a few ulp of the C library's; next to the mirror
    // direction h = wi + wo cancels to about 1e-11 and those ulp become absolute errors of a few
    // 1e-11 in theta_h and theta_d (the largest seen here: 2.9e-11); away from it they agree to
    // 3e-16 (checked below, to 1e-14). In a build without packet kernels (instruction_set.h) both
    // sides are the double path.
    constexpr double kHalfPi = brdf::kPi / 2;
    std::vector<Sample> all;
    for (double t : {0.0, 1e-9, 0.3, 1.2, kHalfPi - 1e-6}) {
        for (double p : {0.0, 1e-12, 1.0, brdf::kPi, -brdf::kPi, 2 * brdf::kPi - 1e-12}) {
            all.push_back(sample(t, p, t, p, Rgbd::Ones()));
            all.push_back(sample(t, p, t, p + brdf::kPi, Rgbd::Ones()));
            all.push_back(sample(t, p, 0.4, p + 0.5, Rgbd::Ones()));
            all.push_back(sample(0.0, 0.0, t, p, Rgbd::Ones()));
        }
    }
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 997; ++i) {
        all.push_back(sample(u(rng) * kHalfPi,
                             u(rng) * 4 * brdf::kPi - 2 * brdf::kPi,
                             u(rng) * kHalfPi,
                             u(rng) * 4 * brdf::kPi - 2 * brdf::kPi,
                             Rgbd::Ones()));
    }
    const std::vector<StratumCoords> packets = stratum_coordinates(all);
    ASSERT_EQ(packets.size(), all.size());
    double far_from_mirror = 0;
    for (std::size_t i = 0; i < all.size(); ++i) {
        const Sample& s = all[i];
        double ch = -1, cd = -1, cp = -1;
        detail::stratum_coords_body(s.theta_i, s.phi_i, s.theta_o, s.phi_o, ch, cd, cp);
        // theta_h back from under its square root (which magnifies rounding near 0).
        EXPECT_NEAR(ch * ch, packets[i][0] * packets[i][0], 1e-10) << "sample " << i;
        EXPECT_NEAR(cd, packets[i][1], 1e-10) << "sample " << i;
        if (ch * ch * kHalfPi < 1e-4 || cd * kHalfPi < 1e-4 || cd * kHalfPi > kHalfPi - 1e-4) {
            // Near a pole of h or d the azimuth is rounding noise (see the test above).
            continue;
        }
        if (ch * ch * kHalfPi > 1e-3) {
            far_from_mirror = std::max(
                {far_from_mirror, std::abs(ch - packets[i][0]), std::abs(cd - packets[i][1])});
        }
        // phi_d folded: 0 and 1 are the same place.
        const double dp = std::abs(cp - packets[i][2]);
        EXPECT_LT(std::min(dp, 1 - dp), 1e-10) << "sample " << i;
    }
    std::printf("largest difference away from the mirror direction: %.3g\n", far_from_mirror);
    EXPECT_LT(far_from_mirror, 1e-14);
}

TEST(Reduction, CoordinatesComputedOnceGiveTheSameReductions) {
    // The fit reduces its working set twice (scoring set, screen) from one computation of the
    // stratum coordinates: each reduction equals the one that computes them itself, sample for
    // sample and weight for weight; every coordinate lies in [0, 1].
    std::vector<Sample> all;
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 6000; ++i) {
        all.push_back(sample(
            u(rng) * 1.5, u(rng) * 6 - 3, u(rng) * 1.5, u(rng) * 6 - 3, Rgbd::Constant(u(rng))));
    }
    const std::vector<StratumCoords> coords = stratum_coordinates(all);
    ASSERT_EQ(coords.size(), all.size());
    for (const StratumCoords& c : coords) {
        for (double v : c) {
            ASSERT_GE(v, 0.0);
            ASSERT_LE(v, 1.0);
        }
    }
    for (const auto& [budget, seed] : {std::pair<std::size_t, std::uint64_t>{1500, 1},
                                       std::pair<std::size_t, std::uint64_t>{1500, 3},
                                       std::pair<std::size_t, std::uint64_t>{400, 2}}) {
        const std::vector<Sample> a = stratified_reduce(all, budget, seed);
        const std::vector<Sample> b = stratified_reduce(all, budget, seed, coords);
        ASSERT_EQ(a.size(), b.size());
        for (std::size_t i = 0; i < a.size(); ++i) {
            ASSERT_EQ(a[i].theta_i, b[i].theta_i);
            ASSERT_EQ(a[i].phi_o, b[i].phi_o);
            ASSERT_EQ(a[i].weight, b[i].weight);
        }
    }
}

TEST(Spec, DefaultsAreGgxLambertScalarSchlickWithRgbScale) {
    FitSpec spec = *make_fit_spec(ModelOptions{});
    EXPECT_EQ(spec.options.residual, ResidualForm::kLog);
    ASSERT_EQ(spec.model.lobes.size(), 1u);
    EXPECT_EQ(spec.model.lobes[0].distribution, brdf::Distribution::kGgx);
    EXPECT_TRUE(spec.model.has_diffuse);
    const std::vector<std::string> names = parameter_names(spec);
    const std::vector<std::string> expect = {"diffuse[0]",
                                             "diffuse[1]",
                                             "diffuse[2]",
                                             "lobes[0].alpha_x",
                                             "lobes[0].fresnel.f0",
                                             "lobes[0].scale[0]",
                                             "lobes[0].scale[1]",
                                             "lobes[0].scale[2]"};
    EXPECT_EQ(names, expect);
    const ParameterMap map = *ParameterMap::make(spec);
    EXPECT_EQ(map.size(), 8);  // the colour is in the scale, f0 is one number
}

TEST(Spec, TemplateSetsFreeFixedSharedAndBounds) {
    const std::string model = brdf::model_to_json(make_fit_spec(ModelOptions{})->model);
    const std::string text = "{\"model\": " + model +
                             ", \"fixed\": [\"diffuse\"], \"shared\": [\"lobes[0].fresnel.f0\"],"
                             " \"free\": [\"lobes[0].scale\"],"
                             " \"bounds\": {\"lobes[0].alpha_x\": [0.01, 0.5]}}";
    Expected<FitSpec> spec = parse_fit_template(text, "t.json");
    ASSERT_TRUE(spec) << spec.error().message;
    const ParameterMap map = *ParameterMap::make(*spec);
    std::map<std::string, ScalarParam> by_name;
    for (const ScalarParam& s : map.scalars()) {
        by_name[s.name] = s;
    }
    EXPECT_FALSE(by_name.at("diffuse[0]").free);
    EXPECT_TRUE(by_name.count("lobes[0].fresnel.f0"));  // one shared scalar
    EXPECT_TRUE(by_name.at("lobes[0].scale[1]").free);
    EXPECT_EQ(by_name.at("lobes[0].alpha_x").lower, 0.01);
    EXPECT_EQ(by_name.at("lobes[0].alpha_x").upper, 0.5);
    EXPECT_EQ(map.size(), 1 + 1 + 3);
}

TEST(Spec, TemplateErrorsNameTheKey) {
    const std::string model = brdf::model_to_json(make_fit_spec(ModelOptions{})->model);
    auto err = [&](const std::string& extra) {
        Expected<FitSpec> s = parse_fit_template("{\"model\": " + model + extra + "}", "t.json");
        return s ? std::string() : s.error().message;
    };
    EXPECT_NE(err(", \"fixed\": [\"lobes[0].fresnel.eta\"]").find("fixed[0]"), std::string::npos);
    EXPECT_NE(err(", \"bounds\": {\"lobes[0].alpha_x\": [1, 0.5]}").find("bounds.lobes[0].alpha_x"),
              std::string::npos);
    EXPECT_NE(err(", \"shared\": [\"lobes[0].alpha_x\"]").find("scalar"), std::string::npos);
    EXPECT_NE(err(", \"frozen\": []").find("frozen"), std::string::npos);
    EXPECT_FALSE(parse_fit_template("not json", "t.json"));
}

TEST(Spec, TemplateRefusesUnknownKeysAndWrongTypesNamingTheKeyPath) {
    const std::string model = brdf::model_to_json(make_fit_spec(ModelOptions{})->model);
    // The message of each refused template; "" when the reader accepted it.
    auto err = [&](const std::string& text) {
        Expected<FitSpec> s = parse_fit_template(text, "t.json");
        return s ? std::string() : s.error().message;
    };
    auto with = [&](const std::string& extra) { return err("{\"model\": " + model + extra + "}"); };
    ASSERT_EQ(with(""), "");  // the template itself is valid
    struct Case {
        std::string text;
        std::string message;  // the whole message: file, key path, rule
    };
    const std::vector<Case> cases = {
        // Unknown keys, at the top level and inside the model (the model's own schema).
        {"{\"model\": " + model + ", \"bonds\": {}}",
         "t.json: bonds: unknown key (allowed here: model, free, fixed, shared, bounds)"},
        {"{\"model\": {\"lobes\": [], \"difuse\": 0.1}}",
         "t.json: model.difuse: unknown key (allowed here: diffuse, lobes, fit)"},
        // Wrongly typed fields.
        {"{\"model\": " + model + ", \"free\": \"diffuse\"}",
         "t.json: free: expected an array of parameter paths, got string"},
        {"{\"model\": " + model + ", \"fixed\": [\"diffuse\", 3]}",
         "t.json: fixed[1]: expected a string, got number"},
        {"{\"model\": " + model + ", \"bounds\": [0, 1]}",
         "t.json: bounds: expected an object, got array"},
        {"{\"model\": " + model + ", \"bounds\": {\"lobes[0].alpha_x\": [\"0.1\", 1]}}",
         "t.json: bounds.lobes[0].alpha_x[0]: expected a number, got string"},
        {"{\"model\": " + model + ", \"bounds\": {\"lobes[0].alpha_x\": [0.1]}}",
         "t.json: bounds.lobes[0].alpha_x: expected [lower, upper], got an array of 1"},
        {"{\"model\": {\"lobes\": [{\"distribution\": \"ggx\", \"alpha\": \"0.2\"}]}}",
         "t.json: model.lobes[0].alpha: expected a number, got string"},
        {"{\"model\": []}", "t.json: model: expected an object, got array"},
        {"[]", "t.json: top level: expected an object, got array"},
        {"{\"free\": []}", "t.json: top level: missing key \"model\""},
    };
    for (const Case& c : cases) {
        EXPECT_EQ(err(c.text), c.message) << c.text;
    }
}

TEST(Spec, NamesParseAndUnknownNamesFail) {
    EXPECT_EQ(*parse_distribution("beckmann"), brdf::Distribution::kBeckmann);
    EXPECT_EQ(parse_fresnel("schlick")->second, false);
    EXPECT_EQ(parse_fresnel("schlick-rgb")->second, true);
    EXPECT_EQ(*parse_residual("cbrt"), ResidualForm::kCubeRoot);
    EXPECT_EQ(*parse_loss("cauchy"), LossKind::kCauchy);
    EXPECT_FALSE(parse_distribution("phong"));
    EXPECT_FALSE(parse_fresnel("metal"));
    EXPECT_FALSE(parse_residual("l1"));
    ModelOptions none;
    none.diffuse = false;
    none.lobes = 0;
    EXPECT_FALSE(make_fit_spec(none));
}

TEST(Report, RoundTripsThroughJsonAndRefusesModelOfUnusableFit) {
    FitSpec spec = *make_fit_spec(ModelOptions{});
    brdf::ModelD truth = spec.model;
    truth.diffuse = Rgbd(0.3, 0.2, 0.1);
    truth.lobes[0].alpha_x = truth.lobes[0].alpha_y = 0.2;
    const brdf::Dataset data = testing::synthesize(truth, testing::measurement_grid());
    FitResult r = *fit(data, spec);
    ASSERT_TRUE(r.usable());
    r.ground_truth = truth;
    const std::string dir = GONIO_BINARY_DIR;
    const std::string path = dir + "/unit_fit_report_test.json";
    ASSERT_TRUE(write_fit_report(path, r));
    EXPECT_EQ(report_path_for(path), dir + "/unit_fit_report_test.report.json");
    Expected<brdf::ModelD> model = brdf::load_model_json(path);
    ASSERT_TRUE(model) << model.error().message;
    EXPECT_EQ(model->lobes[0].alpha_x, r.model.lobes[0].alpha_x);
    Expected<FitResult> back = read_fit_report(report_path_for(path));
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->parameters.size(), r.parameters.size());
    for (std::size_t i = 0; i < r.parameters.size(); ++i) {
        EXPECT_EQ(back->parameters[i].name, r.parameters[i].name);
        EXPECT_EQ(back->parameters[i].value, r.parameters[i].value);
        EXPECT_EQ(back->parameters[i].sigma.has_value(), r.parameters[i].sigma.has_value());
    }
    EXPECT_EQ(back->metrics.log_rmse[1], r.metrics.log_rmse[1]);
    EXPECT_EQ(back->samples.valid, data.samples.size());
    EXPECT_EQ(back->solver.termination, "CONVERGENCE");
    ASSERT_TRUE(back->ground_truth);
    EXPECT_EQ(back->ground_truth->diffuse[0], 0.3);

    // A fit stopped by its iteration limit is not usable: the model file is refused.
    spec.options.max_iterations = 1;
    spec.options.starts = 1;
    FitResult stopped = *fit(data, spec);
    ASSERT_FALSE(stopped.usable());
    const std::string path2 = dir + "/unit_fit_report_stopped.json";
    std::remove(path2.c_str());
    Expected<void> w = write_fit_report(path2, stopped);
    EXPECT_FALSE(w);
    EXPECT_FALSE(std::ifstream(path2).good());
    Expected<FitResult> stopped_back = read_fit_report(report_path_for(path2));
    ASSERT_TRUE(stopped_back);
    EXPECT_FALSE(stopped_back->solver.usable);
    EXPECT_NE(format_summary(stopped).find("DID NOT CONVERGE"), std::string::npos);
    EXPECT_EQ(format_summary(stopped).find("parameters:"), std::string::npos);
}

TEST(Report, ReaderIsStrictAndReadsBackWhatTheWriterWrote) {
    FitSpec spec = *make_fit_spec(ModelOptions{});
    brdf::ModelD truth = spec.model;
    truth.diffuse = Rgbd(0.3, 0.2, 0.1);
    truth.lobes[0].alpha_x = truth.lobes[0].alpha_y = 0.25;
    FitResult r = *fit(testing::synthesize(truth, testing::measurement_grid()), spec);
    ASSERT_TRUE(r.usable());
    r.ground_truth = truth;
    r.data = "strict.csv";
    const std::string dir = GONIO_BINARY_DIR;
    const std::string path = dir + "/unit_fit_report_strict.json";
    ASSERT_TRUE(write_fit_report(path, r));
    const std::string report = report_path_for(path);
    std::ifstream in(report);
    const nlohmann::json written = nlohmann::json::parse(in);

    // Round trip: what the reader returns, written again, is the file it read, key for key.
    Expected<FitResult> back = read_fit_report(report);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(nlohmann::json::parse(fit_report_json(*back)), written);

    auto read_edited = [&](auto edit) {
        nlohmann::json j = written;
        edit(j);
        const std::string p = dir + "/unit_fit_report_strict_edited.report.json";
        std::ofstream(p) << j.dump(2);
        Expected<FitResult> res = read_fit_report(p);
        return res ? std::string() : res.error().message;
    };
    // An unknown key, at the top and deep inside, is refused with its key path and the keys
    // allowed there.
    const std::string top = read_edited([](nlohmann::json& j) { j["paramters"] = 1; });
    EXPECT_NE(top.find("unit_fit_report_strict_edited.report.json: paramters: unknown key (allowed "
                       "here: model, parameters,"),
              std::string::npos)
        << top;
    const std::string stage =
        read_edited([](nlohmann::json& j) { j["solver"]["stages"][0]["tme_s"] = 0.1; });
    EXPECT_NE(stage.find("solver.stages[0].tme_s: unknown key (allowed here: name, samples, "
                         "iterations, termination, time_s, final_cost)"),
              std::string::npos)
        << stage;
    const std::string lobe =
        read_edited([](nlohmann::json& j) { j["model"]["lobes"][0]["alhpa"] = 0.1; });
    EXPECT_NE(lobe.find("model.lobes[0].alhpa: unknown key"), std::string::npos) << lobe;
    // Wrong types and values name the key path.
    const std::string count =
        read_edited([](nlohmann::json& j) { j["samples"]["valid"] = "1118"; });
    EXPECT_NE(count.find("samples.valid: expected a whole number, got string"), std::string::npos)
        << count;
    const std::string bound =
        read_edited([](nlohmann::json& j) { j["parameters"][1]["at_bound"] = "middle"; });
    EXPECT_NE(bound.find("parameters[1].at_bound = \"middle\": must be"), std::string::npos)
        << bound;
    const std::string rgb = read_edited([](nlohmann::json& j) {
        j["metrics"]["log_rmse"] = {0.1, 0.2};
    });
    EXPECT_NE(rgb.find("metrics.log_rmse: expected [r, g, b]"), std::string::npos) << rgb;
    const std::string missing = read_edited([](nlohmann::json& j) { j.erase("solver"); });
    EXPECT_NE(missing.find("top level: missing key \"solver\""), std::string::npos) << missing;
}

TEST(Metrics, MatchTheirDefinitions) {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = Rgbd::Constant(brdf::kPi);  // f = 1 everywhere
    std::vector<Sample> s = {sample(0.0, 0, 0.5, 1, Rgbd(1.0, 2.0, 0.0)),
                             sample(brdf::kPi / 3, 0, 0.5, 1, Rgbd(1.0, 0.0, 3.0))};
    const Metrics met = evaluate_metrics(m, s, 1e-3);
    EXPECT_NEAR(met.rmse[0], 0.0, 1e-15);
    EXPECT_NEAR(met.rmse[1], std::sqrt((1.0 + 1.0) / 2), 1e-12);
    EXPECT_NEAR(met.rmse[2], std::sqrt((1.0 + 4.0) / 2), 1e-12);
    EXPECT_NEAR(met.rel_rmse[1], std::sqrt((1 / (2.001 * 2.001) + 1 / 1e-6) / 2), 1e-9);
    // log: cos_i = 1 and 0.5.
    const double l0 = std::log(2.0) - std::log(1.0);
    const double l1 = std::log(1.5) - std::log(2.5);
    EXPECT_NEAR(met.log_rmse[2], std::sqrt((l0 * l0 + l1 * l1) / 2), 1e-12);
}

}  // namespace
}  // namespace gonio::fitting
