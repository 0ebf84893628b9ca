// Thread-count independence: every pass sums per block of samples and adds the block sums in
// block order (fitting/prepared_samples.h parallel_blocks), so one and two threads give the same
// normal equations to the last bit and the same fitted parameters.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fit_test_util.h"
#include "gonio/base/instruction_set.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/prepared_samples.h"

namespace gonio::fitting {
namespace {

/// `n` samples of a Beckmann + Lambert material (another family than the default GGX model) at
/// seeded random directions above the horizon, with 1 % multiplicative noise (seed 7).
brdf::Dataset cross_family_data(std::size_t n) {
    brdf::ModelD truth;
    truth.has_diffuse = true;
    truth.diffuse = brdf::Rgbd(0.3, 0.15, 0.05);
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kBeckmann;
    l.alpha_x = l.alpha_y = 0.12;
    l.fresnel.type = brdf::FresnelType::kSchlick;
    l.fresnel.f0 = brdf::Rgbd::Constant(0.05);
    truth.lobes = {l};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> noise(0, 0.01);
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs;
    for (std::size_t k = 0; k < n; ++k) {
        const double ti = std::acos(0.05 + 0.95 * u(rng));
        const double to = std::acos(0.05 + 0.95 * u(rng));
        dirs.emplace_back(brdf::spherical_to_cartesian(ti, 2 * brdf::kPi * u(rng)),
                          brdf::spherical_to_cartesian(to, 2 * brdf::kPi * u(rng)));
    }
    brdf::Dataset d = testing::synthesize(truth, dirs);
    for (brdf::Sample& s : d.samples) {
        s.value *= 1 + noise(rng);
    }
    return d;
}

FitResult fit_with_threads(const brdf::Dataset& data, int threads, std::size_t coarse) {
    FitSpec spec = *make_fit_spec(ModelOptions{});
    spec.options.num_threads = threads;
    spec.options.coarse_samples = coarse;
    Expected<FitResult> r = fit(data, spec);
    EXPECT_TRUE(r.has_value());
    return *r;
}

void expect_same_fit(const FitResult& a, const FitResult& b) {
    ASSERT_EQ(a.parameters.size(), b.parameters.size());
    EXPECT_EQ(a.solver.iterations, b.solver.iterations);
    for (std::size_t k = 0; k < a.parameters.size(); ++k) {
        const FittedParameter& p = a.parameters[k];
        const FittedParameter& q = b.parameters[k];
        EXPECT_NEAR(p.value, q.value, 1e-12 * std::max(1.0, std::abs(p.value))) << p.name;
        ASSERT_EQ(p.sigma.has_value(), q.sigma.has_value()) << p.name;
        if (p.sigma) {
            EXPECT_NEAR(*p.sigma, *q.sigma, 1e-12 * std::max(1.0, *p.sigma)) << p.name;
        }
    }
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(a.metrics.log_rmse[c], b.metrics.log_rmse[c], 1e-15);
    }
}

TEST(ThreadCount, NormalEquationsOfOneAndTwoThreadsAreBitIdentical) {
    const brdf::Dataset data = cross_family_data(50000);
    const FitSpec spec = *make_fit_spec(ModelOptions{});
    auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
    for (bool analytic : {true, false}) {
        PreparedSamples ps(map, data.samples, CostOptions{});
        ps.set_analytic(analytic);
        // The closed form of the default model runs fused on packets (normal_equation_packets.h).
        EXPECT_EQ(ps.packets(), analytic && packet_isa() != Isa::kScalar);
        const std::vector<double> x = map->values_of(spec.model);
        NormalEquations one, two;
        ASSERT_TRUE(ps.normal_equations(x.data(), one, 1));
        ASSERT_TRUE(ps.normal_equations(x.data(), two, 2));
        EXPECT_EQ(one.cost_sum, two.cost_sum) << "analytic " << analytic;
        EXPECT_EQ((one.jtj - two.jtj).cwiseAbs().maxCoeff(), 0.0) << "analytic " << analytic;
        EXPECT_EQ((one.jtr - two.jtr).cwiseAbs().maxCoeff(), 0.0) << "analytic " << analytic;
        double s1 = 0, s2 = 0;
        ASSERT_TRUE(ps.sum_of_squares(x.data(), &s1, 1));
        ASSERT_TRUE(ps.sum_of_squares(x.data(), &s2, 2));
        EXPECT_EQ(s1, s2);
        // The sum of squares of the normal-equation pass is the same quantity.
        EXPECT_NEAR(one.cost_sum, s1, 1e-12 * s1);
    }
}

TEST(ThreadCount, OneAndTwoThreadsFitTheSameParametersTo1e12) {
    // 30 000 samples: the starts and the solve on all of them, every pass split over threads.
    const brdf::Dataset data = cross_family_data(30000);
    expect_same_fit(fit_with_threads(data, 1, 20000), fit_with_threads(data, 2, 20000));
}

TEST(ThreadCount, OneAndTwoThreadsAgreeThroughTheReductionAndThePolish) {
    // Coarse to fine: the solve on a reduction of 8 000, then the polish on all 40 000.
    const brdf::Dataset data = cross_family_data(40000);
    const FitResult one = fit_with_threads(data, 1, 8000);
    const FitResult two = fit_with_threads(data, 2, 8000);
    ASSERT_GE(one.solver.stages.size(), 2u);
    EXPECT_EQ(one.solver.stages.back().name, "polish");
    expect_same_fit(one, two);
}

}  // namespace
}  // namespace gonio::fitting
