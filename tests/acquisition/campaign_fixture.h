#pragma once

// The campaign tests' fixture: a fresh campaign folder on the sim4 rig description with a ground
// truth model beside it, and the virtual rig (real Modbus TCP and camera emulator on 127.0.0.1)
// started on it with the rig's devices opened.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "gonio/acquisition/point/campaign.h"
#include "gonio/sim/motor_sim.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::acquisition::testing {

struct CampaignFixture {
    std::string dir;    ///< The campaign folder.
    std::string model;  ///< The ground truth's model file, beside the folder.
    RigConfig rig;
    CampaignSpec spec;
};

/// A fresh campaign folder `<build>/test_campaigns/NAME_PID` created from `spec` (its rig file
/// and JSON set here) on data/rigs/`rig_file` (sim4.json), the ground truth `model_json` written
/// beside it. With `quiet_rig` the rig's error budget is the quiet one (the detector's noise
/// only), for tests that read exact levels.
inline CampaignFixture make_campaign_fixture(const std::string& name,
                                             const std::string& model_json,
                                             CampaignSpec spec,
                                             bool quiet_rig = false,
                                             const std::string& rig_file = "sim4.json") {
    namespace fs = std::filesystem;
    CampaignFixture f;
    f.dir = std::string(GONIO_BINARY_DIR) + "/test_campaigns/" + name + "_" +
            std::to_string(::getpid());
    fs::remove_all(f.dir);
    fs::create_directories(f.dir);
    f.model = f.dir + "_model.json";
    std::ofstream(f.model) << model_json;
    auto rig = read_rig_config(std::string(GONIO_SOURCE_DIR) + "/data/rigs/" + rig_file);
    EXPECT_TRUE(rig) << rig.error().message;
    if (rig) {
        f.rig = *rig;
    }
    if (rig && quiet_rig) {
        nlohmann::json j = nlohmann::json::parse(f.rig.json);
        j["error_budget"] = "quiet";
        auto q = parse_rig_config(j.dump(2), rig_file);
        EXPECT_TRUE(q) << q.error().message;
        if (q) {
            f.rig = *q;
        }
    }
    f.spec = std::move(spec);
    f.spec.rig = "rig.json";
    f.spec.json = campaign_spec_json(f.spec);
    auto c = create_campaign_dir(f.dir, f.spec, f.rig);
    EXPECT_TRUE(c) << c.error().message;
    return f;
}

/// The virtual rig of a fixture and the devices opened on it.
struct LiveRig {
    std::unique_ptr<sim::SimRig> sim;
    RigDevices dev;
};

/// Starts the virtual rig of `f` (its ground truth mounted) at `time_scale` simulated seconds per
/// second and opens the rig's devices on it; `motor_query` is appended to the motors' address
/// (driver settings such as an outage window).
inline LiveRig start_live_rig(const CampaignFixture& f,
                              double time_scale,
                              const std::string& motor_query = "") {
    LiveRig r;
    sim::SimRigOptions so;
    so.brdf_path = f.model;
    so.time_scale = time_scale;
    auto s = sim::SimRig::start(f.rig.json, so);
    EXPECT_TRUE(s) << s.error().message;
    if (!s) {
        return r;
    }
    r.sim = std::move(*s);
    auto dev = open_rig(
        with_addresses(f.rig, r.sim->motor_address() + motor_query, r.sim->camera_address()));
    EXPECT_TRUE(dev) << dev.error().message;
    if (dev) {
        r.dev = std::move(*dev);
    }
    return r;
}

/// Hooks that print nothing.
inline RunHooks quiet_hooks() {
    RunHooks h;
    h.out = nullptr;
    return h;
}

/// A JSON file of a campaign (metadata.json, campaign.json), parsed.
inline nlohmann::json read_json(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return nlohmann::json::parse(ss.str());
}

/// Duration of the simulated drive's move of `d` degrees (its own profile planner).
inline double sim_move_s(double d, double speed, double accel) {
    const auto phases = sim::plan_trapezoid(0, 0, d, speed, accel, accel);
    return phases.empty() ? 0.0 : phases.back().t0 + phases.back().duration;
}

}  // namespace gonio::acquisition::testing
