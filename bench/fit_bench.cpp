// Speed and fit quality of `gonio fit` on tables of real materials (docs/benchmarks/fitting.md).
//
// Data: materials of data/materials/ngan2005.json (published Lambert + Cook-Torrance fits of the
// MERL measurements: Beckmann, V-groove, scalar Schlick, RGB scale) tabulated at the bin centres
// of the full 90 x 90 x 180 MERL grid (1 096 216 samples above the horizon), and two tables that
// no single lobe family represents (a GGX + Beckmann two-lobe mixture, a narrow + wide GGX pair).
// The default model (GGX + Lambert + scalar Schlick + RGB scale) is of another family than all of
// them: these are cross-family fits, as on measured data.
//
// Benchmarks:
//   Iteration/<N>/threads:<t>   one Levenberg-Marquardt iteration over N samples: one fused pass
//                               (cost and normal equations), ms per iteration
//   CrossFamily/<material>      the default fit end to end on the full table: time, iterations,
//                               log RMSE; and the stated loss of the reduction: log RMSE of the
//                               reduced solve alone (no polish) minus that of the polished fit
//   Size/samples:<n>            the default fit of n noisy red-plastic samples at random
//                               directions (1k, 6k, 100k, 1M): in process (solver.wall_time_s
//                               and CPU), `gonio fit` (wall) and scipy least_squares, same CSV,
//                               same run
//   FitCpu/samples:<n>          the default fit alone of the size table's CSV (1k, 6k, 100k),
//   repeated:
//                               process CPU per fit (both threads), log RMSE
//   CsvRead                     read_dataset_csv of a 1M-row CSV written by write_dataset_csv
//   GonioVsScipy                `gonio fit DATA.csv` and bench/scipy_fit.py (Debian python3-scipy,
//                               scipy.optimize.least_squares) on the same 1M-row CSV, same run
//   Ngan86                      the default model and --model auto on all 86 materials' tables
//                               (slow: about 86 x 2 fits); writes --table=FILE (markdown)
//
//   gonio_fit_bench [--table=ngan86.md] [google-benchmark flags]

#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/base/huge_pages.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/resample.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/prepared_samples.h"
#include "gonio/fitting/reduction.h"

namespace {

namespace fitting = gonio::fitting;
namespace brdf = gonio::brdf;
namespace fs = std::filesystem;

std::string g_table_path = "ngan86.md";

nlohmann::json materials_json() {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/materials/ngan2005.json");
    std::stringstream ss;
    ss << in.rdbuf();
    return nlohmann::json::parse(ss.str()).at("materials");
}

brdf::ModelD load_material(const std::string& name) {
    static const nlohmann::json all = materials_json();
    auto m = brdf::parse_model_json(all.at(name).dump(), name);
    if (!m) {
        std::fprintf(stderr, "%s\n", m.error().message.c_str());
        std::exit(1);
    }
    return *m;
}

/// Models no single lobe family represents.
brdf::ModelD mixture(const std::string& name) {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd(0.15, 0.1, 0.05);
    brdf::Lobe<double> a;
    a.distribution = brdf::Distribution::kGgx;
    a.fresnel.type = brdf::FresnelType::kSchlick;
    a.fresnel.f0 = brdf::Rgbd::Constant(0.04);
    brdf::Lobe<double> b = a;
    if (name == "mix-ggx-beckmann") {
        a.alpha_x = a.alpha_y = 0.08;
        b.distribution = brdf::Distribution::kBeckmann;
        b.alpha_x = b.alpha_y = 0.35;
        b.scale = brdf::Rgbd(0.6, 0.5, 0.4);
    } else {  // "two-ggx": a clear coat over a rough base
        a.alpha_x = a.alpha_y = 0.02;
        b.alpha_x = b.alpha_y = 0.3;
        b.scale = brdf::Rgbd(0.8, 0.3, 0.2);
    }
    m.lobes = {a, b};
    return m;
}

brdf::ModelD truth_of(const std::string& name) {
    return name.rfind("mix-", 0) == 0 || name == "two-ggx" ? mixture(name) : load_material(name);
}

/// The full-grid table of a material as samples (one table in memory at a time).
const brdf::Dataset& table(const std::string& name) {
    static std::string cached;
    static brdf::Dataset data;
    if (cached != name) {
        data = brdf::table_to_dataset(brdf::tabulate(*brdf::make_analytic_brdf(truth_of(name))));
        data.source = name;
        cached = name;
    }
    return data;
}

fitting::FitSpec default_spec() {
    return *fitting::make_fit_spec(fitting::ModelOptions{});
}

// ---------------------------------------------------------------------------------------------

void Iteration(benchmark::State& state) {
    const std::size_t n = static_cast<std::size_t>(state.range(0));
    const int threads = static_cast<int>(state.range(1));
    const brdf::Dataset& full = table("red-plastic");
    const std::vector<brdf::Sample> samples = fitting::stratified_reduce(full.samples, n, 1);
    const fitting::FitSpec spec = default_spec();
    auto map = std::make_shared<const fitting::ParameterMap>(*fitting::ParameterMap::make(spec));
    fitting::CostOptions co;
    const fitting::PreparedSamples ps(map, samples, co);
    std::vector<double> x = map->values_of(spec.model);
    fitting::NormalEquations ne;
    double s = 0;
    // One iteration of the solver is one fused pass (cost and normal equations together; the
    // step's cost evaluation is reused for its Jacobian: prepared_samples.h).
    for (auto _ : state) {
        ps.normal_equations(x.data(), ne, threads);
        benchmark::DoNotOptimize(ne.cost_sum);
    }
    // The cost-only pass of a rejected step, for reference.
    const auto t0 = std::chrono::steady_clock::now();
    ps.sum_of_squares(x.data(), &s, threads);
    state.counters["cost_pass_ms"] =
        1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.counters["samples"] = static_cast<double>(samples.size());
    state.counters["analytic"] = ps.analytic() ? 1 : 0;
    state.counters["ns_per_sample"] = benchmark::Counter(
        static_cast<double>(samples.size()),
        benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void CrossFamily(benchmark::State& state, const std::string& name) {
    const brdf::Dataset& data = table(name);
    fitting::FitSpec spec = default_spec();
    fitting::FitResult r;
    for (auto _ : state) {
        r = *fitting::fit(data, spec);
    }
    fitting::FitSpec reduced_only = spec;
    reduced_only.options.polish_iterations = 0;
    reduced_only.options.covariance = false;
    const fitting::FitResult rr = *fitting::fit(data, reduced_only);
    state.counters["fit_s"] = r.solver.wall_time_s;
    state.counters["iterations"] = r.solver.iterations;
    for (const fitting::StageInfo& st : r.solver.stages) {
        state.counters["it_" + st.name] = st.iterations;
        state.counters["s_" + st.name] = st.time_s;
    }
    state.counters["log_rmse"] = r.metrics.log_rmse.mean();
    state.counters["log_rmse_reduced_only"] = rr.metrics.log_rmse.mean();
    state.counters["reduction_loss"] = rr.metrics.log_rmse.mean() - r.metrics.log_rmse.mean();
    state.counters["at_bounds"] = static_cast<double>(r.at_bounds.size());
    state.counters["usable"] = r.usable() ? 1 : 0;
}

/// A 1M-row CSV of the red-plastic table (written once per run, in the working folder).
const std::string& csv_1m() {
    static std::string path;
    if (path.empty()) {
        path = (fs::current_path() / "fit_bench_1m.csv").string();
        brdf::Dataset d = table("red-plastic");
        d.samples.resize(1000000);
        if (!brdf::write_dataset_csv(path, d)) {
            std::fprintf(stderr, "cannot write %s\n", path.c_str());
            std::exit(1);
        }
    }
    return path;
}

void CsvRead(benchmark::State& state) {
    const std::string& path = csv_1m();
    std::size_t rows = 0;
    for (auto _ : state) {
        auto d = brdf::read_dataset_csv(path);
        rows = d ? d->samples.size() : 0;
        benchmark::DoNotOptimize(rows);
    }
    state.counters["rows"] = static_cast<double>(rows);
}

std::string self_dir() {
    char buf[4096];
    const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
    if (n <= 0) {
        return ".";
    }
    buf[n] = 0;
    return fs::path(buf).parent_path().string();
}

/// Runs a command, returns its wall time in seconds and its standard output.
double timed(const std::string& cmd, std::string* out) {
    const auto t0 = std::chrono::steady_clock::now();
    std::FILE* p = popen(cmd.c_str(), "r");
    std::string text;
    if (p != nullptr) {
        char buf[4096];
        std::size_t k;
        while ((k = std::fread(buf, 1, sizeof buf, p)) > 0) {
            text.append(buf, k);
        }
        if (pclose(p) != 0) {
            text = "FAILED: " + text;
        }
    }
    if (out != nullptr) {
        *out = text;
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void GonioVsScipy(benchmark::State& state) {
    const std::string& path = csv_1m();
    const std::string gonio = self_dir() + "/../tools/gonio";
    const std::string script = std::string(GONIO_SOURCE_DIR) + "/bench/scipy_fit.py";
    double t_gonio = 0, t_scipy = 0;
    std::string scipy_out, gonio_out;
    for (auto _ : state) {
        t_gonio = timed(gonio + " fit " + path + " 2>&1", &gonio_out);
        t_scipy = timed("/usr/bin/python3 " + script + " " + path, &scipy_out);
    }
    state.counters["gonio_s"] = t_gonio;
    state.counters["scipy_s"] = t_scipy;
    state.counters["speedup"] = t_scipy / t_gonio;
    try {
        const nlohmann::json j = nlohmann::json::parse(scipy_out);
        state.counters["scipy_fit_s"] = j.at("fit_s").get<double>();
        state.counters["scipy_read_s"] = j.at("read_s").get<double>();
        state.counters["scipy_log_rmse"] = j.at("log_rmse").get<double>();
        state.counters["scipy_nfev"] = j.at("nfev").get<double>();
    } catch (const nlohmann::json::exception&) {
        state.SkipWithError(("scipy: " + scipy_out).c_str());
    }
    const std::size_t at = gonio_out.find("log_rmse");
    if (at != std::string::npos) {
        std::istringstream in(gonio_out.substr(at + 8));
        double r = 0, g = 0, b = 0;
        in >> r >> g >> b;
        state.counters["gonio_log_rmse"] = (r + g + b) / 3;
    }
}

/// A CSV of `n` samples of red-plastic (Ngan et al.'s Beckmann + V-groove fit: another family
/// than the default model) at seeded uniform random directions above the horizon (cos theta in
/// [0.05, 1]) with 1 % Gaussian multiplicative noise (seed 11); written once per size and run.
std::string csv_of(std::size_t n) {
    const std::string path =
        (fs::current_path() / ("fit_bench_" + std::to_string(n) + ".csv")).string();
    if (fs::exists(path)) {
        return path;
    }
    const brdf::ModelD truth = truth_of("red-plastic");
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> noise(0, 0.01);
    brdf::Dataset d;
    d.samples.resize(n);
    for (brdf::Sample& s : d.samples) {
        s.theta_i = std::acos(0.05 + 0.95 * u(rng));
        s.phi_i = 2 * brdf::kPi * u(rng);
        s.theta_o = std::acos(0.05 + 0.95 * u(rng));
        s.phi_o = 2 * brdf::kPi * u(rng);
        s.value = brdf::eval_model(truth, s.wi(), s.wo()) * (1 + noise(rng));
    }
    if (!brdf::write_dataset_csv(path, d)) {
        std::fprintf(stderr, "cannot write %s\n", path.c_str());
        std::exit(1);
    }
    return path;
}

double process_cpu_s() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Minor page faults of this process so far.
long minor_faults() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_minflt;
}

/// The size table: at n points, the default fit in this process (the report's
/// solver.wall_time_s and the process CPU time of the call), the whole `gonio fit` command
/// (wall), and bench/scipy_fit.py on the same CSV in the same run (its least_squares time and its
/// whole run).
void Size(benchmark::State& state) {
    const std::size_t n = static_cast<std::size_t>(state.range(0));
    const std::string path = csv_of(n);
    const auto data = brdf::read_dataset_csv(path);
    if (!data) {
        state.SkipWithError(data.error().message.c_str());
        return;
    }
    const std::string gonio = self_dir() + "/../tools/gonio";
    const std::string script = std::string(GONIO_SOURCE_DIR) + "/bench/scipy_fit.py";
    fitting::FitResult r;
    double cpu = 0, t_cmd = 0, t_scipy = 0, faults = 0;
    std::string scipy_out, gonio_out;
    for (auto _ : state) {
        const double c0 = process_cpu_s();
        const long f0 = minor_faults();
        r = *fitting::fit(*data, default_spec());
        cpu = process_cpu_s() - c0;
        faults = static_cast<double>(minor_faults() - f0);
        t_cmd = timed(gonio + " fit " + path + " 2>&1", &gonio_out);
        t_scipy = timed("/usr/bin/python3 " + script + " " + path, &scipy_out);
    }
    state.counters["samples"] = static_cast<double>(n);
    state.counters["fit_s"] = r.solver.wall_time_s;
    state.counters["fit_cpu_s"] = cpu;
    state.counters["fit_faults"] = faults;
    state.counters["cmd_s"] = t_cmd;
    state.counters["iterations"] = r.solver.iterations;
    state.counters["log_rmse"] = r.metrics.log_rmse.mean();
    for (const fitting::StageInfo& st : r.solver.stages) {
        state.counters["s_" + st.name] = st.time_s;
    }
    try {
        const nlohmann::json j = nlohmann::json::parse(scipy_out);
        const double fit_s = j.at("fit_s").get<double>();
        state.counters["scipy_fit_s"] = fit_s;
        state.counters["scipy_total_s"] = t_scipy;
        state.counters["scipy_log_rmse"] = j.at("log_rmse").get<double>();
        state.counters["lead_fit"] = fit_s / r.solver.wall_time_s;
        state.counters["lead_cmd"] = t_scipy / t_cmd;
    } catch (const nlohmann::json::exception&) {
        state.SkipWithError(("scipy: " + scipy_out).c_str());
    }
}

/// The default fit of the size table's CSV alone, repeated: the process CPU time per fit (the CPU
/// column, both threads counted) and the log RMSE, for the small sizes' fixed costs.
void FitCpu(benchmark::State& state) {
    const std::size_t n = static_cast<std::size_t>(state.range(0));
    const auto data = brdf::read_dataset_csv(csv_of(n));
    if (!data) {
        state.SkipWithError(data.error().message.c_str());
        return;
    }
    fitting::FitResult r;
    for (auto _ : state) {
        r = *fitting::fit(*data, default_spec());
    }
    state.counters["samples"] = static_cast<double>(n);
    state.counters["iterations"] = r.solver.iterations;
    state.counters["log_rmse"] = r.metrics.log_rmse.mean();
    for (const fitting::StageInfo& st : r.solver.stages) {
        state.counters["s_" + st.name] = st.time_s;
        state.counters["it_" + st.name] = st.iterations;
    }
}

void Ngan86(benchmark::State& state) {
    const nlohmann::json all = materials_json();
    struct Row {
        std::string name;
        double log_rmse = 0, auto_log_rmse = 0, fit_s = 0;
        int iterations = 0;
        std::string bounds, chosen;
        bool usable = false;
    };
    std::vector<Row> rows;
    for (auto _ : state) {
        rows.clear();
        for (auto it = all.begin(); it != all.end(); ++it) {
            const brdf::Dataset& data = table(it.key());
            Row row;
            row.name = it.key();
            const fitting::FitResult r = *fitting::fit(data, default_spec());
            row.log_rmse = r.metrics.log_rmse.mean();
            row.fit_s = r.solver.wall_time_s;
            row.iterations = r.solver.iterations;
            row.usable = r.usable();
            for (const std::string& b : r.at_bounds) {
                row.bounds += (row.bounds.empty() ? "" : "; ") + b;
            }
            auto a = fitting::fit_auto(data, fitting::auto_candidates(default_spec().options));
            if (a) {
                row.auto_log_rmse = a->best.metrics.log_rmse.mean();
                row.chosen = a->chosen;
            }
            rows.push_back(row);
            std::fprintf(stderr,
                         "%-28s default %.4f (%d it, %.2f s) auto %.4f (%s) %s\n",
                         row.name.c_str(),
                         row.log_rmse,
                         row.iterations,
                         row.fit_s,
                         row.auto_log_rmse,
                         row.chosen.c_str(),
                         row.bounds.c_str());
        }
    }
    std::vector<double> v, va;
    std::size_t bounded = 0, unusable = 0;
    for (const Row& r : rows) {
        v.push_back(r.log_rmse);
        va.push_back(r.auto_log_rmse);
        bounded += r.bounds.empty() ? 0 : 1;
        unusable += r.usable ? 0 : 1;
    }
    std::sort(v.begin(), v.end());
    std::sort(va.begin(), va.end());
    auto median = [](const std::vector<double>& s) { return s[s.size() / 2]; };
    state.counters["median_log_rmse"] = median(v);
    state.counters["worst_log_rmse"] = v.back();
    state.counters["auto_median_log_rmse"] = median(va);
    state.counters["auto_worst_log_rmse"] = va.back();
    state.counters["with_param_at_bound"] = static_cast<double>(bounded);
    state.counters["not_usable"] = static_cast<double>(unusable);
    std::ofstream out(g_table_path);
    out << "| material | default log RMSE | iterations | fit s | usable | at a bound | auto choice "
           "| "
           "auto log RMSE |\n|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        char buf[512];
        std::snprintf(buf,
                      sizeof buf,
                      "| %s | %.4f | %d | %.2f | %s | %s | %s | %.4f |\n",
                      r.name.c_str(),
                      r.log_rmse,
                      r.iterations,
                      r.fit_s,
                      r.usable ? "yes" : "no",
                      r.bounds.empty() ? "-" : r.bounds.c_str(),
                      r.chosen.c_str(),
                      r.auto_log_rmse);
        out << buf;
    }
}

}  // namespace

int main(int argc, char** argv) {
    // The heap settings of the `gonio` command (tools/main.cpp), so that the fit in this process
    // runs as in the command: a repeated fit does not fault its buffers in again.
    gonio::keep_heap_for_batch_work();
    std::vector<char*> args;
    for (int i = 0; i < argc; ++i) {
        if (std::strncmp(argv[i], "--table=", 8) == 0) {
            g_table_path = argv[i] + 8;
        } else {
            args.push_back(argv[i]);
        }
    }
    int n = static_cast<int>(args.size());
    for (long samples : {20000L, 100000L, 1096216L}) {
        for (long threads : {1L, 2L}) {
            benchmark::RegisterBenchmark("Iteration", Iteration)
                ->Args({samples, threads})
                ->ArgNames({"samples", "threads"})
                ->Unit(benchmark::kMillisecond);
        }
    }
    for (const char* m : {"red-plastic", "white-paint", "chrome", "mix-ggx-beckmann", "two-ggx"}) {
        benchmark::RegisterBenchmark((std::string("CrossFamily/") + m).c_str(), CrossFamily, m)
            ->Iterations(1)
            ->Unit(benchmark::kMillisecond);
    }
    for (long samples : {1000L, 6000L, 100000L, 1000000L}) {
        benchmark::RegisterBenchmark("Size", Size)
            ->Arg(samples)
            ->ArgName("samples")
            ->Iterations(1)
            ->Unit(benchmark::kMillisecond);
    }
    for (long samples : {1000L, 6000L, 100000L}) {
        benchmark::RegisterBenchmark("FitCpu", FitCpu)
            ->Arg(samples)
            ->ArgName("samples")
            ->MeasureProcessCPUTime()
            ->Unit(benchmark::kMillisecond);
    }
    benchmark::RegisterBenchmark("CsvRead", CsvRead)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("GonioVsScipy", GonioVsScipy)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("Ngan86", Ngan86)->Iterations(1)->Unit(benchmark::kSecond);
    benchmark::Initialize(&n, args.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
