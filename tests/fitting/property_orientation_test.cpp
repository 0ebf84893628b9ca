// Fits of anisotropic lobes with an orientation (Lobe::orientation_deg, parameter
// lobes[i].orientation_deg): the Jacobian against central differences, recovery of a brushed
// truth turned by 0 and 30 degrees from noisy samples in full directions within the sigmas the
// fit reports, the canonical form of the result (alpha_x <= alpha_y, orientation in [0, 180)),
// and an isotropic truth fitted anisotropically.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "fit_test_util.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/fit.h"

namespace gonio::fitting {
namespace {

using brdf::Rgbd;
using brdf::Sample;
using testing::deg;

brdf::ModelD brushed(double ax, double ay, double phi_deg) {
    brdf::ModelD m;
    m.diffuse = Rgbd(0.05, 0.05, 0.06);
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kGgx;
    l.anisotropic = true;
    l.alpha_x = ax;
    l.alpha_y = ay;
    l.orientation_deg = phi_deg;
    l.fresnel.type = brdf::FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd::Constant(0.9);
    l.scale = Rgbd(0.95, 0.9, 0.85);
    m.lobes.push_back(l);
    return m;
}

/// Samples over the whole (theta_i, phi_i, theta_o, phi_o) domain: incidence 15..70 degrees at
/// 12 azimuths, the detector on a 10 x 15 degree hemisphere grid, with seeded multiplicative
/// Gaussian noise of relative size `noise` on each channel (seed recorded here: 42).
brdf::Dataset full_direction_samples(const brdf::ModelD& truth, double noise) {
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs;
    for (double ti : {15.0, 35.0, 55.0, 70.0}) {
        for (double pi = 0; pi < 360; pi += 30) {
            for (double to = 5; to < 85; to += 10) {
                for (double po = 0; po < 360; po += 15) {
                    dirs.emplace_back(brdf::spherical_to_cartesian(deg(ti), deg(pi)),
                                      brdf::spherical_to_cartesian(deg(to), deg(po)));
                }
            }
        }
    }
    brdf::Dataset d = testing::synthesize(truth, dirs);
    std::mt19937_64 rng(42);
    std::normal_distribution<double> n(0, 1);
    for (Sample& s : d.samples) {
        for (int c = 0; c < 3; ++c) {
            s.value[c] *= 1 + noise * n(rng);
        }
    }
    return d;
}

struct Fitted {
    double value = 0;
    double sigma = 0;
};

Fitted param(const FitResult& r, const std::string& name) {
    for (const FittedParameter& p : r.parameters) {
        if (p.name == name) {
            return {p.value, p.sigma ? *p.sigma : -1};
        }
    }
    ADD_FAILURE() << "no parameter " << name;
    return {};
}

FitSpec anisotropic_spec() {
    ModelOptions mo;
    mo.anisotropic = true;
    FitSpec spec = *make_fit_spec(mo);
    spec.options.num_threads = 2;
    return spec;
}

// The Jets of the orientation against Ridders' central differences (ceres::GradientChecker), for
// GGX, Beckmann and Student-t, both Smith forms, at ordinary and edge directions.
TEST(Orientation, GradientCheckerPassesForTheOrientation) {
    const std::vector<Sample> samples = [] {
        std::vector<Sample> v;
        const double dirs[][4] = {{30, 0, 40, 170},
                                  {0, 0, 20, 90},
                                  {45, 17, 45, 197},
                                  {88, 10, 87, 185},
                                  {60, 57, 60, 57},
                                  {50, 120, 35, 280}};
        for (const auto& a : dirs) {
            Sample s;
            s.theta_i = deg(a[0]);
            s.phi_i = deg(a[1]);
            s.theta_o = deg(a[2]);
            s.phi_o = deg(a[3]);
            s.value = Rgbd(0.3, 0.4, 0.5);
            v.push_back(s);
        }
        return v;
    }();
    for (brdf::Distribution d :
         {brdf::Distribution::kGgx, brdf::Distribution::kBeckmann, brdf::Distribution::kStudentT}) {
        for (brdf::Shadowing sh :
             {brdf::Shadowing::kSmithCorrelated, brdf::Shadowing::kSmithSeparable}) {
            ModelOptions mo;
            mo.anisotropic = true;
            mo.distribution = d;
            mo.shadowing = sh;
            FitSpec spec = *make_fit_spec(mo);
            spec.model.lobes[0].alpha_x = 0.15;
            spec.model.lobes[0].alpha_y = 0.4;
            spec.model.lobes[0].gamma = 3;
            spec.model.lobes[0].orientation_deg = 33;
            auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
            const std::vector<double> x = map->values_of(spec.model);
            int k_phi = -1;
            for (int k = 0; k < map->size(); ++k) {
                if (map->scalars()[map->free()[k]].field == Field::kOrientation) {
                    k_phi = k;
                }
            }
            ASSERT_GE(k_phi, 0);
            EXPECT_NEAR(x[k_phi], 33, 1e-12);  // the scalar is in degrees
            for (ResidualForm form : {ResidualForm::kAbsolute, ResidualForm::kLog}) {
                for (const Sample& s : samples) {
                    SCOPED_TRACE(std::string(brdf::to_string(d)) + ", " + brdf::to_string(sh) +
                                 ", " + to_string(form) + ", theta_i " + std::to_string(s.theta_i));
                    CostOptions co;
                    co.residual = form;
                    auto cost = make_batch_cost(map, {s}, co);
                    ceres::NumericDiffOptions nd;
                    nd.ridders_relative_initial_step_size = 1e-6;
                    const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
                    ceres::GradientChecker checker(cost.get(), no_manifolds, nd);
                    ceres::GradientChecker::ProbeResults results;
                    const double* p[] = {x.data()};
                    checker.Probe(p, 1e-4, &results);
                    for (int k = 0; k < map->size(); ++k) {
                        for (int c = 0; c < 3; ++c) {
                            const double j = results.jacobians[0](c, k);
                            const double jn = results.numeric_jacobians[0](c, k);
                            ASSERT_TRUE(std::isfinite(j));
                            EXPECT_LE(std::abs(j - jn), 1e-4 * std::abs(jn) + 1e-10)
                                << "residual " << c << " parameter "
                                << map->scalars()[map->free()[k]].name << ": " << j << " vs " << jn;
                        }
                    }
                }
            }
        }
    }
}

// The prepared samples' turned geometry (squares and cross products) against eval_model.
TEST(Orientation, PreparedSamplesAgreeWithTheModelEvaluation) {
    const brdf::ModelD truth = brushed(0.08, 0.3, 30);
    const brdf::Dataset d = full_direction_samples(truth, 0);
    FitSpec spec = anisotropic_spec();
    spec.model = truth;
    auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
    std::vector<double> x = map->values_of(truth);
    auto cost = make_batch_cost(map, d.samples, CostOptions{ResidualForm::kAbsolute, 1e-3, false});
    std::vector<double> r(3 * d.samples.size());
    const double* p[] = {x.data()};
    ASSERT_TRUE(cost->Evaluate(p, r.data(), nullptr));
    // Exact data: every absolute residual is rounding only.
    double worst = 0;
    for (std::size_t i = 0; i < r.size(); ++i) {
        worst = std::max(worst, std::abs(r[i]) / std::max(1.0, d.samples[i / 3].value[i % 3]));
    }
    EXPECT_LT(worst, 1e-12);
}

void expect_recovered(double ax, double ay, double phi_deg) {
    const brdf::ModelD truth = brushed(ax, ay, phi_deg);
    const brdf::Dataset d = full_direction_samples(truth, 0.03);
    const Expected<FitResult> r = fit(d, anisotropic_spec());
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->solver.converged) << r->solver.message;
    const Fitted fx = param(*r, "lobes[0].alpha_x");
    const Fitted fy = param(*r, "lobes[0].alpha_y");
    const Fitted fo = param(*r, "lobes[0].orientation_deg");
    // The canonical form: alpha_x <= alpha_y and the orientation in [0, 180).
    EXPECT_LE(fx.value, fy.value);
    EXPECT_GE(fo.value, 0);
    EXPECT_LT(fo.value, 180);
    ASSERT_GT(fx.sigma, 0);
    ASSERT_GT(fy.sigma, 0);
    ASSERT_GT(fo.sigma, 0);
    // Within four of the reported sigmas, and the sigmas small enough to mean something.
    EXPECT_NEAR(fx.value, ax, 4 * fx.sigma) << "sigma " << fx.sigma;
    EXPECT_NEAR(fy.value, ay, 4 * fy.sigma) << "sigma " << fy.sigma;
    double dphi = fo.value - phi_deg;
    dphi -= 180 * std::round(dphi / 180);
    EXPECT_LT(std::abs(dphi), 4 * fo.sigma) << fo.value << " +- " << fo.sigma;
    // And within a fixed bound of the truth whatever the sigmas: 3 % of a width, 1 degree.
    EXPECT_LE(std::abs(fx.value - ax), 0.03 * ax) << fx.value;
    EXPECT_LE(std::abs(fy.value - ay), 0.03 * ay) << fy.value;
    EXPECT_LE(std::abs(dphi), 1.0) << fo.value;
    EXPECT_LT(fx.sigma, 0.05 * ax);
    EXPECT_LT(fy.sigma, 0.05 * ay);
    EXPECT_LT(fo.sigma, 2.0);
    // The model file carries the orientation in degrees.
    EXPECT_EQ(r->model.lobes[0].orientation_deg, fo.value);
}

TEST(Orientation, RecoversBrushedLobeAlignedWithTheSample) {
    expect_recovered(0.08, 0.3, 0);
}

TEST(Orientation, RecoversBrushedLobeTurnedBy30Degrees) {
    expect_recovered(0.08, 0.3, 30);
}

// A truth written with its slopes exchanged and turned by a further quarter turn is the same lobe:
// the fit reports it in the canonical form (alpha_x <= alpha_y, orientation in [0, 180)).
TEST(Orientation, ReportsTheCanonicalFormOfAnEquivalentTruth) {
    const brdf::Dataset d = full_direction_samples(brushed(0.3, 0.08, 120 + 180), 0.03);
    const Expected<FitResult> r = fit(d, anisotropic_spec());
    ASSERT_TRUE(r) << r.error().message;
    const Fitted fx = param(*r, "lobes[0].alpha_x");
    const Fitted fy = param(*r, "lobes[0].alpha_y");
    const Fitted fo = param(*r, "lobes[0].orientation_deg");
    EXPECT_NEAR(fx.value, 0.08, std::min(4 * fx.sigma, 0.03 * 0.08));
    EXPECT_NEAR(fy.value, 0.3, std::min(4 * fy.sigma, 0.03 * 0.3));
    EXPECT_NEAR(fo.value, 30, std::min(4 * fo.sigma, 1.0));
}

// An isotropic truth fitted with an anisotropic lobe: alpha_x = alpha_y within the sigma of their
// difference (the orientation then means nothing and may take any value).
TEST(Orientation, IsotropicTruthFitsEqualSlopes) {
    const brdf::Dataset d = full_direction_samples(brushed(0.15, 0.15, 0), 0.03);
    const Expected<FitResult> r = fit(d, anisotropic_spec());
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->solver.converged) << r->solver.message;
    const Fitted fx = param(*r, "lobes[0].alpha_x");
    const Fitted fy = param(*r, "lobes[0].alpha_y");
    ASSERT_GT(fx.sigma, 0);
    ASSERT_GT(fy.sigma, 0);
    EXPECT_LT(std::abs(fx.value - fy.value), 4 * std::hypot(fx.sigma, fy.sigma))
        << fx.value << " +- " << fx.sigma << " vs " << fy.value << " +- " << fy.sigma;
    EXPECT_NEAR(fx.value, 0.15, 4 * fx.sigma);
    EXPECT_LT(fx.sigma, 0.01);
}

}  // namespace
}  // namespace gonio::fitting
