// The default fit (GGX + Lambert + Schlick RGB, log residual) on simulated campaigns of real
// materials: published Lambert + Beckmann fits of MERL measurements (data/materials/ngan2005.json),
// sampled on the coarse uniform grids an acquisition plans (theta_i <= theta_r on n_theta values
// over [0, 80] degrees, delta_phi on n_dphi values over [0, 180] degrees), with 3 % multiplicative
// Gaussian noise. The fitted model differs from the data's (GGX against Beckmann, Schlick without
// a free scale), so the checks are against the data and the truth, not against exact parameters:
// the fit converges, keeps its lobe, describes the data nearly as well as the truth itself does
// (log RMSE), reproduces the measured specular peak, and puts alpha within a factor of the truth.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "fit_test_util.h"
#include "gonio/brdf/material_library.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"

namespace gonio::fitting {
namespace {

using testing::deg;

/// The uniform acquisition grid: (theta_i, theta_r) on n_theta values over [0, 80] degrees with
/// theta_i <= theta_r, delta_phi on n_dphi values over [0, 180] degrees (only 0 at theta_i = 0).
std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> uniform_grid(int n_theta, int n_dphi) {
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs;
    for (int a = 0; a < n_theta; ++a) {
        for (int b = a; b < n_theta; ++b) {
            const double ti = deg(80.0 * a / (n_theta - 1));
            const double to = deg(80.0 * b / (n_theta - 1));
            for (int k = 0; k < n_dphi; ++k) {
                if (a == 0 && k > 0) {
                    break;
                }
                const double dphi = deg(180.0 * k / (n_dphi - 1));
                dirs.emplace_back(brdf::spherical_to_cartesian(ti, 0.0),
                                  brdf::spherical_to_cartesian(to, dphi));
            }
        }
    }
    return dirs;
}

double log_rmse(const brdf::ModelD& m, const brdf::Dataset& d) {
    return evaluate_metrics(m, d.samples, 1e-3).log_rmse.mean();
}

struct Case {
    const char* material;
    int n_theta, n_dphi;
    double alpha_factor;  ///< allowed ratio between fitted and true alpha (either way)
    bool peak_resolved;   ///< the grid samples the lobe's width, not only its mirror point
};

class DefaultFitOnCampaign : public ::testing::TestWithParam<Case> {};

TEST_P(DefaultFitOnCampaign, RecoversTheSpecularPeakRegion) {
    const Case c = GetParam();
    const std::uint64_t seed = 7;
    SCOPED_TRACE(std::string(c.material) + ", noise seed " + std::to_string(seed));
    Expected<brdf::ModelD> truth = brdf::load_material(
        c.material, std::string(GONIO_SOURCE_DIR) + "/data/materials/ngan2005.json");
    ASSERT_TRUE(truth) << truth.error().message;
    ASSERT_EQ(truth->lobes.size(), 1u);
    const brdf::Dataset data = testing::with_noise(
        testing::synthesize(*truth, uniform_grid(c.n_theta, c.n_dphi)), seed, {0.03});

    Expected<FitSpec> spec = make_fit_spec({});
    ASSERT_TRUE(spec) << spec.error().message;
    Expected<FitResult> r = fit(data, *spec);
    ASSERT_TRUE(r) << r.error().message;
    // Converged; the verdict may call a cross-family fit a misfit (the default GGX leaves red
    // plastic's dark blue channel 10-15 % off at the median, which the per-channel relative error
    // sees), but the specular region is still where the default fit must be close.
    ASSERT_TRUE(r->solver.converged) << r->solver.message;
    ASSERT_EQ(r->model.lobes.size(), 1u);
    EXPECT_TRUE(r->vanished_lobes.empty());

    // Over the specular region (theta_h below 25 degrees, both directions up to 60 degrees):
    // nearly as close to the data as the truth (whose misfit is the noise alone), with room for
    // the difference of the models.
    brdf::Dataset region;
    for (const brdf::Sample& s : data.samples) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
        if (hd.theta_h < deg(25) && s.theta_i <= deg(61) && s.theta_o <= deg(61)) {
            region.samples.push_back(s);
        }
    }
    const double noise = log_rmse(*truth, region);
    const double fitted = log_rmse(r->model, region);
    if (c.peak_resolved) {
        EXPECT_LT(fitted, 2 * noise + 0.01) << "noise floor " << noise;
    } else {
        // Only the exact mirror samples see the peak: the region is mostly the lobe's flank,
        // where GGX and Beckmann tails of different widths differ by tens of percent.
        EXPECT_LT(fitted, 0.1) << "noise floor " << noise;
    }

    // The measured specular peak: at the samples nearest the mirror direction (theta_h below
    // 2 degrees, incidence up to 60 degrees) the fitted model is within 25 % of the truth.
    int peak_samples = 0;
    for (const brdf::Sample& s : data.samples) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
        if (hd.theta_h > deg(2) || s.theta_i > deg(61)) {
            continue;
        }
        ++peak_samples;
        const double want = brdf::eval_model(*truth, s.wi(), s.wo()).mean();
        const double got = brdf::eval_model(r->model, s.wi(), s.wo()).mean();
        EXPECT_NEAR(got / want, 1.0, 0.25)
            << "theta_i " << s.theta_i << " theta_o " << s.theta_o << " theta_h " << hd.theta_h;
    }
    EXPECT_GE(peak_samples, 2);

    // Alpha of a GGX lobe against the Beckmann truth: within the allowed factor, and never on the
    // upper bound (the lobe did not turn into a second diffuse term).
    const double alpha = r->model.lobes[0].alpha_x;
    const double alpha_true = truth->lobes[0].alpha_x;
    EXPECT_GT(alpha, alpha_true / c.alpha_factor);
    EXPECT_LT(alpha, alpha_true * c.alpha_factor);
    for (const FittedParameter& p : r->parameters) {
        if (p.name == "lobes[0].alpha_x") {
            EXPECT_NE(p.at_bound, "upper");
        }
    }
}

// gold-metallic-paint2 (alpha 0.0214) on the 5 x 5 grid of `gonio acquire --n-theta 5 --n-dphi
// 5`: the peak is narrower than the grid, only the exact mirror samples see it, so alpha is bounded
// by the peak height with f0 <= 1 (a factor of about 4) rather than resolved. gold-paint (alpha
// 0.214) and red-plastic (0.262) are resolved by a 7 x 7 grid; the default model's Schlick term
// with the scale held at 1 reaches 1 at grazing where these lobes' (scale 0.07 to 0.25) stay
// low, which costs gold-paint some width (factor 2).
INSTANTIATE_TEST_SUITE_P(NganMaterials,
                         DefaultFitOnCampaign,
                         ::testing::Values(Case{"gold-metallic-paint2", 5, 5, 4.0, false},
                                           Case{"gold-paint", 7, 7, 2.0, true},
                                           Case{"red-plastic", 7, 7, 1.5, true}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                             std::string name = info.param.material;
                             for (char& ch : name) {
                                 if (ch == '-') {
                                     ch = '_';
                                 }
                             }
                             return name;
                         });

}  // namespace
}  // namespace gonio::fitting
