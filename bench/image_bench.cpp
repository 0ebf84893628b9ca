// Image mode against point mode on the same simulated material and rig speeds: samples per second,
// rig time to a coverage of the half/difference table, and the fit error reached for the time
// spent. Rig time = light-arm moves (trapezoidal profile + settle, acquisition/shared/kinematics.h
// defaults: 20 deg/s, 40 deg/s^2, 50 ms) + every exposure taken (brackets, dark frames, white
// reference); camera readout and transfer are not counted, in either mode. The image-mode
// campaigns run through the device path of `gonio acquire --mode image`: the virtual rig's motor
// controllers on Modbus TCP and its GigE Vision camera (rendering the sphere at each trigger)
// opened through Aravis, on loopback; the wall-clock counters include that transport.

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include "embedded_rig.h"
#include "gonio/acquisition/plans/schedule.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_json.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"

namespace {

using namespace gonio;
using brdf::kPi;

brdf::ModelD truth_model() {
    brdf::ModelD m;
    m.diffuse = brdf::Rgbd(0.35, 0.22, 0.12);
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.3;
    l.fresnel.type = brdf::FresnelType::kNone;
    l.scale = brdf::Rgbd::Constant(0.12);
    m.lobes.push_back(l);
    return m;
}

/// Relative error of the fitted alpha and the largest relative error of the diffuse albedo.
std::pair<double, double> fit_errors(const brdf::Dataset& data) {
    fitting::ModelOptions mo;
    mo.fresnel = brdf::FresnelType::kNone;
    auto spec = fitting::make_fit_spec(mo);
    spec->options.seed = 1;
    spec->options.num_threads = 1;
    spec->options.max_samples = 6000;
    auto fit = fitting::fit(data, *spec);
    if (!fit || !fit->usable() || fit->model.lobes.empty()) {
        return {1.0, 1.0};
    }
    const brdf::ModelD t = truth_model();
    const double e_alpha =
        std::abs(fit->model.lobes[0].alpha_x - t.lobes[0].alpha_x) / t.lobes[0].alpha_x;
    const double e_diffuse = ((fit->model.diffuse - t.diffuse).abs() / t.diffuse).maxCoeff();
    return {e_alpha, e_diffuse};
}

/// The virtual image rig with the ground truth, a `size` px telecentric camera and one ray per
/// pixel; motion at 1000x speed (the rig time is computed, not waited for).
Expected<std::unique_ptr<acquisition::ImageRig>> start_rig(int size, std::uint64_t seed) {
    const std::string model = (std::filesystem::temp_directory_path() /
                               ("gonio_image_bench_" + std::to_string(::getpid()) + ".json"))
                                  .string();
    std::ofstream(model) << brdf::model_to_json(truth_model());
    acquisition::ImageRigOptions o;
    o.brdf_path = model;
    o.image_size = size;
    o.supersample = 1;
    o.seed = seed;
    o.time_scale = 1000;
    auto rig = acquisition::start_image_rig(o, tools::embedded_rig_starter());
    std::filesystem::remove(model);
    return rig;
}

double light_moves_s(const std::vector<acquisition::FrameRecord>& frames, double start) {
    const acquisition::AxisDynamics d;
    double t = 0;
    double at = start;
    for (const auto& f : frames) {
        t += acquisition::trapezoid_time(std::abs(f.light_arm_rad - at), d.speed, d.accel) +
             d.settle_s;
        at = f.light_arm_rad;
    }
    return t;
}

/// Image mode: campaign on a 200 px sphere image, 30 x 30 x 60 table, at most range(0) frames.
void BM_ImageModeCampaign(benchmark::State& state) {
    const int max_frames = static_cast<int>(state.range(0));
    for (auto _ : state) {
        auto rig = start_rig(200, 7);
        if (!rig) {
            state.SkipWithError(rig.error().message.c_str());
            return;
        }
        auto cfg =
            acquisition::image_campaign_config((*rig)->rig, (*rig)->camera, 3, 0.99, max_frames);
        const auto t0 = std::chrono::steady_clock::now();
        auto r = acquisition::run_image_campaign(acquisition::image_rig_capture(**rig, 0.0), cfg);
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (!r) {
            state.SkipWithError(r.error().message.c_str());
            return;
        }
        const double rig_s = r->exposure_time_s + light_moves_s(r->frames, 0.0);
        const auto [e_alpha, e_diffuse] = fit_errors(r->table.to_dataset("bench", 3, true));
        state.counters["frames"] = static_cast<double>(r->frames.size());
        state.counters["pixel_samples"] = static_cast<double>(r->counts.used);
        state.counters["coverage"] = r->coverage.fraction();
        state.counters["covered_bins"] = static_cast<double>(r->coverage.covered_bins());
        state.counters["samples_per_wall_s"] = r->counts.used / wall;
        state.counters["captures"] = static_cast<double>(r->captures);
        state.counters["captures_per_wall_s"] = r->captures / wall;
        state.counters["rig_s"] = rig_s;
        state.counters["bins_per_rig_s"] = r->coverage.covered_bins() / rig_s;
        state.counters["alpha_rel_err"] = e_alpha;
        state.counters["diffuse_rel_err"] = e_diffuse;
    }
}
BENCHMARK(BM_ImageModeCampaign)
    ->Arg(4)
    ->Arg(8)
    ->Arg(16)
    ->Arg(60)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

/// The MERL table (90 x 90 x 180) in image mode: a range(0) px telecentric camera, target 90% of
/// the valid bins, light positions 0.5 degree apart (a quarter of a theta_d row), grazing limits
/// at the rig's max_theta_deg. Counters: coverage reached, empty valid bins by reason, rig time,
/// and the fraction of filled bins (3 samples or more, both directions at least 11.5 degrees above
/// the horizon) whose mean lies within 3 stated standard errors of the ground truth at the bin's
/// mean position.
void BM_ImageModeMerlCoverage(benchmark::State& state) {
    const int size = static_cast<int>(state.range(0));
    for (auto _ : state) {
        auto rig = start_rig(size, 11);
        if (!rig) {
            state.SkipWithError(rig.error().message.c_str());
            return;
        }
        auto cfg = acquisition::image_campaign_config(
            (*rig)->rig, (*rig)->camera, acquisition::TableLayout::merl(), 0.9, 2000);
        cfg.min_gain_fraction = 1e-5;
        // Grazing limits at the rig's max_theta_deg (85 degrees) instead of the default 80.
        cfg.rules.max_theta_i = cfg.rules.max_theta_o = (*rig)->rig.max_theta_deg * kPi / 180;
        const auto t0 = std::chrono::steady_clock::now();
        auto r = acquisition::run_image_campaign(acquisition::image_rig_capture(**rig, 0.0), cfg);
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (!r) {
            state.SkipWithError(r.error().message.c_str());
            return;
        }
        const auto truth = brdf::make_analytic_brdf(truth_model());
        std::size_t checked = 0;
        std::size_t within = 0;
        for (std::size_t b = 0; b < r->table.size(); ++b) {
            if (r->table.count(b) < 3) {
                continue;
            }
            const auto [wi, wo] = brdf::from_half_diff(r->table.mean_position(b));
            if (wi.z() < 0.2 || wo.z() < 0.2) {
                continue;
            }
            const brdf::Rgbd f = truth->eval(wi, wo);
            const brdf::Rgbd e = r->table.standard_error(b);
            for (int c = 0; c < 3; ++c) {
                ++checked;
                within += std::abs(r->table.mean(b)[c] - f[c]) <= 3 * e[c] ? 1 : 0;
            }
        }
        std::map<std::string, double> by_reason;
        for (const auto& h : r->holes) {
            by_reason[h.reason] += static_cast<double>(h.bins);
        }
        const double valid = static_cast<double>(r->coverage.valid_bins());
        state.counters["frames"] = static_cast<double>(r->frames.size());
        state.counters["coverage"] = r->coverage.fraction();
        state.counters["reachable"] = static_cast<double>(r->reachable_bins) / valid;
        state.counters["blind_zone"] = by_reason["blind zone"] / valid;
        state.counters["arm_limits"] = by_reason["arm limits"] / valid;
        state.counters["grazing"] = by_reason["grazing (beyond max_theta)"] / valid;
        state.counters["finer_than_pixel"] = by_reason["finer than a pixel"] / valid;
        state.counters["not_measured"] = by_reason["not measured"] / valid;
        state.counters["rig_s"] = r->exposure_time_s + light_moves_s(r->frames, 0.0);
        state.counters["wall_s"] = wall;
        state.counters["within_3_sigma"] =
            checked == 0 ? 0.0 : static_cast<double>(within) / static_cast<double>(checked);
    }
}
BENCHMARK(BM_ImageModeMerlCoverage)->Arg(256)->Arg(512)->Iterations(1)->Unit(benchmark::kSecond);

/// Point mode: range(0) configurations at the centres of valid bins of the same table (seeded
/// subset), one per bin, scheduled with the acquisition scheduler; each configuration costs its
/// move plus three 10 ms exposures (one per colour filter). Values are the ground truth plus the
/// noise of a 64-pixel patch mean through the same sensor model.
void BM_PointModeCampaign(benchmark::State& state) {
    const std::size_t n = static_cast<std::size_t>(state.range(0));
    for (auto _ : state) {
        const acquisition::TableLayout l = acquisition::coarse_layout(3);
        std::vector<std::size_t> valid;
        for (std::size_t b = 0; b < l.size(); ++b) {
            if (acquisition::bin_valid(l, b)) {
                const auto [wi, wo] = brdf::from_half_diff(acquisition::bin_centre(l, b));
                // The same limits as image mode: 80 degrees, blind zone 5 degrees.
                if (wi.z() > std::cos(80 * kPi / 180) && wo.z() > std::cos(80 * kPi / 180) &&
                    std::acos(std::clamp(wi.dot(wo), -1.0, 1.0)) >= 5 * kPi / 180) {
                    valid.push_back(b);
                }
            }
        }
        std::mt19937_64 rng(11);
        std::shuffle(valid.begin(), valid.end(), rng);
        valid.resize(std::min(n, valid.size()));
        const acquisition::RigLimits lim;
        const std::array<acquisition::AxisDynamics, acquisition::kNumAxes> dyn{};
        std::vector<brdf::RigPosed> poses;
        brdf::Dataset data;
        data.has_sigma = true;
        const auto truth = brdf::make_analytic_brdf(truth_model());
        sim::SensorParams p;
        sim::SensorModel sensor(p);
        sim::ExposureSettings s;
        std::normal_distribution<double> n01(0, 1);
        brdf::RigPosed at;
        for (std::size_t b : valid) {
            const auto [wi, wo] = brdf::from_half_diff(acquisition::bin_centre(l, b));
            auto sol = acquisition::solve({wi, wo, true, true}, lim, dyn, at);
            if (!sol) {
                continue;
            }
            poses.push_back(sol->pose);
            brdf::Sample smp;
            const auto si = brdf::cartesian_to_spherical(wi);
            const auto so = brdf::cartesian_to_spherical(wo);
            smp.theta_i = si.theta;
            smp.phi_i = si.phi;
            smp.theta_o = so.theta;
            smp.phi_o = so.phi;
            const brdf::Rgbd f = truth->eval(wi, wo);
            for (int c = 0; c < 3; ++c) {
                const double radiance = f[c] * wi.z();
                const double to_f =
                    sensor.e_per_count(s) / (p.responsivity_e_per_s * 0.01 * wi.z());
                const double sigma = std::sqrt(sensor.variance_counts(radiance, s) / 64) * to_f;
                smp.value[c] = std::max(0.0, f[c] + sigma * n01(rng));
                smp.sigma[c] = sigma;
            }
            data.samples.push_back(smp);
        }
        const auto t0 = std::chrono::steady_clock::now();
        const acquisition::Schedule sch = acquisition::schedule(poses, brdf::RigPosed{}, dyn);
        const double plan_wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const double rig_s = sch.planned_s + poses.size() * 3 * 0.01;
        const auto [e_alpha, e_diffuse] = fit_errors(data);
        state.counters["configurations"] = static_cast<double>(poses.size());
        state.counters["covered_bins"] = static_cast<double>(poses.size());
        state.counters["rig_s"] = rig_s;
        state.counters["bins_per_rig_s"] = poses.size() / rig_s;
        state.counters["schedule_wall_s"] = plan_wall;
        state.counters["alpha_rel_err"] = e_alpha;
        state.counters["diffuse_rel_err"] = e_diffuse;
    }
}
BENCHMARK(BM_PointModeCampaign)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

/// Per-frame pipeline throughput: one light position (three channels, white reference, dark
/// frames) on a 512 px sphere image: rendering in the camera, GigE Vision transfer, HDR merge,
/// geometry and binning.
void BM_ImageFrameThroughput(benchmark::State& state) {
    auto rig = start_rig(512, 3);
    if (!rig) {
        state.SkipWithError(rig.error().message.c_str());
        return;
    }
    auto cfg = acquisition::image_campaign_config((*rig)->rig, (*rig)->camera, 1, 1.0, 1);
    std::uint64_t samples = 0;
    for (auto _ : state) {
        auto r = acquisition::run_image_campaign(acquisition::image_rig_capture(**rig, 0.0), cfg);
        if (!r) {
            state.SkipWithError(r.error().message.c_str());
            return;
        }
        samples += r->counts.used;
    }
    state.counters["pixel_samples_per_s"] =
        benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ImageFrameThroughput)->Iterations(2)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
