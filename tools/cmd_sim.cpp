// gonio sim: the virtual rig as its own process (motor controllers over Modbus TCP, the camera as
// a GigE Vision device on loopback), for a separate `gonio acquire campaign.json` or for manual
// tests.

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "command.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/data_path.h"
#include "gonio/sim/sim_rig.h"
#include "option_checks.h"

namespace {

struct SimOptions {
    std::string config;
    std::string material;
    std::string brdf;
    double time_scale = 0;
    std::string rig_out;
    std::uint64_t seed = 0;
    std::string camera_ip = "127.0.0.1";
    bool exposure_abs = false;
};

int fail(const std::string& msg) {
    std::fprintf(stderr, "gonio sim: %s\n", msg.c_str());
    return 1;
}

int run(const SimOptions& o) {
    std::string path = o.config;
    if (path.empty()) {
        auto p = gonio::find_data_file("rigs/sim4.json");
        if (!p) {
            return fail(p.error().message);
        }
        path = *p;
    }
    std::ifstream in(path);
    if (!in) {
        return fail(path + ": cannot open the rig description");
    }
    std::stringstream ss;
    ss << in.rdbuf();
    gonio::sim::SimRigOptions so;
    so.material = o.material;
    so.brdf_path = o.brdf;
    so.time_scale = o.time_scale;
    so.seed = o.seed;
    so.camera_ip = o.camera_ip == "auto" ? std::string() : o.camera_ip;
    so.exposure_abs = o.exposure_abs;
    // Block the stop signals before any server thread starts, then wait for one of them.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    auto rig = gonio::sim::SimRig::start(ss.str(), so);
    if (!rig) {
        return fail(rig.error().message);
    }
    const std::string motors = (*rig)->motor_address();
    const std::string camera = (*rig)->camera_address();
    if (!o.rig_out.empty()) {
        // The same rig description with the addresses this process serves.
        nlohmann::json j = nlohmann::json::parse(ss.str());
        for (auto& a : j["axes"]) {
            a["address"] = motors;
        }
        j["shutter"]["address"] = motors;
        if (j.contains("reference_changer")) {
            j["reference_changer"]["address"] = motors;
        }
        j["camera"]["address"] = camera;
        if (auto w = gonio::write_file_atomic(o.rig_out, j.dump(2) + "\n"); !w) {
            return fail(w.error().message);
        }
    }
    std::printf("virtual rig: %s\nmotors: %s\ncamera: %s\n",
                (*rig)->describe().c_str(),
                motors.c_str(),
                camera.c_str());
    if (!o.rig_out.empty()) {
        std::printf("rig description with these addresses: %s\n", o.rig_out.c_str());
    }
    std::printf("Ctrl-C stops\n");
    std::fflush(stdout);
    int sig = 0;
    sigwait(&set, &sig);
    (*rig)->stop();
    std::printf("stopped (signal %d)\n", sig);
    return 0;
}

}  // namespace

GONIO_COMMAND(sim) {
    auto* cmd = app.add_subcommand(
        "sim", "serve the virtual rig (motor controllers and camera) until Ctrl-C");
    auto o = std::make_shared<SimOptions>();
    cmd->add_option("--config", o->config, "rig description (default data/rigs/sim4.json)")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--material", o->material, "ground truth: named material (data/materials)");
    cmd->add_option("--brdf", o->brdf, "ground truth: model JSON or table")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--time-scale", o->time_scale, "motion time scale (simulated s per real s)")
        ->check(gonio::tools::finite_above(0));
    // 0 is the rig description's seed: an explicit seed starts at 1.
    cmd->add_option("--seed", o->seed, "sensor and encoder noise seed")
        ->check(gonio::tools::integer_at_least(1));
    cmd->add_option("--camera-ip",
                    o->camera_ip,
                    "address of the GigE Vision camera, port 3956 (default 127.0.0.1; auto: a "
                    "free 127.x.y.z address, printed and written to --rig-out)");
    cmd->add_flag("--exposure-abs",
                  o->exposure_abs,
                  "name the camera's exposure feature ExposureTimeAbs instead of ExposureTime");
    cmd->add_option(
        "--rig-out", o->rig_out, "write the rig description with the served addresses here");
    return [o, cmd]() {
        if (cmd->count("--brdf") > 0 && cmd->count("--material") > 0) {
            return gonio::tools::usage_error(
                "sim", "--brdf and --material both name the ground truth: give one");
        }
        return run(*o);
    };
}
