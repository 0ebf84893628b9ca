// The help walk (help_walk.h) of the device commands: gonio sim, axis, camera and devices. Every
// run talks to the simulator over loopback: simulated Modbus controllers in this process (a fresh
// one for each run, on an ephemeral port) or the command's own servers, and the simulated GigE
// Vision camera (served by the command itself or by `gonio sim`).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "cli_run.h"
#include "gonio/brdf/model_json.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_light.h"
#include "gonio/sim/motor_controller_server.h"
#include "help_walk.h"

namespace {

namespace fs = std::filesystem;
using gonio::testing::BusyPort;
using gonio::testing::CliRun;
using gonio::testing::Proof;
using gonio::testing::prove;
using gonio::testing::run_gonio;
using gonio::testing::take_written;
using gonio::testing::word_after;

std::string devices_walk_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("help_walk_devices").string();
    return d;
}

/// A model unlike the simulators' default materials.
std::string devices_walk_model() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = gonio::brdf::Rgbd(0.05, 0.3, 0.6);
    const std::string p = devices_walk_dir() + "/m.json";
    std::ofstream(p) << gonio::brdf::model_to_json(m);
    return p;
}

/// Simulated controllers on 127.0.0.1, an ephemeral port: unit 1 at 7 deg and unit 2 at 3 deg,
/// the generic register map, 5 simulated seconds per second.
class Controllers {
  public:
    Controllers() {
        auto p = gonio::devices::load_axis_profile("generic");
        EXPECT_TRUE(p) << p.error().message;
        for (const auto& [unit, deg] : {std::pair<int, double>{1, 7}, {2, 3}}) {
            gonio::sim::MotorSimConfig cfg;
            cfg.time_scale = 5;
            cfg.initial_deg = deg;
            EXPECT_TRUE(server_.add_unit(unit, *p, cfg));
        }
        EXPECT_TRUE(server_.start());
    }
    std::string address() const { return server_.address(); }

  private:
    gonio::sim::MotorControllerServer server_;
};

/// `line` with every "@BUS@" replaced by `address`.
std::string with_bus(std::string line, const std::string& address) {
    for (std::size_t at; (at = line.find("@BUS@")) != std::string::npos;) {
        line.replace(at, 5, address);
    }
    return line;
}

TEST(HelpWalk, AxisEveryOptionHonouredOrRefused) {
    // A fresh controller for every run that names @BUS@ (the runs move stages and arm faults);
    // the commands of a proof's `then` list, marked THEN, talk to the controller of the run
    // before them.
    std::unique_ptr<Controllers> bus;
    auto run_line = [&bus](const std::string& line) {
        std::string l = line;
        if (const std::size_t at = l.find(" THEN"); at != std::string::npos) {
            l.erase(at, 5);
        } else if (l.find("@BUS@") != std::string::npos) {
            bus = std::make_unique<Controllers>();
        }
        return with_bus(l, bus ? bus->address() : "tcp://127.0.0.1:1");
    };
    // The served controllers, probed through their printed address.
    auto served_status = [](int unit, const std::string& extra) {
        return [unit, extra](const std::string& printed) {
            const std::string address = word_after(printed, "serving ");
            // Quoted: an RTU address holds '?' and '&'.
            const CliRun r = run_gonio("axis --connect '" + address + "' --unit " +
                                       std::to_string(unit) + " " + extra);
            return std::to_string(r.status) + "\n" + r.out;
        };
    };
    const std::string x = "axis --connect @BUS@";
    auto then = [](const std::string& l) { return l + " THEN"; };
    std::vector<Proof> table = {
        {"--connect", x + " status", "axis --connect tcp://127.0.0.1:1 status"},
        {"--unit", x + " status", x + " --unit 2 status"},
        {"--profile", x + " status", x + " --profile oriental-az status"},
        {"--name", x + " status", x + " --name arm status"},
        {"--min", x + " move 10", x + " --min 20 move 10"},
        {"--max", x + " move 10", x + " --max 5 move 10"},
        // At 0.01 deg/s (or 0.001 deg/s^2) 10 degrees take minutes: the deadline passes.
        {"--speed",
         x + " move 10 --timeout-ms 3000",
         x + " --speed 0.01 move 10 --timeout-ms 3000"},
        {"--accel",
         x + " move 10 --timeout-ms 3000",
         x + " --accel 0.001 move 10 --timeout-ms 3000"},
        {"--timeout-ms", x + " move 10", x + " move 10 --timeout-ms 1"},
        {"--timeout-ms", x + " home", x + " home --timeout-ms 1"},
    };
    // Each action refuses the options it does not use, naming them.
    const std::vector<std::pair<std::string, std::vector<std::string>>> uses = {
        {"--connect", {"status", "home", "stop", "reset", "move", "fault"}},
        {"--unit", {"status", "home", "stop", "reset", "move", "fault"}},
        {"--profile", {"status", "home", "stop", "reset", "move", "serve"}},
        {"--name", {"status", "home", "stop", "reset", "move"}},
        {"--min", {"move"}},
        {"--max", {"move"}},
        {"--speed", {"move"}},
        {"--accel", {"move"}},
        {"--timeout-ms", {"home", "move"}},
    };
    const std::vector<std::pair<std::string, std::string>> actions = {{"status", "status"},
                                                                      {"home", "home"},
                                                                      {"stop", "stop"},
                                                                      {"reset", "reset"},
                                                                      {"move", "move 10"},
                                                                      {"fault", "fault drop"},
                                                                      {"serve", "serve"}};
    const std::vector<std::pair<std::string, std::string>> values = {{"--connect", "@BUS@"},
                                                                     {"--unit", "2"},
                                                                     {"--profile", "generic"},
                                                                     {"--name", "arm"},
                                                                     {"--min", "-5"},
                                                                     {"--max", "5"},
                                                                     {"--speed", "5"},
                                                                     {"--accel", "5"},
                                                                     {"--timeout-ms", "500"}};
    for (const auto& [option, used_by] : uses) {
        std::string value;
        for (const auto& [o, v] : values) {
            if (o == option) {
                value = v;
            }
        }
        for (const auto& [action, args] : actions) {
            if (std::find(used_by.begin(), used_by.end(), action) != used_by.end()) {
                continue;
            }
            const std::string connect =
                action == "serve" || option == "--connect" ? "" : " --connect @BUS@";
            table.push_back(
                {option, "axis" + connect + " " + option + " " + value + " " + args, ""});
        }
    }
    // The register map a served controller speaks.
    table.push_back({"--profile",
                     "axis --profile generic serve",
                     "axis --profile oriental-az serve",
                     "",
                     "",
                     {},
                     "serving ",
                     served_status(1, "--profile generic status")});
    prove("axis", table, run_line);

    prove("axis move", {{"deg", x + " move 10", x + " move 20"}}, run_line);

    // A fault shows in the requests after it.
    const std::string f = x + " fault";
    prove("axis fault",
          {
              {"kind",
               f + " exception --code 2",
               f + " alarm --code 2",
               "",
               "",
               {then(x + " status")}},
              // One request answered with the exception, or two.
              {"--count",
               f + " exception --code 2 --count 1",
               f + " exception --code 2 --count 2",
               "",
               "",
               {then(x + " status"), then(x + " status")}},
              // A 2 s delay of every reply outlasts the profile's 300 ms response time and its
              // retries; a 1 ms delay does not.
              {"--delay-ms",
               f + " delay --count 20 --delay-ms 1",
               f + " delay --count 20 --delay-ms 2000",
               "",
               "",
               {then(x + " status")}},
              {"--code",
               f + " exception --code 2",
               f + " exception --code 3",
               "",
               "",
               {then(x + " status")}},
              {"--code",
               f + " alarm --code 48",
               f + " alarm --code 49",
               "",
               "",
               {then(x + " move 30"), then(x + " status")}},
              {"--fraction",
               f + " alarm --fraction 0.2",
               f + " alarm --fraction 0.8",
               "",
               "",
               {then(x + " move 30"), then(x + " status")}},
              // Each option is refused by the kinds that do not use it.
              {"--count", f + " alarm --count 2", ""},
              {"--count", f + " stall --count 2", ""},
              {"--delay-ms", f + " drop --delay-ms 5", ""},
              {"--delay-ms", f + " exception --delay-ms 5", ""},
              {"--delay-ms", f + " alarm --delay-ms 5", ""},
              {"--delay-ms", f + " stall --delay-ms 5", ""},
              {"--code", f + " delay --code 3", ""},
              {"--code", f + " drop --code 3", ""},
              {"--code", f + " stall --code 3", ""},
              {"--fraction", f + " delay --fraction 0.3", ""},
              {"--fraction", f + " drop --fraction 0.3", ""},
              {"--fraction", f + " exception --fraction 0.3", ""},
          },
          run_line);

    // The served shutter, opened and read back through coil 5 of unit 3: a server whose shutter
    // is another coil answers with an exception (illegal data address).
    auto shutter_coil_5 = [](const std::string& printed) {
        auto light = gonio::devices::open_modbus_light(word_after(printed, "serving "), 3, 5);
        if (!light) {
            return light.error().message;
        }
        if (auto r = (*light)->set_shutter_open(true); !r) {
            return "open: " + r.error().message;
        }
        auto open = (*light)->shutter_open();
        return open ? std::string(*open ? "coil 5 open" : "coil 5 closed")
                    : "read: " + open.error().message;
    };
    const BusyPort busy;
    ASSERT_GT(busy.port(), 0);
    const std::string s = "axis serve";
    const std::string ready = "serving ";
    prove("axis serve",
          {
              {"--units",
               s + " --units 1",
               s + " --units 1,2",
               "",
               "",
               {},
               ready,
               served_status(2, "status")},
              {"--rtu", s, s + " --rtu", "", "", {}, ready, served_status(1, "status")},
              // The port in use: the server says so and stops; port 0 takes a free one.
              {"--port",
               s + " --port " + std::to_string(busy.port()),
               s,
               "",
               "",
               {},
               ready,
               served_status(1, "status")},
              {"--port", s + " --rtu --port 5020", ""},
              // 1000 simulated seconds per second end a 10-degree move at once; 0.001 do not
              // within the deadline.
              {"--time-scale",
               s + " --time-scale 1000",
               s + " --time-scale 0.001",
               "",
               "",
               {},
               ready,
               served_status(1, "move 10 --timeout-ms 3000")},
              {"--shutter-unit",
               s,
               s + " --shutter-unit 3",
               "",
               "",
               {},
               ready,
               served_status(3, "status"),
               false,
               0,
               true},
              {"--shutter-coil",
               s + " --shutter-unit 3",
               s + " --shutter-unit 3 --shutter-coil 5",
               "",
               "",
               {},
               ready,
               shutter_coil_5,
               false,
               0,
               true},
              {"--shutter-coil", s + " --shutter-coil 5", ""},
          });
    for (const char* action : {"status", "home", "stop", "reset"}) {
        gonio::testing::prove_no_options(std::string("axis ") + action + " --connect " +
                                         "tcp://127.0.0.1:1");
    }
}

TEST(HelpWalk, CameraEveryOptionHonouredOrRefused) {
    const std::string d = devices_walk_dir();
    const std::string m = devices_walk_model();
    const std::string exr = d + "/f.exr";
    // The embedded simulated camera, small frames.
    const std::string c = "camera --connect sim capture --width 64 --height 48";
    prove("camera",
          {
              {"--connect", "camera --connect sim info", "camera --connect gige://127.2.0.1 info"},
              {"--connect", "camera --connect sim serve", ""},
          });
    prove(
        "camera capture",
        {
            // The frame goes to the named file.
            {"output", c + " " + d + "/a.exr", c + " " + d + "/b.exr", "", d + "/a.exr"},
            {"--exposure-us", c + " " + exr, c + " --exposure-us 2500 " + exr, "", exr},
            {"--gain", c + " " + exr, c + " --gain 4 " + exr, "", exr},
            {"--camera-gain", c + " " + exr, c + " --camera-gain 6 " + exr, "", exr},
            {"--camera-gain", c + " --gain 2 --camera-gain 6 " + exr, ""},
            {"--format", c + " " + exr, c + " --format Mono8 " + exr, "", exr},
            {"--roi", c + " " + exr, c + " --roi 8,8,32,24 " + exr, "", exr},
            // A 2048 x 2048 frame takes longer than 1 ms to render and send (its noise alone takes
            // several), and far less than a minute however loaded the machine.
            {"--timeout-ms",
             "camera --connect sim capture --width 2048 --height 2048 --timeout-ms 60000 " + exr,
             "camera --connect sim capture --width 2048 --height 2048 --timeout-ms 1 " + exr},
            {"--width",
             "camera --connect sim capture --height 48 --width 64 " + exr,
             "camera --connect sim capture --height 48 --width 80 " + exr,
             "",
             exr},
            {"--height",
             "camera --connect sim capture --width 64 --height 48 " + exr,
             "camera --connect sim capture --width 64 --height 40 " + exr,
             "",
             exr},
            {"--seed", c + " " + exr, c + " --seed 9 " + exr, "", exr},
            {"--theta-i-deg", c + " " + exr, c + " --theta-i-deg 60 " + exr, "", exr},
            {"--phi-i-deg", c + " " + exr, c + " --phi-i-deg 90 " + exr, "", exr},
            {"--theta-o-deg", c + " " + exr, c + " --theta-o-deg 10 " + exr, "", exr},
            {"--phi-o-deg", c + " " + exr, c + " --phi-o-deg 90 " + exr, "", exr},
            {"--irradiance", c + " " + exr, c + " --irradiance 0.5 " + exr, "", exr},
            // The simulated camera's set-up means nothing to another camera.
            {"--width", "camera --connect gige://127.2.0.1 capture --width 80 " + exr, ""},
            {"--height", "camera --connect gige://127.2.0.1 capture --height 80 " + exr, ""},
            {"--seed", "camera --connect gige://127.2.0.1 capture --seed 3 " + exr, ""},
            {"--theta-i-deg",
             "camera --connect gige://127.2.0.1 capture --theta-i-deg 3 " + exr,
             ""},
            {"--phi-i-deg", "camera --connect gige://127.2.0.1 capture --phi-i-deg 3 " + exr, ""},
            {"--theta-o-deg",
             "camera --connect gige://127.2.0.1 capture --theta-o-deg 3 " + exr,
             ""},
            {"--phi-o-deg", "camera --connect gige://127.2.0.1 capture --phi-o-deg 3 " + exr, ""},
            {"--irradiance", "camera --connect gige://127.2.0.1 capture --irradiance 3 " + exr, ""},
        });
    gonio::testing::prove_no_options("camera --connect sim info");

    // The served camera, probed by another process: its description, or one captured frame.
    const std::string ready = "gige://";
    auto info = [](const std::string& printed) {
        const CliRun r = run_gonio("camera --connect " + word_after(printed, "") + " info");
        return r.out;
    };
    auto frame = [exr](const std::string& printed) {
        const CliRun r =
            run_gonio("camera --connect " + word_after(printed, "") + " capture " + exr);
        return r.out + take_written(exr);
    };
    // Whether a camera answers at 127.77.3.9 (addresses are compared as placeholders, so the
    // printed one cannot show where the camera went).
    auto info_at_fixed_address = [](const std::string&) {
        const CliRun r = run_gonio("camera --connect gige://127.77.3.9 info");
        return std::to_string(r.status) + "\n" + r.out;
    };
    const std::string s = "camera serve --ip auto --width 64 --height 48";
    const std::string sw = "camera serve --ip auto --height 48";
    const std::string sh = "camera serve --ip auto --width 64";
    prove("camera serve",
          {
              {"--ip",
               "camera serve --ip auto",
               "camera serve --ip 127.77.3.9",
               "",
               "",
               {},
               ready,
               info_at_fixed_address,
               false,
               0,
               true},
              {"--exposure-abs", s, s + " --exposure-abs", "", "", {}, ready, info},
              {"--material", s, s + " --material gold", "", "", {}, ready, frame},
              {"--brdf", s, s + " --brdf " + m, "", "", {}, ready, frame},
              {"--brdf", s + " --brdf " + m + " --material gold", ""},
              {"--width", sw + " --width 64", sw + " --width 80", "", "", {}, ready, info},
              {"--height", sh + " --height 48", sh + " --height 40", "", "", {}, ready, info},
              {"--seed", s, s + " --seed 9", "", "", {}, ready, frame},
              {"--theta-i-deg", s, s + " --theta-i-deg 60", "", "", {}, ready, frame},
              {"--phi-i-deg", s, s + " --phi-i-deg 90", "", "", {}, ready, frame},
              {"--theta-o-deg", s, s + " --theta-o-deg 10", "", "", {}, ready, frame},
              {"--phi-o-deg", s, s + " --phi-o-deg 90", "", "", {}, ready, frame},
              {"--irradiance", s, s + " --irradiance 0.5", "", "", {}, ready, frame},
          });
}

TEST(HelpWalk, SimEveryOptionHonouredOrRefused) {
    const std::string d = devices_walk_dir();
    const std::string m = devices_walk_model();
    const std::string exr = d + "/sim.exr";
    // A rig description whose simulated sample is gold (the shipped one mounts red plastic).
    const std::string config = d + "/gold.json";
    {
        std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
        std::stringstream ss;
        ss << in.rdbuf();
        std::string text = ss.str();
        const std::size_t at = text.find("\"material\": \"red-plastic\"");
        ASSERT_NE(at, std::string::npos);
        text.replace(at, 25, "\"material\": \"gold\"");
        std::ofstream(config) << text;
    }
    const std::string ready = "Ctrl-C stops";
    auto camera_info = [](const std::string& printed) {
        return run_gonio("camera --connect " + word_after(printed, "camera: ") + " info").out;
    };
    auto frame = [exr](const std::string& printed) {
        const CliRun r = run_gonio("camera --connect " + word_after(printed, "camera: ") +
                                   " capture --roi 0,0,64,48 " + exr);
        return r.out + take_written(exr);
    };
    auto move = [](const std::string& printed) {
        const CliRun r = run_gonio("axis --connect " + word_after(printed, "motors: ") +
                                   " --unit 1 move 10 --timeout-ms 3000");
        return std::to_string(r.status) + "\n" + r.out;
    };
    auto camera_at_fixed_address = [](const std::string&) {
        const CliRun r = run_gonio("camera --connect gige://127.77.4.2 info");
        return std::to_string(r.status) + "\n" + r.out;
    };
    const std::string rig_out = d + "/served.json";
    auto served_rig = [rig_out](const std::string&) { return take_written(rig_out); };
    const std::string s = "sim --camera-ip auto";
    prove("sim",
          {
              {"--config", s, s + " --config " + config, "", "", {}, ready, frame, false, 0, true},
              {"--material", s, s + " --material gold", "", "", {}, ready, frame},
              {"--brdf", s, s + " --brdf " + m, "", "", {}, ready, frame},
              {"--brdf", s + " --brdf " + m + " --material gold", ""},
              {"--time-scale",
               s + " --time-scale 1000",
               s + " --time-scale 0.001",
               "",
               "",
               {},
               ready,
               move},
              {"--time-scale", s + " --time-scale 0", ""},
              {"--seed", s + " --seed 1", s + " --seed 2", "", "", {}, ready, frame},
              {"--seed", s + " --seed 0", ""},
              {"--camera-ip",
               "sim --camera-ip auto",
               "sim --camera-ip 127.77.4.2",
               "",
               "",
               {},
               ready,
               camera_at_fixed_address,
               false,
               0,
               true},
              {"--exposure-abs", s, s + " --exposure-abs", "", "", {}, ready, camera_info},
              {"--rig-out", s, s + " --rig-out " + rig_out, "", "", {}, ready, served_rig},
          });
}

TEST(HelpWalk, DevicesListsNoOptionAndRefusesAny) {
    gonio::testing::prove_no_options("devices");
}

}  // namespace
