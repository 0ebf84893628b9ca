// Evaluation speed of the analytic model, in double and through ceres::Jet<double, 8>, with the
// relative error against a long double evaluation of the same directions as a counter.
//
//   cmake -S . -B build -DGONIO_BUILD_BENCH=ON && cmake --build build --target gonio_brdf_bench
//   build/bench/gonio_brdf_bench --benchmark_min_time=0.5
//
// items_per_second is model evaluations per second on one core. The *Packets entries evaluate the
// same pairs as structure of arrays through eval_model_packets (SIMD width chosen at run time,
// printed as the label) and report the largest relative difference to the scalar evaluation and to
// long double.

#include <benchmark/benchmark.h>
#include <ceres/jet.h>

#include <cmath>
#include <random>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"

namespace {

using gonio::brdf::Distribution;
using gonio::brdf::FresnelType;
using gonio::brdf::Lobe;
using gonio::brdf::Model;
using gonio::brdf::ModelD;
using gonio::brdf::Rgb;
using gonio::brdf::Rgbd;
using gonio::brdf::Shadowing;
using gonio::brdf::Vec3;
using gonio::brdf::Vec3d;
using Jet8 = ceres::Jet<double, 8>;
using LD = long double;

/// The default model: Lambert + GGX, height-correlated Smith, Schlick with RGB f0.
ModelD default_model() {
    ModelD m;
    m.diffuse = Rgbd(0.3, 0.2, 0.1);
    Lobe<double> l;
    l.distribution = Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.2;
    l.shadowing = Shadowing::kSmithCorrelated;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd(0.04, 0.05, 0.06);
    m.lobes.push_back(l);
    return m;
}

ModelD variant(Distribution d, Shadowing s, FresnelType f) {
    ModelD m = default_model();
    m.lobes[0].distribution = d;
    m.lobes[0].shadowing = s;
    m.lobes[0].fresnel.type = f;
    m.lobes[0].fresnel.eta_rgb = Rgbd(0.214, 1.037, 1.169);
    m.lobes[0].fresnel.k = Rgbd(3.67, 2.59, 2.36);
    m.lobes[0].exponent = 50;
    return m;
}

struct Pairs {
    std::vector<Vec3d> wi;
    std::vector<Vec3d> wo;
};

/// 4096 direction pairs over the upper hemisphere, seed 12345.
const Pairs& pairs() {
    static const Pairs p = [] {
        Pairs out;
        std::mt19937_64 rng(12345);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        auto dir = [&] {
            const double c = 1.0 - u(rng);
            const double phi = 2 * gonio::brdf::kPi * u(rng);
            const double s = std::sqrt(1 - c * c);
            return Vec3d(s * std::cos(phi), s * std::sin(phi), c);
        };
        for (int i = 0; i < 4096; ++i) {
            out.wi.push_back(dir());
            out.wo.push_back(dir());
        }
        return out;
    }();
    return p;
}

/// Largest relative difference between double and long double evaluations over the pairs.
double max_relative_error(const ModelD& m) {
    const Model<LD> ml =
        gonio::brdf::cast_model<LD>(m, [](double v) { return static_cast<LD>(v); });
    const Pairs& p = pairs();
    double worst = 0;
    for (std::size_t i = 0; i < p.wi.size(); ++i) {
        const Rgbd f = gonio::brdf::eval_model(m, p.wi[i], p.wo[i]);
        const Rgb<LD> g =
            gonio::brdf::eval_model(ml, Vec3<LD>(p.wi[i].cast<LD>()), Vec3<LD>(p.wo[i].cast<LD>()));
        for (int c = 0; c < 3; ++c) {
            const double e =
                static_cast<double>(std::fabs(f[c] - g[c]) / (std::fabs(g[c]) + 1e-300L));
            worst = std::max(worst, e);
        }
    }
    return worst;
}

void run_double(benchmark::State& state, const ModelD& m) {
    const Pairs& p = pairs();
    const std::size_t n = p.wi.size();
    std::size_t i = 0;
    for (auto _ : state) {
        Rgbd f = gonio::brdf::eval_model(m, p.wi[i], p.wo[i]);
        benchmark::DoNotOptimize(f);
        i = (i + 1) & (n - 1);
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["max_rel_err_vs_long_double"] = max_relative_error(m);
}

void BM_EvalDefaultDouble(benchmark::State& state) {
    run_double(state, default_model());
}
BENCHMARK(BM_EvalDefaultDouble);

void BM_EvalBeckmannConductorDouble(benchmark::State& state) {
    run_double(
        state,
        variant(Distribution::kBeckmann, Shadowing::kSmithCorrelated, FresnelType::kConductor));
}
BENCHMARK(BM_EvalBeckmannConductorDouble);

void BM_EvalGgxDielectricDouble(benchmark::State& state) {
    run_double(state,
               variant(Distribution::kGgx, Shadowing::kSmithSeparable, FresnelType::kDielectric));
}
BENCHMARK(BM_EvalGgxDielectricDouble);

void BM_EvalBlinnPhongVGrooveDouble(benchmark::State& state) {
    run_double(state,
               variant(Distribution::kBlinnPhong, Shadowing::kVGroove, FresnelType::kSchlick));
}
BENCHMARK(BM_EvalBlinnPhongVGrooveDouble);

void BM_EvalDefaultThroughBrdfInterface(benchmark::State& state) {
    const auto brdf = gonio::brdf::make_analytic_brdf(default_model());
    const Pairs& p = pairs();
    const std::size_t n = p.wi.size();
    std::size_t i = 0;
    for (auto _ : state) {
        Rgbd f = brdf->eval(p.wi[i], p.wo[i]);
        benchmark::DoNotOptimize(f);
        i = (i + 1) & (n - 1);
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EvalDefaultThroughBrdfInterface);

void BM_EvalDefaultJet8(benchmark::State& state) {
    const ModelD md = default_model();
    Model<Jet8> m = gonio::brdf::cast_model<Jet8>(md, [](double v) { return Jet8(v); });
    // The 8 fitted parameters: diffuse rgb, alpha, f0 rgb, scale r.
    for (int c = 0; c < 3; ++c) {
        m.diffuse[c].v[c] = 1;
        m.lobes[0].fresnel.f0[c].v[4 + c] = 1;
    }
    m.lobes[0].alpha_x.v[3] = 1;
    m.lobes[0].scale[0].v[7] = 1;
    const Pairs& p = pairs();
    std::vector<Vec3<Jet8>> wi;
    std::vector<Vec3<Jet8>> wo;
    for (std::size_t k = 0; k < p.wi.size(); ++k) {
        wi.push_back(p.wi[k].cast<Jet8>());
        wo.push_back(p.wo[k].cast<Jet8>());
    }
    const std::size_t n = wi.size();
    std::size_t i = 0;
    double max_diff = 0;
    for (auto _ : state) {
        Rgb<Jet8> f = gonio::brdf::eval_model(m, wi[i], wo[i]);
        benchmark::DoNotOptimize(f);
        i = (i + 1) & (n - 1);
    }
    // Value part against the double evaluation (outside the timed loop).
    for (std::size_t k = 0; k < n; ++k) {
        const Rgb<Jet8> f = gonio::brdf::eval_model(m, wi[k], wo[k]);
        const Rgbd g = gonio::brdf::eval_model(md, p.wi[k], p.wo[k]);
        for (int c = 0; c < 3; ++c) {
            max_diff = std::max(max_diff, std::fabs(f[c].a - g[c]) / (std::fabs(g[c]) + 1e-300));
        }
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["max_rel_diff_value_vs_double"] = max_diff;
}
BENCHMARK(BM_EvalDefaultJet8);

/// The pairs as structure of arrays.
struct PairsSoA {
    std::vector<double> c[6];
    gonio::brdf::DirectionPairs dirs() const {
        return {c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data(), c[5].data()};
    }
};

const PairsSoA& pairs_soa() {
    static const PairsSoA s = [] {
        PairsSoA out;
        const Pairs& p = pairs();
        for (std::size_t k = 0; k < p.wi.size(); ++k) {
            for (int a = 0; a < 3; ++a) {
                out.c[a].push_back(p.wi[k][a]);
                out.c[3 + a].push_back(p.wo[k][a]);
            }
        }
        return out;
    }();
    return s;
}

void run_packets(benchmark::State& state, const ModelD& m) {
    const PairsSoA& soa = pairs_soa();
    const std::size_t n = soa.c[0].size();
    std::vector<double> r(n), g(n), b(n);
    double* const out[3] = {r.data(), g.data(), b.data()};
    for (auto _ : state) {
        gonio::brdf::eval_model_packets(m, n, soa.dirs(), out);
        benchmark::DoNotOptimize(r.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
    const Model<LD> ml =
        gonio::brdf::cast_model<LD>(m, [](double v) { return static_cast<LD>(v); });
    const Pairs& p = pairs();
    double vs_scalar = 0;
    double vs_long_double = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const Rgbd f = gonio::brdf::eval_model(m, p.wi[k], p.wo[k]);
        const Rgb<LD> fl =
            gonio::brdf::eval_model(ml, Vec3<LD>(p.wi[k].cast<LD>()), Vec3<LD>(p.wo[k].cast<LD>()));
        for (int c = 0; c < 3; ++c) {
            const double v = out[c][k];
            vs_scalar = std::max(vs_scalar, std::fabs(v - f[c]) / (std::fabs(f[c]) + 1e-300));
            vs_long_double =
                std::max(vs_long_double,
                         static_cast<double>(std::fabs(v - fl[c]) / (std::fabs(fl[c]) + 1e-300L)));
        }
    }
    state.SetLabel(gonio::brdf::packet_instruction_set());
    state.counters["max_rel_diff_vs_scalar"] = vs_scalar;
    state.counters["max_rel_err_vs_long_double"] = vs_long_double;
}

void BM_EvalDefaultPackets(benchmark::State& state) {
    run_packets(state, default_model());
}
BENCHMARK(BM_EvalDefaultPackets);

void BM_EvalBeckmannConductorPackets(benchmark::State& state) {
    run_packets(
        state,
        variant(Distribution::kBeckmann, Shadowing::kSmithCorrelated, FresnelType::kConductor));
}
BENCHMARK(BM_EvalBeckmannConductorPackets);

void BM_EvalGgxDielectricPackets(benchmark::State& state) {
    run_packets(state,
                variant(Distribution::kGgx, Shadowing::kSmithSeparable, FresnelType::kDielectric));
}
BENCHMARK(BM_EvalGgxDielectricPackets);

void BM_EvalBlinnPhongVGroovePackets(benchmark::State& state) {
    run_packets(state,
                variant(Distribution::kBlinnPhong, Shadowing::kVGroove, FresnelType::kSchlick));
}
BENCHMARK(BM_EvalBlinnPhongVGroovePackets);

}  // namespace

BENCHMARK_MAIN();
