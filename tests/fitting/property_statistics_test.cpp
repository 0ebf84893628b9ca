// Honest statistics over seeds: uncertainties that cover the truth under 2 % multiplicative noise
// (sandwich covariance without sigma columns, relative sigmas reweighted at the model with them),
// automatic model choice by BIC, and goodness of fit that refuses a model that cannot represent
// the data.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "fit_test_util.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"

namespace gonio::fitting {
namespace {

using brdf::Distribution;
using brdf::Rgbd;

/// A truth of the default structure (GGX + Lambert + scalar Schlick + RGB scale).
brdf::ModelD default_truth(Distribution d, double alpha, Rgbd diffuse, Rgbd scale, double f0) {
    ModelOptions mo;
    mo.distribution = d;
    brdf::ModelD m = make_fit_spec(mo)->model;
    m.diffuse = diffuse;
    m.lobes[0].alpha_x = m.lobes[0].alpha_y = alpha;
    m.lobes[0].exponent = 2 / (alpha * alpha) - 2;
    m.lobes[0].scale = scale;
    m.lobes[0].fresnel.f0 = Rgbd::Constant(f0);
    return m;
}

/// Multiplicative Gaussian noise of 2 %, seeded; with sigma columns stated as 2 % of the measured
/// value when `with_sigma` (what a user who knows the relative noise writes).
brdf::Dataset noisy(const brdf::ModelD& truth, std::uint64_t seed, bool with_sigma) {
    testing::Noise noise;
    noise.sigma = with_sigma ? testing::StatedSigma::kOfMeasured : testing::StatedSigma::kNone;
    return testing::noisy_measurement(truth, seed, noise);
}

struct Coverage {
    int inside = 0;    ///< within 3 sigma
    int inside_1 = 0;  ///< within 1 sigma
    int total = 0;
};

/// Upper bound on the fraction of parameters within one sigma of the truth (0.68 expected): the
/// sigmas are not inflated.
constexpr double kMaxWithinOneSigma = 0.85;

Coverage coverage(bool with_sigma) {
    const brdf::ModelD truths[] = {
        default_truth(Distribution::kGgx, 0.08, Rgbd(0.3, 0.2, 0.1), Rgbd(0.9, 0.8, 0.7), 0.05),
        default_truth(Distribution::kGgx, 0.2, Rgbd(0.05, 0.1, 0.4), Rgbd(1.2, 1.0, 0.8), 0.1),
        default_truth(Distribution::kGgx, 0.35, Rgbd(0.5, 0.5, 0.2), Rgbd(0.6, 0.6, 0.6), 0.04),
    };
    const FitSpec spec = *make_fit_spec(ModelOptions{});
    const ParameterMap map = *ParameterMap::make(spec);
    Coverage cov;
    int material = 0;
    for (const brdf::ModelD& truth : truths) {
        ++material;
        for (std::uint64_t seed = 1; seed <= 5; ++seed) {
            Expected<FitResult> r = fit(noisy(truth, 100 * material + seed, with_sigma), spec);
            EXPECT_TRUE(r) << r.error().message;
            if (!r) {
                continue;
            }
            EXPECT_TRUE(r->solver.converged) << "material " << material << " seed " << seed;
            EXPECT_NE(r->covariance_method.find(with_sigma ? "IRLS" : "sandwich"),
                      std::string::npos)
                << r->covariance_method;
            for (const FittedParameter& p : r->parameters) {
                if (!p.free || !p.at_bound.empty()) {
                    continue;
                }
                double expect = 0;
                for (const ScalarParam& s : map.scalars()) {
                    if (s.name == p.name) {
                        expect = map.value_of(truth, s);
                    }
                }
                ++cov.total;
                if (p.sigma && std::abs(p.value - expect) <= *p.sigma) {
                    ++cov.inside_1;
                }
                if (p.sigma && std::abs(p.value - expect) <= 3 * *p.sigma) {
                    ++cov.inside;
                } else {
                    std::printf("material %d seed %llu: %s = %.6g, truth %.6g, sigma %.3g\n",
                                material,
                                static_cast<unsigned long long>(seed),
                                p.name.c_str(),
                                p.value,
                                expect,
                                p.sigma ? *p.sigma : -1.0);
                }
            }
        }
    }
    return cov;
}

TEST(FitStatistics, SandwichSigmasCoverUnderMultiplicativeNoiseWithoutSigmaColumns) {
    const Coverage c = coverage(false);
    ASSERT_GE(c.total, 100);
    EXPECT_GE(c.inside, 0.9 * c.total) << c.inside << " of " << c.total << " within 3 sigma";
    // Not too wide either: about 68% within one sigma for a Gaussian estimate; sigmas twice too
    // large would put 95% there.
    EXPECT_LE(c.inside_1, kMaxWithinOneSigma * c.total)
        << c.inside_1 << " of " << c.total << " within 1 sigma";
}

TEST(FitStatistics, ReweightedRelativeSigmasCoverWhenSigmaColumnsAreGiven) {
    const Coverage c = coverage(true);
    ASSERT_GE(c.total, 100);
    EXPECT_GE(c.inside, 0.9 * c.total) << c.inside << " of " << c.total << " within 3 sigma";
    EXPECT_LE(c.inside_1, kMaxWithinOneSigma * c.total)
        << c.inside_1 << " of " << c.total << " within 1 sigma";
}

TEST(FitStatistics, ModelAutoPicksTheGeneratingFamily) {
    // The distribution family is always recovered. For one-lobe GGX data the two-lobe GGX may win
    // by a small BIC margin: the criterion's Gaussian likelihood counts every residual as an
    // independent observation of one variance, while the log residual of multiplicative noise is
    // heteroscedastic (docs/fitting-guide.md), so a second lobe is accepted there too.
    const FitOptions options = make_fit_spec(ModelOptions{})->options;
    struct Case {
        std::string family;
        brdf::ModelD truth;
    };
    brdf::ModelD two =
        default_truth(Distribution::kGgx, 0.03, Rgbd(0.2, 0.2, 0.2), Rgbd(0.5, 0.5, 0.5), 0.04);
    brdf::Lobe<double> wide = two.lobes[0];
    wide.alpha_x = wide.alpha_y = 0.4;
    wide.scale = Rgbd(0.8, 0.4, 0.2);
    two.lobes.push_back(wide);
    const Case cases[] = {
        {"ggx",
         default_truth(Distribution::kGgx, 0.3, Rgbd(0.2, 0.3, 0.1), Rgbd(0.8, 0.8, 0.8), 0.05)},
        {"beckmann",
         default_truth(
             Distribution::kBeckmann, 0.3, Rgbd(0.2, 0.3, 0.1), Rgbd(0.8, 0.8, 0.8), 0.05)},
        {"ggx x2", two},
    };
    for (const Case& c : cases) {
        for (std::uint64_t seed = 1; seed <= 2; ++seed) {
            Expected<AutoFitResult> r =
                fit_auto(noisy(c.truth, seed, false), auto_candidates(options));
            ASSERT_TRUE(r) << r.error().message;
            if (c.family == "ggx") {
                EXPECT_TRUE(r->chosen == "ggx" || r->chosen == "ggx x2") << r->chosen;
            } else {
                EXPECT_EQ(r->chosen, c.family) << "seed " << seed;
            }
            ASSERT_FALSE(r->ranking.empty());
            EXPECT_EQ(r->ranking.front().name, r->chosen);
            for (std::size_t i = 1; i < r->ranking.size(); ++i) {
                if (r->ranking[i].converged) {
                    EXPECT_LE(r->ranking[i - 1].criterion, r->ranking[i].criterion);
                }
            }
            EXPECT_TRUE(r->best.usable());
        }
    }
}

TEST(FitStatistics, AModelThatCannotRepresentTheDataIsNotUsableAndSaysWhatToTry) {
    // A retro-reflection peak (wo near wi) over a glossy surface: no microfacet lobe at the
    // mirror direction can follow it.
    const brdf::ModelD glossy =
        default_truth(Distribution::kGgx, 0.1, Rgbd(0.3, 0.3, 0.3), Rgbd(1.0, 1.0, 1.0), 0.04);
    brdf::Dataset data = testing::synthesize(glossy, testing::measurement_grid());
    for (brdf::Sample& s : data.samples) {
        const double c = s.wi().dot(s.wo());
        const double retro = c > 0 ? 20 * std::pow(c, 30) : 0;
        s.value += Rgbd(retro, 0.5 * retro, 0.2 * retro);
    }
    Expected<FitResult> r = fit(data, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_TRUE(r->solver.converged);
    EXPECT_FALSE(r->goodness.represents);
    EXPECT_FALSE(r->usable());
    ASSERT_FALSE(r->goodness.warnings.empty());
    EXPECT_NE(r->goodness.warnings[0].find("log RMSE of channel r"), std::string::npos);
    EXPECT_NE(r->goodness.suggestion.find("--model auto"), std::string::npos);
    EXPECT_NE(r->goodness.suggestion.find("--lobes 2"), std::string::npos);
    // The glossy surface alone is represented, without a warning.
    Expected<FitResult> g = fit(noisy(glossy, 3, false), *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(g) << g.error().message;
    EXPECT_TRUE(g->goodness.represents);
    EXPECT_TRUE(g->goodness.warnings.empty());
    EXPECT_TRUE(g->usable());
}

TEST(FitStatistics, TinyStatedSigmasWarnButASmallMisfitStaysUsable) {
    // 2 % noise stated as 0.01 % sigmas: chi-square near 4e4. A log RMSE of 2 % is a usable fit
    // with a warning; the same sigmas under a retro-reflection peak (log RMSE far above 2 %) are
    // not.
    const brdf::ModelD glossy =
        default_truth(Distribution::kGgx, 0.2, Rgbd(0.3, 0.3, 0.3), Rgbd(1.0, 1.0, 1.0), 0.04);
    brdf::Dataset small = noisy(glossy, 5, true);
    for (brdf::Sample& s : small.samples) {
        s.sigma = s.sigma / 200;
    }
    Expected<FitResult> r = fit(small, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->goodness.reduced_chi_square.has_value());
    EXPECT_GT(*r->goodness.reduced_chi_square, 1000);
    EXPECT_LT(r->metrics.log_rmse.maxCoeff(), 0.02);
    EXPECT_TRUE(r->goodness.represents);
    EXPECT_TRUE(r->usable());
    ASSERT_FALSE(r->goodness.warnings.empty());
    EXPECT_NE(r->goodness.warnings.back().find("sigmas are far smaller"), std::string::npos)
        << r->goodness.warnings.back();

    brdf::Dataset retro = small;
    for (brdf::Sample& s : retro.samples) {
        const double c = s.wi().dot(s.wo());
        const double peak = c > 0 ? 20 * std::pow(c, 30) : 0;
        s.value += Rgbd(peak, peak, peak);
        s.sigma = 1e-4 * s.value;
    }
    Expected<FitResult> q = fit(retro, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(q) << q.error().message;
    EXPECT_GT(q->metrics.log_rmse.maxCoeff(), 0.02);
    EXPECT_FALSE(q->goodness.represents);
    EXPECT_FALSE(q->usable());
}

TEST(FitStatistics, ReportsTheIterationsOfEveryStageAndTheReductionOnLargeInputs) {
    // A dense random set larger than twice the reduction: reduced solve, then the polish.
    const brdf::ModelD truth =
        default_truth(Distribution::kGgx, 0.2, Rgbd(0.3, 0.2, 0.1), Rgbd(0.9, 0.8, 0.7), 0.05);
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs;
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    while (dirs.size() < 50000) {
        const double ti = std::acos(0.05 + 0.95 * u(rng));
        const double to = std::acos(0.05 + 0.95 * u(rng));
        dirs.emplace_back(brdf::spherical_to_cartesian(ti, 0.0),
                          brdf::spherical_to_cartesian(to, 2 * brdf::kPi * u(rng)));
    }
    brdf::Dataset data = testing::synthesize(truth, dirs);
    FitSpec spec = *make_fit_spec(ModelOptions{});
    spec.options.coarse_samples = 5000;
    Expected<FitResult> r = fit(data, spec);
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->usable());
    int sum = 0;
    bool reduced = false, polish = false;
    for (const StageInfo& st : r->solver.stages) {
        sum += st.iterations;
        reduced = reduced || (st.name == "reduced" && st.samples < 10000);
        polish = polish || (st.name == "polish" && st.samples == 50000);
    }
    EXPECT_TRUE(reduced);
    EXPECT_TRUE(polish);
    EXPECT_EQ(sum, r->solver.iterations);
    EXPECT_NEAR(r->model.lobes[0].alpha_x, 0.2, 1e-6);
}

}  // namespace
}  // namespace gonio::fitting
