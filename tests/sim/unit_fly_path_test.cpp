// Fly scans on the virtual rig: an exposure taken while the detector arm sweeps across a glossy
// peak integrates the truth along the arm's path, as a real sensor would.

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/exposure_path.h"
#include "gonio/brdf/rig_geometry.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/camera_render.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::sim {
namespace {

using gonio::test_units::kDeg;
constexpr double kAlpha = 0.05;

/// sim4.json as a quiet rig at the real time scale, the light arm at -30 deg and the detector
/// arm at 0.
std::string fly_rig_json() {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    std::stringstream ss;
    ss << in.rdbuf();
    nlohmann::json j = nlohmann::json::parse(ss.str());
    j["error_budget"] = "quiet";
    j["sim"]["time_scale"] = 1;
    j["sim"]["initial_deg"] = {{"light", -30}, {"detector", 0}, {"tilt", 0}, {"spin", 0}};
    return j.dump();
}

std::unique_ptr<brdf::Brdf> ggx_truth() {
    brdf::ModelD m;
    m.diffuse = brdf::Rgbd::Constant(0.02);
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = kAlpha;
    l.fresnel.type = brdf::FresnelType::kNone;
    l.scale = brdf::Rgbd::Constant(0.5);
    m.lobes.push_back(l);
    return brdf::make_analytic_brdf(m);
}

/// The camera's patch radiance over an exposure whose detector arm turns at `speed` rad/s from
/// `a0` for `t` seconds (light arm at -30 deg, tilt and spin 0), by the midpoint rule on 200000
/// steps: an integral independent of the rig's quadrature and of its trajectory sampling.
double reference_radiance(const brdf::Brdf& f, double a0, double speed, double t) {
    constexpr int kSteps = 200000;
    double sum = 0;
    for (int k = 0; k < kSteps; ++k) {
        const double a = a0 + speed * t * (k + 0.5) / kSteps;
        const auto [wi, wo] = brdf::rig_forward(brdf::RigPosed{-30 * kDeg, a, 0, 0});
        sum += f.eval(wi, wo).mean() * wi.z();
    }
    return sum / kSteps;  // irradiance 1 W/m^2
}

TEST(FlyPath, SweptExposureIsThePathIntegralOfTheTruth) {
    auto rig = SimRig::start(fly_rig_json(), SimRigOptions{});
    ASSERT_TRUE(rig) << rig.error().message;
    const auto truth = ggx_truth();
    // The detector arm cruises at 30 deg/s (sim4.json); one exposure spans 4 alpha = 0.2 rad of
    // its travel, across the specular peak at +30 deg.
    const double speed = 30 * kDeg;
    const double exposure_s = 4 * kAlpha / speed;
    MotorControllerServer& motors = (*rig)->motors();
    // The detector arm (unit 2) driven through the real protocol stack.
    auto profile = devices::load_axis_profile("generic");
    ASSERT_TRUE(profile) << profile.error().message;
    auto bus = devices::ModbusBus::open(*devices::parse_bus_address((*rig)->motor_address()));
    ASSERT_TRUE(bus) << bus.error().message;
    devices::ModbusAxis detector(
        *bus, 2, *profile, "detector", devices::SoftLimits{-170, 170}, devices::Motion{30, 60, 5});
    // Start the exposure once the arm is past its ramp (7.5 deg) and 5.9 deg before the peak.
    const double start_deg = 30 - 0.5 * 4 * kAlpha / kDeg - 0.2;
    double before = 0, after = 0;
    SceneState s;
    for (int attempt = 0;; ++attempt) {
        if (attempt > 0) {
            // The last start came late (this thread was descheduled on a loaded machine): the
            // exposure was not centred on the peak. The arm goes back and sweeps again.
            ASSERT_TRUE(detector.wait_done(std::chrono::seconds(30)));
            ASSERT_TRUE(detector.move_to(0.0, std::chrono::seconds(30)));
        }
        ASSERT_TRUE(detector.start_move(60.0));
        for (int guard = 0; motors.position_deg(2) < start_deg; ++guard) {
            ASSERT_LT(guard, 100000) << motors.position_deg(2);
            std::this_thread::sleep_for(std::chrono::microseconds(200));  // polls the arm's travel
        }
        before = motors.position_deg(2) * kDeg;
        s = (*rig)->world().scene();
        s.shutter_open = true;
        (*rig)->world().fill_path(exposure_s, &s);
        after = motors.position_deg(2) * kDeg;
        if (before / kDeg - start_deg < 0.3 || attempt == 5) {
            break;
        }
    }
    ASSERT_FALSE(s.path.empty());
    // The drive's touch probe latched the exposure's edges: read through the protocol stack, they
    // bracket the cruise's travel over the exposure (to a step, 0.001 deg).
    auto latch = detector.exposure_latch_deg();
    ASSERT_TRUE(latch) << latch.error().message;
    EXPECT_GE((*latch)[0], before / kDeg - 0.001);
    EXPECT_LE((*latch)[0], after / kDeg + 0.001);
    EXPECT_NEAR((*latch)[1] - (*latch)[0], speed * exposure_s / kDeg, 0.002);
    const double swept = patch_radiance_over(*truth, s);
    // The exposure started between the two read-backs (microseconds apart): the reference at
    // either end brackets it.
    const double r0 = reference_radiance(*truth, before, speed, exposure_s);
    const double r1 = reference_radiance(*truth, after, speed, exposure_s);
    EXPECT_GE(swept, std::min(r0, r1) * (1 - 1e-6)) << r0 << " " << r1;
    EXPECT_LE(swept, std::max(r0, r1) * (1 + 1e-6)) << r0 << " " << r1;
    EXPECT_LT(std::abs(r1 / r0 - 1), 1e-3);
    // The smear is real: the value at mid-exposure is far from the exposure's mean.
    const double mid = 0.5 * (before + after) + 0.5 * speed * exposure_s;
    const auto [wi, wo] = brdf::rig_forward(brdf::RigPosed{-30 * kDeg, mid, 0, 0});
    const double at_mid = truth->eval(wi, wo).mean() * wi.z();
    EXPECT_GT(at_mid / swept, 1.5);
}

TEST(FlyPath, LatchedPathMeanReproducesTheRigsIntegral) {
    // What a fly campaign records and the fit models: the exposure's path between the positions
    // the drive latched, averaged by the fit's quadrature (brdf/exposure_path.h: 1 deg pieces, 4
    // nodes), against the rig's own integral along the stages' trajectory.
    auto rig = SimRig::start(fly_rig_json(), SimRigOptions{});
    ASSERT_TRUE(rig) << rig.error().message;
    const auto truth = ggx_truth();
    const double speed = 30 * kDeg;
    const double exposure_s = 4 * kAlpha / speed;  // the exposure spans 4 alpha
    MotorControllerServer& motors = (*rig)->motors();
    auto profile = devices::load_axis_profile("generic");
    ASSERT_TRUE(profile) << profile.error().message;
    auto bus = devices::ModbusBus::open(*devices::parse_bus_address((*rig)->motor_address()));
    ASSERT_TRUE(bus) << bus.error().message;
    devices::ModbusAxis detector(
        *bus, 2, *profile, "detector", devices::SoftLimits{-170, 170}, devices::Motion{30, 60, 5});
    ASSERT_TRUE(detector.start_move(60.0));
    const double start_deg = 30 - 0.5 * 4 * kAlpha / kDeg - 0.2;
    for (int guard = 0; motors.position_deg(2) < start_deg; ++guard) {
        ASSERT_LT(guard, 100000) << motors.position_deg(2);
        std::this_thread::sleep_for(std::chrono::microseconds(200));  // polls the arm's travel
    }
    SceneState s = (*rig)->world().scene();
    s.shutter_open = true;
    (*rig)->world().fill_path(exposure_s, &s);
    ASSERT_FALSE(s.path.empty());
    auto latch = detector.exposure_latch_deg();
    ASSERT_TRUE(latch) << latch.error().message;
    const auto [wi0, wo0] = brdf::rig_forward(brdf::RigPosed{-30 * kDeg, (*latch)[0] * kDeg, 0, 0});
    const auto [wi1, wo1] = brdf::rig_forward(brdf::RigPosed{-30 * kDeg, (*latch)[1] * kDeg, 0, 0});
    const std::vector<brdf::PathNode> nodes =
        brdf::exposure_path_nodes(wi0, wo0, wi1, wo1, 1.0 * kDeg, 4);
    const double cos_i = wi0.z();
    const brdf::Rgbd mean = brdf::exposure_path_mean<double>(
        nodes, cos_i, [&](const brdf::Vec3d& wi, const brdf::Vec3d& wo) {
            return truth->eval(wi, wo);
        });
    // The rig integrates f cos_i over the exposure (irradiance 1): the same mean times cos_i, to
    // the latch's step (0.001 deg of a 11.5 deg exposure).
    const double swept = patch_radiance_over(*truth, s);
    EXPECT_NEAR(mean.mean() * cos_i / swept, 1, 2e-4) << mean.mean() * cos_i << " " << swept;
    // And the independent midpoint rule along the latched path.
    const double reference = reference_radiance(
        *truth, (*latch)[0] * kDeg, speed, ((*latch)[1] - (*latch)[0]) * kDeg / speed);
    EXPECT_NEAR(mean.mean() * cos_i / reference, 1, 1e-6);
}

TEST(FlyPath, StandingStagesHaveNoPath) {
    auto rig = SimRig::start(fly_rig_json(), SimRigOptions{});
    ASSERT_TRUE(rig) << rig.error().message;
    SceneState s = (*rig)->world().scene();
    (*rig)->world().fill_path(0.5, &s);
    EXPECT_TRUE(s.path.empty());
}

}  // namespace
}  // namespace gonio::sim
