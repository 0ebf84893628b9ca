// Acquisition benchmarks: planning + scheduling of ~100k configurations; scheduled motion time
// against raster order and the lower bound; measurements per second on the virtual rig at a large
// time scale; the motion time of a realistic campaign at real axis speeds.

#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/plans/schedule.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/brdf/dataset.h"
#include "gonio/sim/sim_rig.h"

namespace acq = gonio::acquisition;
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = gonio::brdf::kPi / 180;

acq::RigConfig sim4() {
    auto rig = acq::read_rig_config(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    if (!rig) {
        std::fprintf(stderr, "%s\n", rig.error().message.c_str());
        std::abort();
    }
    return *rig;
}

std::vector<gonio::brdf::RigPosed> solve_all(const acq::Plan& plan, const acq::RigConfig& rig) {
    const auto lim = acq::rig_limits(rig);
    const auto dyn = acq::rig_dynamics(rig);
    std::vector<gonio::brdf::RigPosed> poses;
    gonio::brdf::RigPosed prev{};
    for (const acq::PlannedConfig& c : plan.configs) {
        auto s = acq::solve(acq::Target{c.wi, c.wo, c.isotropic, true}, lim, dyn, prev);
        if (s) {
            poses.push_back(s->pose);
            prev = s->pose;
        }
    }
    return poses;
}

/// Plan (uniform grid, reachability) + inverse kinematics + schedule for about 100k configurations.
void BM_PlanAndSchedule100k(benchmark::State& state) {
    const acq::RigConfig rig = sim4();
    acq::UniformGridSpec spec{46, 85 * kDeg, 97};
    acq::Schedule last;
    std::size_t n = 0;
    for (auto _ : state) {
        auto plan = acq::plan_uniform(spec);
        acq::remove_unreachable(acq::rig_limits(rig), &*plan);
        const auto poses = solve_all(*plan, rig);
        acq::ScheduleOptions so;
        so.budget_s = 0.2;
        last = acq::schedule(poses, gonio::brdf::RigPosed{}, acq::rig_dynamics(rig), so);
        n = poses.size();
        benchmark::DoNotOptimize(last.order.data());
    }
    state.counters["configs"] = static_cast<double>(n);
    state.counters["planned_h"] = last.planned_s / 3600;
    state.counters["raster_h"] = last.raster_s / 3600;
    state.counters["planned_over_raster"] = last.planned_s / last.raster_s;
    state.counters["planned_over_lower_bound"] = last.planned_s / last.lower_bound_s;
}
BENCHMARK(BM_PlanAndSchedule100k)->Unit(benchmark::kMillisecond)->Iterations(3);

/// A realistic campaign at real axis speeds (sim4 dynamics): a 10 x 7 uniform grid and a MERL-like
/// half/difference grid; motion time only (capture adds exposure and transfer time).
void BM_RealisticCampaignMotion(benchmark::State& state) {
    const acq::RigConfig rig = sim4();
    acq::Plan plan;
    if (state.range(0) == 0) {
        plan = *acq::plan_uniform(acq::UniformGridSpec{10, 80 * kDeg, 7});
    } else {
        plan = *acq::plan_half_diff(acq::HalfDiffSpec{16, 16, 12, 80 * kDeg});
    }
    acq::remove_unreachable(acq::rig_limits(rig), &plan);
    const auto poses = solve_all(plan, rig);
    acq::Schedule s;
    for (auto _ : state) {
        s = acq::schedule(poses, gonio::brdf::RigPosed{}, acq::rig_dynamics(rig));
    }
    state.counters["configs"] = static_cast<double>(poses.size());
    state.counters["naive_4d"] = static_cast<double>(plan.naive_count);
    state.counters["planned_min"] = s.planned_s / 60;
    state.counters["raster_min"] = s.raster_s / 60;
    state.counters["lower_bound_min"] = s.lower_bound_s / 60;
    state.counters["planned_over_raster"] = s.planned_s / s.raster_s;
}
BENCHMARK(BM_RealisticCampaignMotion)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

/// Measurements per second on the virtual rig (time scale 1000): a 5 x 4 uniform campaign per
/// iteration, white reference included. The error counter is the largest |measured - truth| in
/// units of the sample's own sigma over the dataset.
void BM_VirtualRigCampaign(benchmark::State& state) {
    acq::RigConfig rig = sim4();
    std::size_t measured = 0;
    double worst_sigma = 0;
    int k = 0;
    for (auto _ : state) {
        const std::string dir = "bench_campaign_" + std::to_string(k++);
        fs::remove_all(dir);
        acq::CampaignSpec spec = acq::default_campaign_spec("bench");
        spec.uniform.n_theta = 5;
        spec.uniform.n_dphi = 4;
        spec.adaptive = false;
        spec.drift_every = 0;
        spec.json = acq::campaign_spec_json(spec);
        if (!acq::create_campaign_dir(dir, spec, rig)) {
            state.SkipWithError("cannot create the campaign folder");
            return;
        }
        gonio::sim::SimRigOptions so;
        so.time_scale = 1000;
        so.material = "red-plastic";
        auto sim = gonio::sim::SimRig::start(rig.json, so);
        auto dev = acq::open_rig(
            acq::with_addresses(rig, (*sim)->motor_address(), (*sim)->camera_address()));
        acq::RunHooks h;
        h.out = nullptr;
        auto res = acq::run_campaign(dir, *dev, h);
        if (!res || res->outcome != acq::Outcome::kCompleted) {
            state.SkipWithError("campaign did not complete");
            return;
        }
        measured += res->measured_now;
        // Error next to time: measured against the ground truth, in units of each sample's sigma.
        auto ds = gonio::brdf::read_dataset_csv(dir + "/dataset.csv");
        if (ds) {
            for (const auto& smp : ds->samples) {
                const double t = (*sim)->sample()->eval(smp.wi(), smp.wo()).mean();
                worst_sigma =
                    std::max(worst_sigma, std::abs(smp.value.mean() - t) / smp.sigma.mean());
            }
        }
        fs::remove_all(dir);
    }
    state.counters["measurements_per_s"] =
        benchmark::Counter(static_cast<double>(measured), benchmark::Counter::kIsRate);
    state.counters["worst_error_sigmas"] = worst_sigma;
}
BENCHMARK(BM_VirtualRigCampaign)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
