// RGL material files: reading, evaluation and writing, each with its error beside its time.
//   RglRead    a real measurement (../shared/data/rgl) read and checked: MB/s; error: largest
//              relative difference to the reference reader's values at its 400 reference pairs
//   RglEval    f_r at seeded random direction pairs through the VNDF warp: evaluations/s
//   RglWrite   an analytic GGX (alpha 0.2, Schlick, Lambert) written as a file (power iteration,
//              warps, nodes); error: median / 95th percentile / largest relative error of the
//              file against the model over 2000 seeded pairs (half near the mirror direction)
// Run: build/bench/gonio_rgl_bench --benchmark_min_time=0.5

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/rgl_bsdf.h"

namespace {

using namespace gonio::brdf;

const std::string kData = std::string(GONIO_SOURCE_DIR) + "/../shared/data/rgl/";

struct Dirs {
    Vec3d wi, wo;
};

std::vector<Dirs> random_pairs(unsigned seed, int n, bool near_mirror_half) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Dirs> out;
    const double lim = 80 * kPi / 180;
    while (static_cast<int>(out.size()) < n) {
        const double ti = u(rng) * lim, pi = (2 * u(rng) - 1) * kPi;
        double to = u(rng) * lim, po = (2 * u(rng) - 1) * kPi;
        if (near_mirror_half && out.size() % 2 == 1) {
            to = ti + (2 * u(rng) - 1) * 10 * kPi / 180;
            po = pi + kPi + (2 * u(rng) - 1) * 10 * kPi / 180;
            if (to < 0 || to > lim) {
                continue;
            }
        }
        out.push_back({spherical_to_cartesian(ti, pi), spherical_to_cartesian(to, po)});
    }
    return out;
}

void RglRead(benchmark::State& state) {
    const std::string path = kData + "satin_rosaline_rgb.bsdf";
    if (!std::ifstream(path).good()) {
        state.SkipWithError("../shared/data/rgl not found");
        return;
    }
    std::size_t bytes = std::filesystem::file_size(path);
    for (auto _ : state) {
        auto b = read_rgl_bsdf(path);
        benchmark::DoNotOptimize(b);
    }
    auto b = read_rgl_bsdf(path);
    double worst = 0;
    std::ifstream in(kData + "satin_rosaline_rgb.reference.csv");
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
        double v[7];
        char c;
        std::istringstream s(line);
        s >> v[0] >> c >> v[1] >> c >> v[2] >> c >> v[3] >> c >> v[4] >> c >> v[5] >> c >> v[6];
        const Rgbd f = b->eval_unclipped(spherical_to_cartesian(v[0], v[1]),
                                         spherical_to_cartesian(v[2], v[3]));
        for (int k = 0; k < 3; ++k) {
            if (v[4 + k] > 1e-4) {
                worst = std::max(worst, std::abs(f[k] - v[4 + k]) / v[4 + k]);
            }
        }
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
    state.counters["max_rel_vs_reference"] = worst;
}
BENCHMARK(RglRead)->Unit(benchmark::kMillisecond);

void RglEval(benchmark::State& state) {
    const std::string path = kData + "satin_rosaline_rgb.bsdf";
    auto b = read_rgl_bsdf(path);
    if (!b) {
        state.SkipWithError("../shared/data/rgl not found");
        return;
    }
    const std::vector<Dirs> pairs = random_pairs(7, 4096, false);
    std::size_t k = 0;
    for (auto _ : state) {
        const Dirs& d = pairs[k++ & 4095];
        benchmark::DoNotOptimize(b->eval(d.wi, d.wo));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(RglEval);

void RglWrite(benchmark::State& state) {
    ModelD m;
    m.diffuse = Rgbd(0.12, 0.25, 0.4);
    Lobe<double> lobe;
    lobe.alpha_x = lobe.alpha_y = 0.2;
    lobe.fresnel.type = FresnelType::kSchlick;
    m.lobes.push_back(lobe);
    const AnalyticBrdf model(m, "GGX alpha 0.2");
    const std::string path = (std::filesystem::temp_directory_path() /
                              ("gonio_rgl_bench_" + std::to_string(::getpid()) + ".bsdf"))
                                 .string();
    for (auto _ : state) {
        auto rep = write_rgl_bsdf(path, model);
        benchmark::DoNotOptimize(rep);
    }
    auto back = read_rgl_bsdf(path);
    std::vector<double> rel;
    for (const Dirs& d : random_pairs(20261201, 2000, true)) {
        const Rgbd truth = model.eval(d.wi, d.wo);
        rel.push_back(((back->eval(d.wi, d.wo) - truth).abs() / truth).maxCoeff());
    }
    std::sort(rel.begin(), rel.end());
    state.counters["rel_err_median"] = rel[rel.size() / 2];
    state.counters["rel_err_p95"] = rel[rel.size() * 95 / 100];
    state.counters["rel_err_max"] = rel.back();
    std::filesystem::remove(path);
}
BENCHMARK(RglWrite)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
