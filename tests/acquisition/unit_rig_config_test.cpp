// Rig descriptions: every section, the simulator's and the camera's included, names a mistyped key
// with its path instead of running on a default.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "gonio/acquisition/rig_config.h"

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
