// Hard inputs: each ends with a correct fit or a clear error, never NaN and never a crash.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "fit_test_util.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"

namespace gonio::fitting {
namespace {

using brdf::Rgbd;
using testing::deg;

brdf::ModelD default_truth(double alpha, Rgbd f0, Rgbd diffuse) {
    brdf::ModelD m = make_fit_spec(ModelOptions{})->model;
    m.lobes[0].alpha_x = m.lobes[0].alpha_y = alpha;
    m.lobes[0].fresnel.f0 = f0;
    m.diffuse = diffuse;
    return m;
}

/// No NaN or Inf anywhere in a result, whatever its state.
void expect_finite(const FitResult& r) {
    for (const FittedParameter& p : r.parameters) {
        EXPECT_TRUE(std::isfinite(p.value)) << p.name;
        if (p.sigma) {
            EXPECT_TRUE(std::isfinite(*p.sigma)) << p.name;
        }
    }
    for (int c = 0; c < 3; ++c) {
        EXPECT_TRUE(std::isfinite(r.metrics.rmse[c]));
        EXPECT_TRUE(std::isfinite(r.metrics.rel_rmse[c]));
        EXPECT_TRUE(std::isfinite(r.metrics.log_rmse[c]));
    }
    const std::string json = fit_report_json(r);
    EXPECT_EQ(json.find("nan"), std::string::npos);
    EXPECT_EQ(json.find("inf"), std::string::npos);
}

double value_of(const FitResult& r, const std::string& name) {
    for (const FittedParameter& p : r.parameters) {
        if (p.name == name) {
            return p.value;
        }
    }
    return std::numeric_limits<double>::quiet_NaN();
}

bool listed(const std::vector<std::string>& v, const std::string& name) {
    return std::find(v.begin(), v.end(), name) != v.end();
}

TEST(FitStress, NearMirrorAlpha0002IsRecoveredWhenThePeakIsScannedFinely) {
    // A near-mirror metal: the peak (half width about 0.07 degrees in theta_h) is resolved by a
    // fine scan of +-0.5 degrees around the mirror direction at each incidence.
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs = testing::measurement_grid();
    for (double ti = 10; ti <= 70; ti += 20) {
        const brdf::Vec3d wi = brdf::spherical_to_cartesian(deg(ti), 0.0);
        for (double off = -0.5; off <= 0.5001; off += 0.05) {
            dirs.emplace_back(wi, brdf::spherical_to_cartesian(deg(ti + off), brdf::kPi));
            dirs.emplace_back(wi, brdf::spherical_to_cartesian(deg(ti), brdf::kPi + deg(off)));
        }
    }
    const brdf::ModelD truth = default_truth(0.002, Rgbd(0.9, 0.8, 0.6), Rgbd(0.01, 0.01, 0.01));
    // The truth's colour is in f0 (Schlick per channel): fit that structure.
    ModelOptions mo;
    mo.fresnel_rgb = true;
    FitSpec spec = *make_fit_spec(mo);
    Expected<FitResult> r = fit(testing::synthesize(truth, dirs), spec);
    ASSERT_TRUE(r) << r.error().message;
    expect_finite(*r);
    ASSERT_TRUE(r->usable()) << r->solver.message;
    EXPECT_NEAR(value_of(*r, "lobes[0].alpha_x"), 0.002, 1e-8);
    EXPECT_NEAR(value_of(*r, "lobes[0].fresnel.f0[2]"), 0.6, 1e-6);
}

TEST(FitStress, GrazingOnlyDataEndFiniteAndFlagWhatTheyCannotFix) {
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs;
    for (double ti = 75; ti <= 88; ti += 1) {
        for (double to = 75; to <= 88; to += 1) {
            for (double dphi : {180.0, 170.0, 150.0}) {
                dirs.emplace_back(brdf::spherical_to_cartesian(deg(ti), 0.0),
                                  brdf::spherical_to_cartesian(deg(to), deg(dphi)));
            }
        }
    }
    const brdf::ModelD truth = default_truth(0.2, Rgbd(0.04, 0.04, 0.04), Rgbd(0.5, 0.4, 0.3));
    Expected<FitResult> r = fit(testing::synthesize(truth, dirs), *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(r) << r.error().message;
    expect_finite(*r);
    if (r->usable()) {
        // Exact data: whatever the conditioning, the fit reproduces them.
        EXPECT_LT(r->metrics.rel_rmse.maxCoeff(), 1e-5);
    }
}

/// A lobe whose scale is free (scalar Schlick f0, the colour in the scale) can vanish; with the
/// default Schlick RGB the scale is 1 and F >= (1 - cos)^5, so a lobe always remains.
ModelOptions scale_free() {
    ModelOptions o;
    o.fresnel_rgb = false;
    return o;
}

TEST(FitStress, PurelyDiffuseDataGiveTheAlbedoAndSayTheLobeIsNotIdentifiable) {
    brdf::ModelD truth = default_truth(0.2, Rgbd::Zero(), Rgbd(0.5, 0.3, 0.1));
    truth.lobes.clear();
    const brdf::Dataset data = testing::synthesize(truth, testing::measurement_grid());
    Expected<FitResult> r = fit(data, *make_fit_spec(scale_free()));
    ASSERT_TRUE(r) << r.error().message;

    expect_finite(*r);
    ASSERT_TRUE(r->usable()) << r->solver.message;
    EXPECT_NEAR(value_of(*r, "diffuse[0]"), 0.5, 1e-6);
    EXPECT_NEAR(value_of(*r, "diffuse[2]"), 0.1, 1e-6);
    EXPECT_NEAR(value_of(*r, "lobes[0].scale[1]"), 0.0, 1e-6);
    EXPECT_TRUE(listed(r->not_identifiable, "lobes[0].alpha_x"));
    EXPECT_TRUE(listed(r->not_identifiable, "lobes[0].fresnel.f0"));
    for (const FittedParameter& p : r->parameters) {
        if (p.name == "lobes[0].alpha_x") {
            EXPECT_FALSE(p.identifiable);
            EXPECT_FALSE(p.sigma.has_value());
        }
    }
    // With the default model the Fresnel floor keeps a lobe: the fit is the best compromise,
    // close to the data but not exact, and still finite.
    Expected<FitResult> d = fit(data, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(d);
    expect_finite(*d);
    EXPECT_NEAR(value_of(*d, "diffuse[0]"), 0.5, 1e-3);
}

TEST(FitStress, AllZeroDataFitZeroAlbedosWithoutNan) {
    brdf::Dataset data = testing::synthesize(brdf::ModelD{}, testing::measurement_grid());
    for (const brdf::Sample& s : data.samples) {
        ASSERT_EQ(s.value.maxCoeff(), 0.0);
    }
    for (ResidualForm form : {ResidualForm::kLog,
                              ResidualForm::kRelative,
                              ResidualForm::kCubeRoot,
                              ResidualForm::kAbsolute}) {
        FitSpec spec = *make_fit_spec(scale_free());
        spec.options.residual = form;
        Expected<FitResult> r = fit(data, spec);
        ASSERT_TRUE(r) << r.error().message;
        expect_finite(*r);
        ASSERT_TRUE(r->usable()) << to_string(form) << ": " << r->solver.message;
        EXPECT_NEAR(value_of(*r, "diffuse[1]"), 0.0, 1e-6);
        EXPECT_NEAR(value_of(*r, "lobes[0].scale[1]"), 0.0, 1e-6);
        EXPECT_TRUE(listed(r->not_identifiable, "lobes[0].alpha_x")) << to_string(form);
    }
    // The default model cannot reach zero (Fresnel floor): finite, whatever it converges to.
    Expected<FitResult> d = fit(data, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(d);
    expect_finite(*d);
}

TEST(FitStress, SingleSampleIsUnderdeterminedAndSaysSo) {
    const brdf::ModelD truth = default_truth(0.2, Rgbd(0.04, 0.04, 0.04), Rgbd(0.5, 0.4, 0.3));
    const brdf::Dataset data =
        testing::synthesize(truth,
                            {{brdf::spherical_to_cartesian(deg(30), 0.0),
                              brdf::spherical_to_cartesian(deg(30), brdf::kPi)}});
    Expected<FitResult> r = fit(data, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(r) << r.error().message;
    expect_finite(*r);
    if (r->usable()) {
        // One sample and seven parameters: no parameter is determined on its own.
        EXPECT_FALSE(r->not_identifiable.empty());
        for (const FittedParameter& p : r->parameters) {
            if (p.free) {
                EXPECT_FALSE(p.identifiable && p.sigma) << p.name;
            }
        }
    }
}

TEST(FitStress, NoValidSampleIsAClearError) {
    brdf::Dataset data;
    data.source = "empty.csv";
    Expected<FitResult> r = fit(data, *make_fit_spec(ModelOptions{}));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("no valid sample"), std::string::npos);
}

TEST(FitStress, InvalidAndFlaggedRowsAreRejectedAndCountedAndTheRestIsFitted) {
    const brdf::ModelD truth = default_truth(0.1, Rgbd(0.05, 0.05, 0.05), Rgbd(0.4, 0.3, 0.2));
    brdf::Dataset data = testing::synthesize(truth, testing::measurement_grid());
    const std::size_t n = data.samples.size();
    for (std::size_t i = 0; i < n; ++i) {
        data.samples[i].line = i + 2;  // as from a file with a header line
    }
    data.samples[3].value[0] = std::numeric_limits<double>::quiet_NaN();
    data.samples[4].value[1] = -0.1;
    data.samples[5].theta_i = 1.7;  // below the horizon
    data.samples[6].value[2] = std::numeric_limits<double>::infinity();
    // One channel saturated: the camera clipped the red channel at the peak; the capture flagged
    // those samples, so they are rejected instead of pulling the fit down.
    std::size_t saturated = 0;
    for (brdf::Sample& s : data.samples) {
        if (s.value[0] > 3.0) {
            s.value[0] = 3.0;
            s.flags |= brdf::kFlagSaturated;
            ++saturated;
        }
    }
    ASSERT_GT(saturated, 0u);
    Expected<FitResult> r = fit(data, *make_fit_spec(ModelOptions{}));
    ASSERT_TRUE(r) << r.error().message;
    expect_finite(*r);
    // Saturated samples are counted apart from the invalid ones; both are left out.
    EXPECT_EQ(r->samples.rejected, 4u);
    EXPECT_EQ(r->samples.saturated, saturated);
    EXPECT_EQ(r->samples.valid, n - 4 - saturated);
    EXPECT_EQ(r->samples.rejected_lines[0], 5u);  // sample 3 at line 5
    ASSERT_TRUE(r->usable()) << r->solver.message;
    EXPECT_NEAR(value_of(*r, "lobes[0].alpha_x"), 0.1, 1e-6);
    EXPECT_NEAR(value_of(*r, "diffuse[0]"), 0.4, 1e-6);
}

TEST(FitStress, UnflaggedSaturatedChannelStillEndsFinite) {
    const brdf::ModelD truth = default_truth(0.05, Rgbd(0.9, 0.5, 0.3), Rgbd(0.1, 0.1, 0.1));
    brdf::Dataset data = testing::synthesize(truth, testing::measurement_grid());
    for (brdf::Sample& s : data.samples) {
        s.value[0] = std::min(s.value[0], 1.0);
    }
    for (LossKind loss : {LossKind::kNone, LossKind::kCauchy}) {
        FitSpec spec = *make_fit_spec(ModelOptions{});
        spec.options.loss = loss;
        Expected<FitResult> r = fit(data, spec);
        ASSERT_TRUE(r) << r.error().message;
        expect_finite(*r);
        // Clipping is not in the model: the fit is biased (alpha widens to meet the flat top)
        // but stays inside the bounds and finite.
        EXPECT_GE(value_of(*r, "lobes[0].alpha_x"), 1e-4);
        EXPECT_LE(value_of(*r, "lobes[0].alpha_x"), 4.0);
    }
}

}  // namespace
}  // namespace gonio::fitting
