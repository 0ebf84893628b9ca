// The virtual rig's world: the camera sees the directions the stages' angles give through the
// documented four-axis geometry, the shutter, the reference changer and the filter coils switch
// what it sees.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/devices/filter_wheel.h"
#include "gonio/devices/modbus_light.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::sim {
namespace {

/// sim4.json as a quiet rig (no instrument errors): these tests check the geometry itself
/// (unit_instrument_errors_test.cpp checks the errors).
std::string sim4_json() {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    std::stringstream ss;
    ss << in.rdbuf();
    nlohmann::json j = nlohmann::json::parse(ss.str());
    j["error_budget"] = "quiet";
    return j.dump();
}

TEST(RigWorld, SceneFollowsTheStagesAndCoils) {
    SimRigOptions o;
    auto rig = SimRig::start(sim4_json(), o);
    ASSERT_TRUE(rig) << rig.error().message;
    // Power-up: light arm at 0 (along the sample normal), detector arm at 45 deg: wo lies in the
    // sample's x-z plane at 45 deg from the normal.
    SceneState s = (*rig)->world().scene();
    EXPECT_NEAR((s.wi - brdf::Vec3d(0, 0, 1)).norm(), 0, 1e-9);
    const double h = std::sqrt(0.5);
    EXPECT_NEAR((s.wo - brdf::Vec3d(h, 0, h)).norm(), 0, 1e-9);
    // The stage angles themselves, for image-mode renderers (radians).
    EXPECT_NEAR(s.light_arm_rad, 0, 1e-9);
    EXPECT_NEAR(s.detector_arm_rad, brdf::kPi / 4, 1e-9);
    EXPECT_NEAR(s.tilt_rad, 0, 1e-9);
    EXPECT_NEAR(s.spin_rad, 0, 1e-9);
    EXPECT_FALSE(s.shutter_open);
    // The shutter and the reference changer are coils on the Modbus server.
    auto shutter = devices::open_modbus_light((*rig)->motor_address(), 5, 0);
    ASSERT_TRUE(shutter) << shutter.error().message;
    ASSERT_TRUE((*shutter)->set_shutter_open(true));
    EXPECT_TRUE((*rig)->world().scene().shutter_open);
    auto changer = devices::open_modbus_light((*rig)->motor_address(), 6, 0);
    ASSERT_TRUE(changer);
    const brdf::Vec3d wi(0, 0, 1), wo(h, 0, h);
    const double sample_value = (*rig)->sample()->eval(wi, wo).mean();
    ASSERT_TRUE((*changer)->set_shutter_open(true));
    (*rig)->world().scene();  // the world switches the mounted BRDF at each exposure
    auto dev_brdf = std::make_shared<MountedBrdf>((*rig)->sample(), 0.99);
    EXPECT_NEAR(dev_brdf->eval(wi, wo).mean(), sample_value, 1e-15);
    dev_brdf->set_white(true);
    EXPECT_NEAR(dev_brdf->eval(wi, wo)[0], 0.99 / brdf::kPi, 1e-15);
    EXPECT_EQ(dev_brdf->eval(brdf::Vec3d(0, 0, -1), wo)[0], 0.0);
    EXPECT_EQ((*rig)->world().exposures(), 3u);
}

TEST(RigWorld, SimSectionIsReadStrictlyWithItsDefaults) {
    const nlohmann::json rig = nlohmann::json::parse(sim4_json());
    auto start_with = [&](const nlohmann::json& sim) {
        nlohmann::json j = rig;
        j["sim"] = sim;
        return SimRig::start(j.dump(), SimRigOptions{});
    };
    // Present keys are read, absent ones keep their defaults (light arm 0, red-plastic).
    {
        auto started = start_with({{"initial_deg", {{"detector", 30}}}, {"time_scale", 50}});
        ASSERT_TRUE(started) << started.error().message;
        const SceneState s = (*started)->world().scene();
        EXPECT_NEAR(s.detector_arm_rad, 30 * brdf::kPi / 180, 1e-9);
        EXPECT_NEAR(s.light_arm_rad, 0, 1e-9);
        EXPECT_EQ((*started)->describe().rfind("sample red-plastic", 0), 0u);
    }
    auto refused = [&](const nlohmann::json& sim) {
        auto started = start_with(sim);
        return started ? std::string("accepted") : started.error().message;
    };
    // Unknown keys are refused with their key path and the keys allowed there.
    EXPECT_EQ(
        refused({{"time_scael", 20}}),
        "sim rig: sim.time_scael: unknown key (allowed here: material, brdf, time_scale, seed, "
        "start_homed, initial_deg, irradiance_w_m2, sensor)");
    EXPECT_EQ(refused({{"sensor", {{"widht", 640}}}}),
              "sim rig: sim.sensor.widht: unknown key (allowed here: width, height)");
    EXPECT_EQ(
        refused({{"initial_deg", {{"detecter", 45}}}}),
        "sim rig: sim.initial_deg.detecter: unknown key (allowed here: light, detector, tilt, "
        "spin)");
    // Types and ranges, by key path.
    EXPECT_EQ(refused({{"time_scale", "fast"}}),
              "sim rig: sim.time_scale: expected a number, got string");
    EXPECT_EQ(refused({{"sensor", {{"width", 640.5}}}}),
              "sim rig: sim.sensor.width = 640.5: must be a whole number in [1, 16384]");
    EXPECT_EQ(refused({{"start_homed", 1}}),
              "sim rig: sim.start_homed: expected true or false, got number");
    EXPECT_EQ(refused({{"time_scale", 0}}),
              "sim rig: sim.time_scale = 0: must be > 0 (simulated seconds per second)");
    EXPECT_EQ(refused("red-plastic"), "sim rig: sim: expected an object, got string");
}

TEST(RigWorld, FilterWheelCoilsSelectTheCameraFilter) {
    SimRigOptions o;
    auto rig = SimRig::start(sim4_json(), o);
    ASSERT_TRUE(rig) << rig.error().message;
    // No filter in the beam at power-up: the unfiltered mean of R, G and B.
    const brdf::Rgbd mono = brdf::Rgbd::Constant(1.0 / 3.0);
    EXPECT_NEAR(((*rig)->world().scene().filter - mono).abs().maxCoeff(), 0, 1e-15);
    // sim4.json: red, green, blue filter coils on units 7, 8, 9, coil 0.
    auto wheel = devices::open_modbus_filter_wheel(
        (*rig)->motor_address(),
        {devices::FilterCoil{7, 0}, devices::FilterCoil{8, 0}, devices::FilterCoil{9, 0}});
    ASSERT_TRUE(wheel) << wheel.error().message;
    for (int c : {2, 0, 1}) {
        ASSERT_TRUE((*wheel)->set_filter(c));
        const SceneState s = (*rig)->world().scene();
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(s.filter[k], k == c ? 1.0 : 0.0) << "filter " << c << " channel " << k;
        }
        // Exactly one coil on.
        for (int u = 7; u <= 9; ++u) {
            EXPECT_EQ((*rig)->motors().shutter_open(u), u - 7 == c) << "unit " << u;
        }
    }
    EXPECT_FALSE((*wheel)->set_filter(3));
    EXPECT_FALSE((*wheel)->set_filter(-1));
}

}  // namespace
}  // namespace gonio::sim
