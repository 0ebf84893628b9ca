// Fits of samples measured while the arms moved (fly scans): each value is the mean of the truth
// over its exposure's path; the fit that models the path recovers the roughness within its sigma,
// a fit that takes each value at its mid-exposure directions does not.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fit_test_util.h"
#include "gonio/brdf/exposure_path.h"
#include "gonio/fitting/exposure_paths.h"
#include "gonio/fitting/fit.h"

namespace gonio::fitting {
namespace {

using testing::deg;

constexpr double kAlpha = 0.05;
constexpr double kNoise = 0.005;  // relative one-sigma noise of each value

brdf::ModelD ggx_truth(const FitSpec& spec) {
    brdf::ModelD m = spec.model;
    m.diffuse = brdf::Rgbd(0.05, 0.08, 0.12);
    m.lobes[0].alpha_x = m.lobes[0].alpha_y = kAlpha;
    m.lobes[0].fresnel.f0 = brdf::Rgbd::Constant(0.04);
    m.lobes[0].scale = brdf::Rgbd::Constant(1.0);
    return m;
}

/// The mean of f cos(theta_i) over an in-plane detector sweep from theta_o = a to b (phi_o = pi,
/// the plane of incidence, phi_i = 0) divided by cos(theta_i): the midpoint rule on 4000 steps
/// of the polar angle, which the great circle of the plane of incidence runs through uniformly.
brdf::Rgbd sweep_mean(const brdf::ModelD& truth, double theta_i, double a, double b) {
    constexpr int kSteps = 4000;
    const brdf::Vec3d wi = brdf::spherical_to_cartesian(theta_i, 0.0);
    brdf::Rgbd sum = brdf::Rgbd::Zero();
    for (int k = 0; k < kSteps; ++k) {
        const double t = a + (b - a) * (k + 0.5) / kSteps;
        sum += brdf::eval_model(truth, wi, brdf::spherical_to_cartesian(t, brdf::kPi));
    }
    return sum / kSteps;  // cos(theta_i) is constant along the sweep
}

/// Fly sweeps of the detector in the plane of incidence at six incidences, each frame's
/// exposure spanning 4 alpha (0.2 rad) of detector travel, frames back to back between 1 and 84 deg;
/// seeded Gaussian noise (seed 7) of kNoise relative, stated as the sigma.
brdf::Dataset swept_data(const brdf::ModelD& truth) {
    brdf::Dataset d;
    d.source = "fly sweeps";
    d.has_sigma = d.has_path = true;
    std::mt19937_64 rng(7);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double span = 4 * kAlpha;
    for (double ti_deg : {15.0, 25.0, 35.0, 45.0, 55.0, 65.0}) {
        const double ti = deg(ti_deg);
        // The frames are placed so that one is centred on the mirror direction and its
        // neighbours straddle the peak.
        const double first = ti - span / 2 - span * std::floor((ti - span / 2 - deg(1)) / span);
        for (double a = first; a + span < deg(84); a += span) {
            brdf::Sample s;
            s.theta_i = ti;
            s.phi_i = 0;
            s.theta_o = a + span / 2;
            s.phi_o = brdf::kPi;
            s.has_path = true;
            s.path_start = {ti, 0, a, brdf::kPi};
            s.path_end = {ti, 0, a + span, brdf::kPi};
            const brdf::Rgbd v = sweep_mean(truth, ti, a, a + span);
            for (int c = 0; c < 3; ++c) {
                s.value[c] = v[c] * (1 + kNoise * gauss(rng));
                s.sigma[c] = kNoise * v[c];
            }
            d.samples.push_back(s);
        }
    }
    return d;
}

const FittedParameter& alpha_of(const FitResult& r) {
    for (const FittedParameter& p : r.parameters) {
        if (p.name == "lobes[0].alpha_x") {
            return p;
        }
    }
    static FittedParameter none;
    ADD_FAILURE() << "no lobes[0].alpha_x in the fit";
    return none;
}

TEST(ExposurePathFit, ModelMeanMatchesTheIndependentIntegral) {
    const FitSpec spec = *make_fit_spec(ModelOptions{});
    const brdf::ModelD truth = ggx_truth(spec);
    // A frame centred on the mirror direction at 35 deg: the fit's quadrature (1 deg pieces, 4
    // nodes) against the 4000-step midpoint rule.
    brdf::Sample s;
    const double ti = deg(35);
    s.theta_i = ti;
    s.theta_o = ti;
    s.phi_o = brdf::kPi;
    s.has_path = true;
    s.path_start = {ti, 0, ti - 2 * kAlpha, brdf::kPi};
    s.path_end = {ti, 0, ti + 2 * kAlpha, brdf::kPi};
    const brdf::Rgbd model = sample_model_value(truth, s);
    const brdf::Rgbd reference = sweep_mean(truth, ti, ti - 2 * kAlpha, ti + 2 * kAlpha);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(model[c] / reference[c], 1, 1e-6) << c;
    }
    // The smear: the peak value is several times the exposure's mean.
    const brdf::Rgbd peak = brdf::eval_model(truth, s.wi(), s.wo());
    EXPECT_GT(peak[0] / model[0], 1.4);
}

TEST(ExposurePathFit, RecoversAlphaOfSmearedDataWhereThePointFitCannot) {
    const FitSpec spec = *make_fit_spec(ModelOptions{});
    const brdf::ModelD truth = ggx_truth(spec);
    const brdf::Dataset swept = swept_data(truth);
    ASSERT_GT(swept.samples.size(), 30u);
    Expected<FitResult> r = fit(swept, spec);
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->usable()) << r->solver.message;
    const FittedParameter& a = alpha_of(*r);
    ASSERT_TRUE(a.sigma.has_value());
    std::printf("path fit: alpha %.6g +- %.3g (truth %.6g)\n", a.value, *a.sigma, kAlpha);
    EXPECT_LE(std::abs(a.value - kAlpha), 2 * *a.sigma);
    EXPECT_LT(*a.sigma, 0.02 * kAlpha);
    // The same values taken as measured at their mid-exposure directions: the smear widens the
    // peak, the fit's alpha comes out far outside its own sigma.
    brdf::Dataset point = swept;
    point.has_path = false;
    for (brdf::Sample& s : point.samples) {
        s.has_path = false;
    }
    Expected<FitResult> p = fit(point, spec);
    ASSERT_TRUE(p) << p.error().message;
    const FittedParameter& b = alpha_of(*p);
    ASSERT_TRUE(b.sigma.has_value());
    std::printf("point fit: alpha %.6g +- %.3g (truth %.6g)\n", b.value, *b.sigma, kAlpha);
    EXPECT_GT(std::abs(b.value - kAlpha), 10 * *b.sigma);
}

}  // namespace
}  // namespace gonio::fitting
