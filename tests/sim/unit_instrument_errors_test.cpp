// The virtual rig's instrument errors: the error budget of the rig description (its profiles, its
// strict reading), the seeded draws they make (reproducible, of the stated size), and the world
// that shows the camera the arms' true directions, the lamp's fluctuation and stray light.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/test_units.h"
#include "gonio/brdf/rig_error_budget.h"
#include "gonio/brdf/rig_geometry.h"
#include "gonio/sim/instrument_errors.h"
#include "gonio/sim/sensor_model.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::sim {
namespace {

using gonio::test_units::kDeg;

nlohmann::json sim4() {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    std::stringstream ss;
    ss << in.rdbuf();
    return nlohmann::json::parse(ss.str());
}

TEST(ErrorBudget, AbsentIsTheReferenceProfileAndQuietIsNone) {
    nlohmann::json rig = sim4();
    rig.erase("error_budget");
    auto b = brdf::read_error_budget(rig.dump(), "rig.json");
    ASSERT_TRUE(b) << b.error().message;
    EXPECT_EQ(b->profile, "reference");
    EXPECT_GT(b->lamp_fluctuation, 0);
    EXPECT_GT(b->light_arm.repeatability_deg, 0);
    rig["error_budget"] = "quiet";
    b = brdf::read_error_budget(rig.dump(), "rig.json");
    ASSERT_TRUE(b) << b.error().message;
    EXPECT_EQ(b->lamp_fluctuation, 0);
    EXPECT_EQ(b->stray_light, 0);
    EXPECT_EQ(brdf::arm_direction_sigma_rad(b->detector_arm), 0);
    EXPECT_EQ(brdf::relative_sigma(*b, 10), 0);
}

TEST(ErrorBudget, ObjectChangesAProfilesTermsAndIsReadStrictly) {
    nlohmann::json rig = sim4();
    rig["error_budget"] = {{"profile", "quiet"},
                           {"lamp", {{"fluctuation", 0.003}}},
                           {"detector_arm", {{"zero_offset_deg", 0.04}}}};
    auto b = brdf::read_error_budget(rig.dump(), "rig.json");
    ASSERT_TRUE(b) << b.error().message;
    EXPECT_EQ(b->profile, "custom");
    EXPECT_EQ(b->lamp_fluctuation, 0.003);
    EXPECT_EQ(b->lamp_drift_per_hour, 0);  // the quiet profile's
    EXPECT_EQ(b->detector_arm.zero_offset_deg, 0.04);
    EXPECT_EQ(b->light_arm.zero_offset_deg, 0);
    // Fluctuation counts twice (the value's exposure and the white reference's), drift over time.
    EXPECT_NEAR(brdf::relative_sigma(*b, 0), std::sqrt(2) * 0.003, 1e-15);
    // Each refusal names the key.
    rig["error_budget"] = {{"lamp", {{"fluctuation", -0.1}}}};
    b = brdf::read_error_budget(rig.dump(), "rig.json");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("error_budget.lamp.fluctuation"), std::string::npos)
        << b.error().message;
    rig["error_budget"] = {{"lamp", {{"flicker", 0.1}}}};
    b = brdf::read_error_budget(rig.dump(), "rig.json");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("flicker"), std::string::npos) << b.error().message;
    rig["error_budget"] = "noisy";
    b = brdf::read_error_budget(rig.dump(), "rig.json");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("unknown profile"), std::string::npos) << b.error().message;
    rig["error_budget"] = 3;
    EXPECT_FALSE(brdf::read_error_budget(rig.dump(), "rig.json"));
}

TEST(ErrorBudget, ReferenceProfileGivesAboutHalfAPercentAtKTwoOnAMatteSample) {
    // docs/error-budget.md: a matte sample (f = 0.5 / pi) at theta_i = 45 deg, theta_o = 0,
    // measured within half an hour of its white reference. The angular term: d ln f / d theta_i
    // = tan theta_i for a Lambertian (cos theta_i in the radiance), one arm's sigma.
    const brdf::RigErrorBudget b = brdf::reference_error_budget();
    const double f = 0.5 / brdf::kPi;
    const double rel = brdf::relative_sigma(b, 0.5);
    const double stray = brdf::stray_light_brdf(b, std::cos(45 * kDeg)) / f;
    const double angular = std::tan(45 * kDeg) * brdf::arm_direction_sigma_rad(b.light_arm);
    const double combined = std::sqrt(rel * rel + stray * stray + angular * angular);
    EXPECT_GT(2 * combined, 0.004);
    EXPECT_LT(2 * combined, 0.006);
}

TEST(InstrumentErrors, DrawsAreSeededAndOfTheStatedSize) {
    const brdf::RigErrorBudget b = brdf::reference_error_budget();
    const InstrumentErrors a(b, 7), again(b, 7), other(b, 8);
    EXPECT_EQ(a.zero_offset_rad(Arm::kLight), again.zero_offset_rad(Arm::kLight));
    EXPECT_NE(a.zero_offset_rad(Arm::kLight), other.zero_offset_rad(Arm::kLight));
    EXPECT_EQ(a.lamp_factor(123, 0.5), again.lamp_factor(123, 0.5));
    // Repeatability: a fresh draw after each move; the scatter over many moves is the stated one
    // (20000 draws: the sample standard deviation within 2 %, about 4.5 of its own sigmas).
    const int n = 20000;
    double s1 = 0, s2 = 0, f1 = 0, f2 = 0;
    for (int k = 1; k <= n; ++k) {
        const double e =
            a.arm_angle(Arm::kDetector, 0.3, k) - 0.3 - a.zero_offset_rad(Arm::kDetector);
        s1 += e;
        s2 += e * e;
        const double l = a.lamp_factor(k, 0) - 1;
        f1 += l;
        f2 += l * l;
    }
    const double sd = std::sqrt(s2 / n - (s1 / n) * (s1 / n));
    EXPECT_NEAR(sd / (b.detector_arm.repeatability_deg * kDeg), 1, 0.02);
    EXPECT_NEAR(std::sqrt(f2 / n - (f1 / n) * (f1 / n)) / b.lamp_fluctuation, 1, 0.02);
    EXPECT_NEAR(a.arm_angle(Arm::kDetector, 0.3, 5), a.arm_angle(Arm::kDetector, 0.3, 5), 0);
    // Drift: linear in rig time at the drawn rate.
    EXPECT_NEAR(
        a.lamp_factor(9, 2.0) / a.lamp_factor(9, 0.0), 1 + 2 * a.drift_rate_per_hour(), 1e-12);
}

TEST(InstrumentErrors, TiltedArmAxisLeavesTheArmPlane) {
    brdf::RigErrorBudget b = brdf::quiet_error_budget();
    b.light_arm.axis_tilt_deg = 0.5;
    const InstrumentErrors e(b, 3);
    const double tilt = e.axis_tilt_rad(Arm::kLight);
    ASSERT_GT(std::abs(tilt), 1e-4);
    for (double a : {0.0, 0.7, 2.0}) {
        const brdf::Vec3d d = e.arm_direction(Arm::kLight, a, 1);
        // Rotating (cos a, sin a, 0) about W_y by the tilt: z = -sin(tilt) cos a, unit length.
        EXPECT_NEAR(d.z(), -std::sin(tilt) * std::cos(a), 1e-15);
        EXPECT_NEAR(d.norm(), 1, 1e-15);
    }
    // The detector arm, without a tilt, stays in the plane.
    EXPECT_EQ(e.arm_direction(Arm::kDetector, 0.7, 1).z(), 0);
}

TEST(InstrumentErrors, WorldShowsTheCameraTheTrueDirectionsAndStrayLight) {
    nlohmann::json rig = sim4();
    rig["error_budget"] = {
        {"profile", "quiet"}, {"detector_arm", {{"zero_offset_deg", 0.2}}}, {"stray_light", 0.01}};
    auto s = SimRig::start(rig.dump(), {});
    ASSERT_TRUE(s) << s.error().message;
    const InstrumentErrors* inst = (*s)->world().instrument();
    ASSERT_NE(inst, nullptr);
    const double offset = inst->zero_offset_rad(Arm::kDetector);
    ASSERT_GT(std::abs(offset), 1e-5);
    // Power-up: light arm at 0, detector at 45 deg (encoders); the camera sees the detector at
    // 45 deg plus the drawn zero offset.
    const SceneState sc = (*s)->world().scene();
    const auto nominal = brdf::rig_forward(brdf::RigPosed{0, 45 * kDeg, 0, 0});
    EXPECT_NEAR((sc.wi - nominal.first).norm(), 0, 1e-12);
    EXPECT_NEAR(brdf::angle_between(sc.wo, nominal.second), std::abs(offset), 1e-9);
    EXPECT_NEAR(sc.detector_arm_rad, 45 * kDeg + offset, 1e-12);
    EXPECT_NEAR(sc.stray_radiance_w_m2_sr, 0.01 * sc.irradiance_w_m2 / brdf::kPi, 1e-15);
    // The quiet rig: the encoders' directions exactly, no stray light.
    rig["error_budget"] = "quiet";
    auto q = SimRig::start(rig.dump(), {});
    ASSERT_TRUE(q) << q.error().message;
    const SceneState qs = (*q)->world().scene();
    EXPECT_NEAR((qs.wo - nominal.second).norm(), 0, 1e-12);
    EXPECT_EQ(qs.stray_radiance_w_m2_sr, 0);
    EXPECT_EQ(qs.irradiance_w_m2, 1.0);
}

TEST(SensorModel, NonLinearityBendsTheResponseAsStated) {
    // Noise-free enough: a bright uniform frame of many pixels, mean counts against the formula
    // x (1 + beta (x - 1/2)) of the linear chain's mean.
    SensorParams p;
    p.width = 200;
    p.height = 200;
    p.read_noise_e = 0;
    p.dark_current_e_per_s = 0;
    SensorModel linear(p);
    p.nonlinearity = 0.05;
    SensorModel bent(p);
    ExposureSettings es;
    es.exposure_us = 1000;
    const double radiance = 0.7 * 30000 / (p.responsivity_e_per_s * 1e-3) * 0.9;
    const cv::Mat L(200, 200, CV_32F, cv::Scalar(radiance));
    const double black = linear.black_level(es.format);
    const double full = linear.saturation_level(es.format) - black;
    const double x = (linear.mean_counts(radiance, es) - black) / full;
    ASSERT_GT(x, 0.2);
    ASSERT_LT(x, 0.9);
    const double mean_bent = cv::mean(bent.expose(L, es))[0] - black;
    const double mean_linear = cv::mean(linear.expose(L, es))[0] - black;
    EXPECT_NEAR(mean_linear / full, x, 2e-4);
    EXPECT_NEAR(mean_bent / full, x * (1 + 0.05 * (x - 0.5)), 5e-4);
}

}  // namespace
}  // namespace gonio::sim
