// Modbus round-trip latency against the simulated controllers (TCP on loopback, RTU on a
// pseudo-terminal), and complete moves per second at a large time scale.
//
//   gonio_modbus_bench --benchmark_filter=. --benchmark_counters_tabular=true

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/motor_controller_server.h"

namespace {

using namespace std::chrono_literals;

void round_trip(benchmark::State& state, gonio::sim::Transport transport) {
    auto profile = gonio::devices::load_axis_profile("oriental-az");
    if (!profile) {
        state.SkipWithError(profile.error().message.c_str());
        return;
    }
    gonio::sim::MotorControllerServer server;
    gonio::sim::MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.initial_deg = 12.34;
    server.add_unit(1, *profile, cfg);
    gonio::sim::ServerOptions so;
    so.transport = transport;
    if (auto r = server.start(so); !r) {
        state.SkipWithError(r.error().message.c_str());
        return;
    }
    auto bus =
        gonio::devices::ModbusBus::open(*gonio::devices::parse_bus_address(server.address()));
    if (!bus) {
        state.SkipWithError(bus.error().message.c_str());
        return;
    }
    const int wire = *gonio::devices::wire_address(*profile, profile->position.address);
    const std::int64_t expected = gonio::devices::degrees_to_steps(*profile, 12.34);
    gonio::devices::RequestPolicy pol;
    std::vector<double> us;
    us.reserve(100000);
    std::int64_t wrong = 0;
    for (auto _ : state) {
        const auto t0 = std::chrono::steady_clock::now();
        auto w = (*bus)->read_registers(1, wire, 2, pol, "position");
        const auto t1 = std::chrono::steady_clock::now();
        if (!w) {
            state.SkipWithError(w.error().message.c_str());
            return;
        }
        if (gonio::devices::decode_value(w->data(), 32, true, profile->word_order) != expected) {
            ++wrong;
        }
        us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    }
    std::sort(us.begin(), us.end());
    state.counters["median_us"] = us[us.size() / 2];
    state.counters["p99_us"] = us[std::min(us.size() - 1, us.size() * 99 / 100)];
    state.counters["wrong_values"] = static_cast<double>(wrong);
}

void BM_ModbusRoundTripTcp(benchmark::State& state) {
    round_trip(state, gonio::sim::Transport::kTcp);
}
void BM_ModbusRoundTripRtuPty(benchmark::State& state) {
    round_trip(state, gonio::sim::Transport::kRtu);
}
BENCHMARK(BM_ModbusRoundTripTcp)->Unit(benchmark::kMicrosecond)->MinTime(1.0);
BENCHMARK(BM_ModbusRoundTripRtuPty)->Unit(benchmark::kMicrosecond)->MinTime(1.0);

/// Complete moves (start, poll until in position, read back) of 10 degrees at 20 deg/s with the
/// simulator running `range(0)` times faster than real time.
void BM_MovesPerSecond(benchmark::State& state) {
    auto profile = gonio::devices::load_axis_profile("oriental-az");
    if (!profile) {
        state.SkipWithError(profile.error().message.c_str());
        return;
    }
    gonio::sim::MotorControllerServer server;
    gonio::sim::MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.time_scale = static_cast<double>(state.range(0));
    server.add_unit(1, *profile, cfg);
    if (auto r = server.start(); !r) {
        state.SkipWithError(r.error().message.c_str());
        return;
    }
    gonio::devices::Motion m;
    m.speed_deg_per_s = 20;
    m.accel_deg_per_s2 = 40;
    auto axis = gonio::devices::open_axis(
        "bench", server.address(), 1, "oriental-az", gonio::devices::SoftLimits{-90, 90}, m);
    if (!axis) {
        state.SkipWithError(axis.error().message.c_str());
        return;
    }
    double target = 10;
    double max_err = 0;
    for (auto _ : state) {
        if (auto r = (*axis)->move_to(target, 60s); !r) {
            state.SkipWithError(r.error().message.c_str());
            return;
        }
        max_err = std::max(max_err, std::fabs(server.position_deg(1) - target));
        target = target == 10 ? 0 : 10;
    }
    state.counters["moves_per_s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["max_abs_err_deg"] = max_err;
    // A 10 degree move at 20 deg/s and 40 deg/s^2 lasts 0.5 + 1.0 = 1.5 s of simulated time.
    state.counters["sim_move_s"] = 1.5;
}
BENCHMARK(BM_MovesPerSecond)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
