// Rig descriptions: every section, the simulator's and the camera's included, names a mistyped key
// with its path instead of running on a default.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "gonio/acquisition/shared/rig_config.h"

namespace {

using gonio::acquisition::parse_rig_config;

nlohmann::json shipped_rig() {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    std::stringstream ss;
    ss << in.rdbuf();
    return nlohmann::json::parse(ss.str());
}

std::string error_of(const nlohmann::json& j) {
    auto r = parse_rig_config(j.dump(), "rig.json");
    return r ? std::string() : r.error().message;
}

nlohmann::json zoom_rig() {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim-image-zoom.json");
    std::stringstream ss;
    ss << in.rdbuf();
    return nlohmann::json::parse(ss.str());
}

TEST(RigConfig, ZoomedPlacementsAreReadWithTheirCoils) {
    const auto r = parse_rig_config(zoom_rig().dump(), "sim-image-zoom.json");
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_EQ(r->placements.size(), 4u);
    EXPECT_EQ(r->placements[0].placement.name, "zoom-1");
    EXPECT_EQ(r->placements[2].placement.magnification, 8);
    EXPECT_DOUBLE_EQ(r->placements[3].placement.offset_m[0], 0.019);
    EXPECT_EQ(r->placements[3].coil.unit, 13);
    // On the shutter's bus unless an address is given; moved with the others.
    EXPECT_EQ(r->placements[1].coil.address, r->shutter.address);
    const auto moved =
        gonio::acquisition::with_addresses(*r, "tcp://127.0.0.1:1502", "gige://127.0.0.9");
    EXPECT_EQ(moved.placements[3].coil.address, "tcp://127.0.0.1:1502");
    const auto again = parse_rig_config(moved.json, "moved.json");
    ASSERT_TRUE(again) << again.error().message;
    EXPECT_EQ(again->placements[3].coil.address, "tcp://127.0.0.1:1502");
    EXPECT_EQ(r->blind_angle_deg, 1.5);
    EXPECT_EQ(r->max_theta_deg, 88);
}

TEST(RigConfig, BadPlacementsAreNamed) {
    nlohmann::json j = zoom_rig();
    j["placements"][1]["magnification"] = 0.5;
    EXPECT_NE(error_of(j).find("placements[1].magnification = 0.5"), std::string::npos)
        << error_of(j);
    j = zoom_rig();
    j["placements"][0]["offset_m"] = {0.01};
    EXPECT_NE(error_of(j).find("placements[0].offset_m"), std::string::npos) << error_of(j);
    j = zoom_rig();
    j["placements"][2]["zoom"] = 3;
    EXPECT_NE(error_of(j).find("placements[2]"), std::string::npos) << error_of(j);
    EXPECT_NE(error_of(j).find("zoom"), std::string::npos) << error_of(j);
    j = zoom_rig();
    j["placements"][0].erase("unit");
    EXPECT_NE(error_of(j).find("placements[0]"), std::string::npos) << error_of(j);
}

TEST(RigConfig, ShippedRigIsAccepted) {
    const auto r = parse_rig_config(shipped_rig().dump(), "sim4.json");
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(r->camera_address, shipped_rig()["camera"]["address"].get<std::string>());
}

TEST(RigConfig, MistypedSimulatorAndCameraKeysAreNamedWithTheirPath) {
    struct Case {
        const char* pointer;
        const char* key;
        const char* expected;
    };
    const Case cases[] = {
        {"/sim", "time_scael", "rig.json: sim.time_scael: unknown key"},
        {"/sim/sensor", "widht", "rig.json: sim.sensor.widht: unknown key"},
        {"/sim/initial_deg", "ligth", "rig.json: sim.initial_deg.ligth: unknown key"},
        {"/camera", "adress", "rig.json: camera.adress: unknown key"},
    };
    for (const Case& c : cases) {
        nlohmann::json j = shipped_rig();
        j[nlohmann::json::json_pointer(c.pointer)][c.key] = 1;
        const std::string e = error_of(j);
        EXPECT_NE(e.find(c.expected), std::string::npos) << c.pointer << ": " << e;
    }
}

TEST(RigConfig, SimulatorSensorMustBeAnObject) {
    nlohmann::json j = shipped_rig();
    j["sim"]["sensor"] = 640;
    const std::string e = error_of(j);
    EXPECT_NE(e.find("sim.sensor: expected an object"), std::string::npos) << e;
}

}  // namespace
