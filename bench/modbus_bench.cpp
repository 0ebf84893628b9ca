// Modbus round-trip latency against the simulated controllers (TCP on loopback, RTU on a
// pseudo-terminal), complete moves per second at a large time scale, and bus polls per second
// beside move-completion latency under the bus scheduler's poll budget.
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
    // A 10 degree move at 20 deg/s and 40 deg/s^2 lasts d/v + v/a = 0.5 + 0.5 = 1.0 s of
    // simulated time (it just reaches full speed: d = v^2/a).
    state.counters["sim_move_s"] = 1.0;
}
BENCHMARK(BM_MovesPerSecond)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond)->UseRealTime();

/// Bus polls per second beside move-completion latency, for a poll budget of range(0) polls/s
/// (0 = the old behaviour: a status poll every poll_ms, no budget, no back-off). A 10 degree move
/// at 20 deg/s and 40 deg/s^2 lasts d/v + v/a = 1.0 s, in real time here (time scale 1), so the
/// completion latency is the wall time of start + wait beyond 1.0 s.
void BM_PollBudget(benchmark::State& state) {
    auto profile = gonio::devices::load_axis_profile("oriental-az");
    if (!profile) {
        state.SkipWithError(profile.error().message.c_str());
        return;
    }
    gonio::sim::MotorControllerServer server;
    gonio::sim::MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.time_scale = 1;
    server.add_unit(1, *profile, cfg);
    gonio::sim::ServerOptions so;
    so.log = nullptr;
    if (auto r = server.start(so); !r) {
        state.SkipWithError(r.error().message.c_str());
        return;
    }
    const int budget = static_cast<int>(state.range(0));
    auto addr = gonio::devices::parse_bus_address(
        server.address() + "?poll_rate=" + std::to_string(budget > 0 ? budget : 100000));
    auto bus = gonio::devices::ModbusBus::open(*addr);
    if (!bus) {
        state.SkipWithError(bus.error().message.c_str());
        return;
    }
    gonio::devices::AxisOptions opt;
    if (budget == 0) {
        opt.max_poll_interval_ms = profile->timeouts.poll_ms;  // No back-off.
    }
    gonio::devices::ModbusAxis axis(*bus,
                                    1,
                                    *profile,
                                    "bench",
                                    gonio::devices::SoftLimits{-90, 90},
                                    gonio::devices::Motion{20, 40, 0},
                                    opt);
    const double move_s = 1.0 / cfg.time_scale;
    double target = 10;
    std::vector<double> latency_ms;
    double wall_s = 0;
    const auto polls0 = (*bus)->stats().polls;
    double max_err = 0;
    for (auto _ : state) {
        const auto t0 = std::chrono::steady_clock::now();
        if (auto r = axis.move_to(target, 60s); !r) {
            state.SkipWithError(r.error().message.c_str());
            return;
        }
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        wall_s += s;
        latency_ms.push_back(1e3 * (s - move_s));
        max_err = std::max(max_err, std::fabs(server.position_deg(1) - target));
        target = target == 10 ? 0 : 10;
    }
    std::sort(latency_ms.begin(), latency_ms.end());
    const double polls = static_cast<double>((*bus)->stats().polls - polls0);
    state.counters["polls_per_s"] = polls / wall_s;
    state.counters["polls_per_move"] = polls / static_cast<double>(latency_ms.size());
    state.counters["latency_median_ms"] = latency_ms[latency_ms.size() / 2];
    state.counters["latency_max_ms"] = latency_ms.back();
    state.counters["max_abs_err_deg"] = max_err;
}
BENCHMARK(BM_PollBudget)
    ->Arg(0)
    ->Arg(200)
    ->Arg(50)
    ->Arg(20)
    ->Iterations(6)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
