// Tables: MERL load time of a full-size file, lookups per second (nearest, trilinear) with their
// error against the model the table was made from, model -> table conversion, table sampling.
//
//   cmake -S . -B build -DGONIO_BUILD_BENCH=ON && cmake --build build --target gonio_table_bench
//   build/bench/gonio_table_bench

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/table.h"
#include "gonio/brdf/table_sampling.h"

namespace {

using namespace gonio::brdf;
using gonio::Expected;
namespace fs = std::filesystem;

ModelD bench_model() {
    ModelD m;
    m.diffuse = Rgbd(0.25, 0.2, 0.15);
    Lobe<double> l;
    l.alpha_x = l.alpha_y = 0.25;
    l.shadowing = Shadowing::kSmithCorrelated;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd(0.9, 0.7, 0.4);
    m.lobes.push_back(l);
    return m;
}

const TabulatedBrdf& full_table() {
    static const TabulatedBrdf table = [] {
        TabulateOptions o;
        o.threads = 2;
        return tabulate(AnalyticBrdf(bench_model()), o);
    }();
    return table;
}

// The full-size file, written once into the temporary directory (removed at exit).
const std::string& full_file() {
    static const std::string path = [] {
        const fs::path p = fs::temp_directory_path() /
                           ("gonio_table_bench_" + std::to_string(::getpid()) + ".binary");
        if (!write_merl(p.string(), full_table())) {
            std::abort();
        }
        std::atexit([] { fs::remove(full_file()); });
        return p.string();
    }();
    return path;
}

void BM_MerlLoad(benchmark::State& state) {
    const std::string& path = full_file();
    std::size_t mismatches = 0;
    for (auto _ : state) {
        Expected<TabulatedBrdf> t = read_merl(path);
        if (!t) {
            state.SkipWithError(t.error().message.c_str());
            return;
        }
        mismatches = t->raw() == full_table().raw() ? 0 : 1;
        benchmark::DoNotOptimize(t->raw().data());
    }
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                            static_cast<int64_t>(merl_file_size(TableGrid::merl())));
    state.counters["entries_differing"] = static_cast<double>(mismatches);
}
BENCHMARK(BM_MerlLoad)->Unit(benchmark::kMillisecond);

// Baseline: the same file read into memory with one fread, no decoding or checks.
void BM_RawFileRead(benchmark::State& state) {
    const std::string& path = full_file();
    const std::size_t size = merl_file_size(TableGrid::merl());
    for (auto _ : state) {
        std::vector<unsigned char> bytes(size);
        std::FILE* f = std::fopen(path.c_str(), "rb");
        if (f == nullptr) {
            state.SkipWithError("cannot open the benchmark file");
            return;
        }
        const std::size_t got = std::fread(bytes.data(), 1, size, f);
        std::fclose(f);
        if (got != size) {
            state.SkipWithError("short read");
            return;
        }
        benchmark::DoNotOptimize(bytes.data());
    }
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(size));
}
BENCHMARK(BM_RawFileRead)->Unit(benchmark::kMillisecond);

struct Pairs {
    std::vector<Vec3d> wi, wo;
    std::vector<Rgbd> truth;
};

const Pairs& pairs() {
    static const Pairs p = [] {
        Pairs out;
        std::mt19937_64 rng(2026);
        std::uniform_real_distribution<double> u(0, 1);
        const ModelD m = bench_model();
        const double cos_max = std::cos(80.0 * kPi / 180);
        for (int k = 0; k < 4096; ++k) {
            auto dir = [&] {
                const double c = 1 - u(rng) * (1 - cos_max);
                return spherical_to_cartesian(std::acos(c), 2 * kPi * u(rng));
            };
            out.wi.push_back(dir());
            out.wo.push_back(dir());
            out.truth.push_back(eval_model(m, out.wi.back(), out.wo.back()));
        }
        return out;
    }();
    return p;
}

void lookup_bench(benchmark::State& state, Interpolation mode) {
    TabulatedBrdf table = full_table();
    table.set_interpolation(mode);
    const Pairs& p = pairs();
    std::size_t k = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(table.eval(p.wi[k], p.wo[k]));
        k = (k + 1) & 4095;
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
    std::vector<double> err;
    for (std::size_t j = 0; j < p.wi.size(); ++j) {
        err.push_back(((table.eval(p.wi[j], p.wo[j]) - p.truth[j]).abs() / p.truth[j]).maxCoeff());
    }
    std::sort(err.begin(), err.end());
    state.counters["rel_err_median"] = err[err.size() / 2];
    state.counters["rel_err_p95"] = err[err.size() * 95 / 100];
}

void BM_LookupNearest(benchmark::State& state) {
    lookup_bench(state, Interpolation::kNearest);
}
void BM_LookupTrilinear(benchmark::State& state) {
    lookup_bench(state, Interpolation::kTrilinear);
}
BENCHMARK(BM_LookupNearest);
BENCHMARK(BM_LookupTrilinear);

void BM_ModelToTable(benchmark::State& state) {
    const AnalyticBrdf brdf(bench_model());
    TabulateOptions o;
    o.threads = static_cast<unsigned>(state.range(0));
    double worst = 0;
    for (auto _ : state) {
        const TabulatedBrdf t = tabulate(brdf, o);
        state.PauseTiming();
        // Error at a sample of bin centres against the model.
        const TableGrid& g = t.grid();
        worst = 0;
        for (std::size_t flat = 0; flat < g.size(); flat += 97) {
            if (!t.bin_valid(flat)) {
                continue;
            }
            const std::array<int, 3> b = g.unflatten(flat);
            const auto [wi, wo] = g.centre_directions(b[0], b[1], b[2]);
            const Rgbd f = eval_model(brdf.model(), wi, wo);
            worst = std::max(worst, ((t.bin_value(flat) - f).abs() / f).maxCoeff());
        }
        state.ResumeTiming();
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * 1458000);
    state.counters["rel_err_at_centres"] = worst;
}
BENCHMARK(BM_ModelToTable)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_TableSample(benchmark::State& state) {
    TabulatedBrdf table = full_table();
    table.set_interpolation(Interpolation::kTrilinear);
    const TableSampler sampler(table);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    const Vec3d wi = spherical_to_cartesian(0.6, 0.0);
    double sum = 0;
    for (auto _ : state) {
        const DirectionSample d = sampler.sample(wi, u(rng), u(rng), u(rng));
        sum += table.eval(wi, d.w)[1] * d.w.z() / d.pdf;
        benchmark::DoNotOptimize(sum);
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
    // Monte Carlo estimate of the green directional albedo at theta_i = 0.6 (reported, not timed).
    state.counters["albedo_g_estimate"] = sum / static_cast<double>(state.iterations());
}
BENCHMARK(BM_TableSample);

}  // namespace

BENCHMARK_MAIN();
