// gonio axis: drive one Modbus axis by hand (status, home, move, stop, reset, fault injection), or
// serve simulated controllers for manual tests.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/motor_controller_server.h"
#include "option_checks.h"

namespace {

struct AxisCliOptions {
    std::string connect;
    int unit = 1;
    std::string profile = "generic";
    std::string name = "axis";
    double min_deg = -180;
    double max_deg = 180;
    double speed = 20;
    double accel = 40;
    int timeout_ms = 60000;
    double target_deg = 0;
    // fault
    std::string fault_kind;
    int fault_count = 1;
    int fault_delay_ms = 1000;
    int fault_code = 0;
    double fault_fraction = 0.5;
    // serve
    std::vector<int> units{1};
    bool rtu = false;
    int port = 0;
    double time_scale = 1;
    int shutter_unit = 0;
    int shutter_coil = 0;
};

/// Which actions use each option of `gonio axis`; an option given to an action that does not use
/// it is refused (exit 2) rather than dropped.
struct OptionUse {
    const char* option;
    std::vector<std::string> actions;
};

const std::vector<OptionUse>& axis_option_uses() {
    static const std::vector<OptionUse> uses = {
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
    return uses;
}

/// Which fault kinds use each option of `gonio axis fault`.
const std::vector<OptionUse>& fault_option_uses() {
    static const std::vector<OptionUse> uses = {
        {"--count", {"delay", "drop", "exception"}},
        {"--delay-ms", {"delay"}},
        {"--code", {"exception", "alarm"}},
        {"--fraction", {"alarm", "stall"}},
    };
    return uses;
}

std::string join(const std::vector<std::string>& v) {
    std::string out;
    for (std::size_t i = 0; i < v.size(); ++i) {
        out += (i == 0 ? "" : i + 1 == v.size() ? " and " : ", ") + v[i];
    }
    return out;
}

/// The message for the first option given on `app` that `mode` does not use, or "".
std::string unused_option(const CLI::App& app,
                          const std::vector<OptionUse>& uses,
                          const std::string& mode,
                          const char* what) {
    for (const OptionUse& u : uses) {
        if (app.count(u.option) > 0 &&
            std::find(u.actions.begin(), u.actions.end(), mode) == u.actions.end()) {
            return std::string(u.option) + " is not used by " + what + mode + " (only by " +
                   join(u.actions) + ")";
        }
    }
    return {};
}

int fail(const std::string& msg) {
    std::fprintf(stderr, "gonio axis: %s\n", msg.c_str());
    return 1;
}

gonio::Expected<std::unique_ptr<gonio::devices::Axis>> open(const AxisCliOptions& o) {
    if (o.connect.empty()) {
        return gonio::make_error(
            "--connect ADDRESS is required (tcp://HOST:PORT or rtu:DEVICE?baud=N)");
    }
    gonio::devices::Motion m;
    m.speed_deg_per_s = o.speed;
    m.accel_deg_per_s2 = o.accel;
    return gonio::devices::open_axis(
        o.name, o.connect, o.unit, o.profile, gonio::devices::SoftLimits{o.min_deg, o.max_deg}, m);
}

int print_status(gonio::devices::Axis& axis, int unit) {
    auto st = axis.status();
    if (!st) {
        return fail(st.error().message);
    }
    std::printf("axis \"%s\" unit %d: %s, position %.4f deg, homed %s",
                axis.name().c_str(),
                unit,
                gonio::devices::to_string(st->state),
                st->position_deg,
                st->homed ? "yes" : "no");
    if (st->state == gonio::devices::AxisState::kAlarm) {
        std::printf(
            ", alarm code %d (0x%X)", st->alarm_code, static_cast<unsigned>(st->alarm_code));
    }
    std::printf("\n");
    return 0;
}

int run_axis(const AxisCliOptions& o, const std::string& action) {
    auto axis = open(o);
    if (!axis) {
        return fail(axis.error().message);
    }
    gonio::devices::Axis& a = **axis;
    const auto timeout = std::chrono::milliseconds(o.timeout_ms);
    gonio::Expected<void> r;
    if (action == "home") {
        r = a.home(timeout);
    } else if (action == "move") {
        r = a.move_to(o.target_deg, timeout);
    } else if (action == "stop") {
        r = a.stop();
    } else if (action == "reset") {
        r = a.reset_alarm();
    }
    if (!r) {
        return fail(r.error().message);
    }
    return print_status(a, o.unit);
}

int run_fault(const AxisCliOptions& o) {
    auto kind = gonio::sim::parse_fault_kind(o.fault_kind);
    if (!kind) {
        return fail(kind.error().message);
    }
    auto addr = gonio::devices::parse_bus_address(o.connect);
    if (!addr) {
        return fail(addr.error().message);
    }
    auto bus = gonio::devices::ModbusBus::open(*addr);
    if (!bus) {
        return fail(bus.error().message);
    }
    gonio::sim::Fault f;
    f.kind = *kind;
    f.unit = o.unit;
    f.count = o.fault_count;
    f.delay = std::chrono::milliseconds(o.fault_delay_ms);
    if (f.kind == gonio::sim::FaultKind::kException) {
        f.exception_code = o.fault_code > 0 ? o.fault_code : 6;
    } else {
        f.alarm_code = o.fault_code;
    }
    f.fraction = o.fault_fraction;
    gonio::devices::RequestPolicy pol;
    auto w = (*bus)->write_registers(
        o.unit, gonio::sim::kFaultRegister, gonio::sim::fault_registers(f), pol, "fault registers");
    if (!w) {
        return fail(w.error().message);
    }
    std::printf("fault \"%s\" armed on unit %d\n", o.fault_kind.c_str(), o.unit);
    return 0;
}

int run_serve(const AxisCliOptions& o) {
    auto profile = gonio::devices::load_axis_profile(o.profile);
    if (!profile) {
        return fail(profile.error().message);
    }
    gonio::sim::MotorControllerServer server;
    gonio::sim::MotorSimConfig cfg;
    cfg.time_scale = o.time_scale;
    for (int u : o.units) {
        if (auto r = server.add_unit(u, *profile, cfg); !r) {
            return fail(r.error().message);
        }
    }
    if (o.shutter_unit > 0) {
        if (auto r = server.add_shutter(o.shutter_unit, o.shutter_coil); !r) {
            return fail(r.error().message);
        }
    }
    // Block the stop signals before the server thread starts, then wait for one of them.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    gonio::sim::ServerOptions so;
    so.transport = o.rtu ? gonio::sim::Transport::kRtu : gonio::sim::Transport::kTcp;
    so.port = o.port;
    if (auto r = server.start(so); !r) {
        return fail(r.error().message);
    }
    std::ostringstream units;
    for (size_t i = 0; i < o.units.size(); ++i) {
        units << (i ? "," : "") << o.units[i];
    }
    std::printf("serving %s units %s profile %s time-scale %g",
                server.address().c_str(),
                units.str().c_str(),
                profile->name.c_str(),
                o.time_scale);
    if (o.shutter_unit > 0) {
        std::printf(" shutter unit %d coil %d", o.shutter_unit, o.shutter_coil);
    }
    std::printf("\n");
    std::fflush(stdout);
    int sig = 0;
    sigwait(&set, &sig);
    server.stop();
    std::printf("stopped (signal %d)\n", sig);
    return 0;
}

}  // namespace

GONIO_COMMAND(axis) {
    auto* cmd =
        app.add_subcommand("axis", "drive one Modbus axis by hand, or serve simulated ones");
    auto o = std::make_shared<AxisCliOptions>();
    cmd->add_option(
        "--connect", o->connect, "bus address: tcp://HOST:PORT or rtu:DEVICE?baud=N&parity=N");
    cmd->add_option("--unit", o->unit, "Modbus unit id of the drive")->check(CLI::Range(1, 247));
    cmd->add_option("--profile", o->profile, "register-map profile name or JSON path");
    cmd->add_option("--name", o->name, "axis name used in messages");
    cmd->add_option("--min", o->min_deg, "soft limit, degrees");
    cmd->add_option("--max", o->max_deg, "soft limit, degrees");
    cmd->add_option("--speed", o->speed, "speed, deg/s");
    cmd->add_option("--accel", o->accel, "acceleration, deg/s^2");
    cmd->add_option("--timeout-ms", o->timeout_ms, "deadline for home/move");
    cmd->require_subcommand(1);
    auto action = std::make_shared<std::string>();
    const std::pair<const char*, const char*> simple[] = {
        {"status", "print state, position, homed flag and alarm code"},
        {"home", "run the drive's homing and wait for its homed flag"},
        {"stop", "decelerate to a stop"},
        {"reset", "clear a drive alarm"}};
    for (const auto& entry : simple) {
        const char* name = entry.first;
        auto* sub = cmd->add_subcommand(name, entry.second);
        sub->fallthrough();
        sub->callback([action, name] { *action = name; });
    }
    auto* move = cmd->add_subcommand("move", "absolute move, waiting for in-position");
    move->fallthrough();
    move->add_option("deg", o->target_deg, "target, degrees")->required();
    move->callback([action] { *action = "move"; });
    auto* fault = cmd->add_subcommand("fault", "arm a fault on a simulated controller");
    fault->fallthrough();
    fault->add_option("kind", o->fault_kind, "delay, drop, exception, alarm or stall")->required();
    fault->add_option("--count", o->fault_count, "requests affected (delay, drop, exception)");
    fault->add_option("--delay-ms", o->fault_delay_ms, "reply delay");
    fault->add_option("--code", o->fault_code, "exception or alarm code");
    fault->add_option("--fraction", o->fault_fraction, "fraction of the next move (alarm, stall)");
    fault->callback([action] { *action = "fault"; });
    auto* serve = cmd->add_subcommand("serve", "serve simulated controllers until Ctrl-C");
    serve->fallthrough();
    serve->add_option("--units", o->units, "unit ids")->delimiter(',');
    serve->add_flag("--rtu", o->rtu, "serve Modbus RTU on a pseudo-terminal instead of TCP");
    serve->add_option("--port", o->port, "TCP port (0 = ephemeral)");
    serve->add_option("--time-scale", o->time_scale, "simulated seconds per second")
        ->check(CLI::PositiveNumber);
    serve->add_option("--shutter-unit", o->shutter_unit, "unit carrying a shutter coil");
    serve->add_option("--shutter-coil", o->shutter_coil, "shutter coil address");
    serve->callback([action] { *action = "serve"; });
    return [o, action, cmd, fault, serve]() -> int {
        // An option the chosen action would drop is a usage error naming it.
        const std::string where = "axis " + *action;
        if (std::string m = unused_option(*cmd, axis_option_uses(), *action, ""); !m.empty()) {
            return gonio::tools::usage_error(where.c_str(), m);
        }
        if (*action == "fault" && gonio::sim::parse_fault_kind(o->fault_kind)) {
            if (std::string m =
                    unused_option(*fault, fault_option_uses(), o->fault_kind, "the fault kind ");
                !m.empty()) {
                return gonio::tools::usage_error(where.c_str(), m);
            }
        }
        if (*action == "serve") {
            if (o->rtu && serve->count("--port") > 0) {
                return gonio::tools::usage_error(
                    where.c_str(), "--port is the TCP port; --rtu serves on a pseudo-terminal");
            }
            if (serve->count("--shutter-coil") > 0 && o->shutter_unit <= 0) {
                return gonio::tools::usage_error(
                    where.c_str(), "--shutter-coil needs --shutter-unit (the unit carrying it)");
            }
        }
        if (*action == "serve") {
            return run_serve(*o);
        }
        if (*action == "fault") {
            return run_fault(*o);
        }
        if (*action == "status") {
            auto axis = open(*o);
            if (!axis) {
                return fail(axis.error().message);
            }
            return print_status(**axis, o->unit);
        }
        return run_axis(*o, *action);
    };
}
