// The vndf plan (Dupuy and Jakob 2018) against the uniform plan and the adaptive plan (uniform grid
// then refinement passes) for the same motion time on the sim4 rig's axis dynamics, on three ground
// truths: glossy (GGX alpha 0.05), rough (GGX alpha 0.4) and anisotropic (axis-aligned GGX alpha_x
// 0.05, alpha_y 0.2), each with a Lambertian part; argument 3 is the rough truth again with the
// vndf plan at 32 x 32 nodes per theta_i.
//
// How it is measured. The plans are built as a campaign builds them (the vndf plan's second pass
// from its own retro-reflection measurements, the adaptive passes from the values measured before
// them); a measurement is the truth at the planned pair times (1 + 0.001 n), n standard normal
// (seeded), the relative noise of the virtual rig's camera at its exposure target. Motion time:
// the configurations solved against the rig's limits and scheduled as the campaign runner does
// (schedule(), 0.2 s of 2-opt), pass after pass from where the previous one ended; exposure and
// transfer time are the same per measurement on every plan and not counted.
//
// What the measurement gives without fitting. The vndf plan: its RGL file (dataset.bsdf),
// evaluated by gonio's reader. The uniform and adaptive plans: scattered measurements, evaluated
// by inverse-distance weighting (1 / d^2, in log f) of the 8 nearest measured configurations in
// the canonical space, each pair embedded as (wi, wo) with phi_i = 0 after the isotropic and
// reciprocal folding.
//
// Error: over 4000 seeded pairs with both elevations up to 75 deg and phi_i uniform, half of them
// within 10 deg of the mirror direction: the median and 90th percentile of |f - f_true| / f_true
// (luminance), and the cosine-weighted relative L2 error sqrt(sum (f - f_true)^2 cos_o^2 / sum
// f_true^2 cos_o^2), which the peak dominates.
//
// BM_AnisotropicVndfAgainstAnisotropicGrid: the same for a brushed lobe turned by 30 degrees, the
// anisotropic vndf plan against the anisotropic grid plan and the isotropic vndf plan.
//
// Run: build/bench/gonio_vndf_plan_bench (a few minutes of CPU).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/plans/plan_vndf.h"
#include "gonio/acquisition/plans/schedule.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/rgl_bsdf.h"

namespace acq = gonio::acquisition;
namespace brdf = gonio::brdf;
using brdf::kPi;
using brdf::Rgbd;
using brdf::Vec3d;

namespace {

constexpr double kDeg = kPi / 180;
constexpr double kNoise = 1e-3;

acq::RigConfig sim4() {
    auto rig = acq::read_rig_config(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    if (!rig) {
        std::fprintf(stderr, "%s\n", rig.error().message.c_str());
        std::abort();
    }
    return *rig;
}

brdf::ModelD truth_model(int which) {
    brdf::ModelD m;
    m.has_diffuse = true;
    brdf::Lobe<double> lobe;
    lobe.distribution = brdf::Distribution::kGgx;
    lobe.shadowing = brdf::Shadowing::kSmithCorrelated;
    lobe.fresnel.type = brdf::FresnelType::kSchlick;
    lobe.fresnel.f0 = Rgbd::Constant(0.04);
    if (which == 0) {
        m.diffuse = Rgbd(0.05, 0.03, 0.02);
        lobe.alpha_x = lobe.alpha_y = 0.05;
    } else if (which == 1) {
        m.diffuse = Rgbd(0.2, 0.15, 0.1);
        lobe.alpha_x = lobe.alpha_y = 0.4;
    } else {
        m.diffuse = Rgbd(0.05, 0.05, 0.05);
        lobe.anisotropic = true;
        lobe.alpha_x = 0.05;
        lobe.alpha_y = 0.2;
    }
    m.lobes.push_back(lobe);
    return m;
}

const char* truth_name(int which) {
    return which == 0 ? "glossy" : which == 1 ? "rough" : "anisotropic";
}

double lum(const Rgbd& c) {
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/// Measures a plan on the truth (seeded relative noise).
std::vector<Rgbd> measure(const acq::Plan& plan, const brdf::Brdf& truth, std::mt19937* rng) {
    std::normal_distribution<double> n(0.0, 1.0);
    std::vector<Rgbd> out;
    for (const acq::PlannedConfig& c : plan.configs) {
        out.push_back(truth.eval(c.wi, c.wo) * (1.0 + kNoise * n(*rng)));
    }
    return out;
}

/// Motion time of a pass from `*pose` (updated to where it ends), as the campaign schedules it.
double motion_s(const acq::Plan& plan, const acq::RigConfig& rig, brdf::RigPosed* pose) {
    const auto lim = acq::rig_limits(rig);
    const auto dyn = acq::rig_dynamics(rig);
    std::vector<brdf::RigPosed> poses;
    brdf::RigPosed prev = *pose;
    for (const acq::PlannedConfig& c : plan.configs) {
        auto s = acq::solve(acq::Target{c.wi, c.wo, c.isotropic, true}, lim, dyn, prev);
        if (s) {
            poses.push_back(s->pose);
            prev = s->pose;
        }
    }
    if (poses.empty()) {
        return 0;
    }
    acq::ScheduleOptions so;
    so.budget_s = 0.2;
    const acq::Schedule s = acq::schedule(poses, *pose, dyn, so);
    *pose = poses[s.order.back()];
    return s.planned_s;
}

struct Pair {
    Vec3d wi, wo;
};

std::vector<Pair> error_pairs() {
    std::mt19937 rng(20261202);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Pair> out;
    while (out.size() < 4000) {
        const double ti = u(rng) * 75 * kDeg;
        const double pi = (2 * u(rng) - 1) * kPi;
        double to = u(rng) * 75 * kDeg;
        double po = (2 * u(rng) - 1) * kPi;
        if (out.size() % 2 == 1) {
            to = ti + (2 * u(rng) - 1) * 10 * kDeg;
            po = pi + kPi + (2 * u(rng) - 1) * 10 * kDeg;
            if (to < 0 || to > 75 * kDeg) {
                continue;
            }
        }
        out.push_back({brdf::spherical_to_cartesian(ti, pi), brdf::spherical_to_cartesian(to, po)});
    }
    return out;
}

struct Errors {
    double median = 0, p90 = 0, l2 = 0;
};

template <class Eval>
Errors errors_of(const brdf::Brdf& truth, const Eval& eval) {
    static const std::vector<Pair> pairs = error_pairs();
    std::vector<double> rel;
    double num = 0, den = 0;
    for (const Pair& p : pairs) {
        const double t = lum(truth.eval(p.wi, p.wo));
        const double f = eval(p.wi, p.wo);
        rel.push_back(std::abs(f - t) / t);
        const double c = p.wo.z();
        num += (f - t) * (f - t) * c * c;
        den += t * t * c * c;
    }
    std::sort(rel.begin(), rel.end());
    return {rel[rel.size() / 2], rel[rel.size() * 9 / 10], std::sqrt(num / den)};
}

/// Scattered measurements evaluated by inverse-distance weighting in the canonical space.
class Scattered {
  public:
    /// fold_isotropy false: anisotropic measurements, embedded as measured (wi, wo) and, by
    /// reciprocity, as (wo, wi); no turn about the normal folds them together.
    explicit Scattered(bool fold_isotropy = true) : fold_(fold_isotropy) {}
    void add(const acq::Plan& plan, const std::vector<Rgbd>& values) {
        for (std::size_t k = 0; k < plan.configs.size(); ++k) {
            const Vec3d& wi = plan.configs[k].wi;
            const Vec3d& wo = plan.configs[k].wo;
            const double lv = std::log(std::max(lum(values[k]), 1e-9));
            pts_.push_back(fold_ ? embed(wi, wo) : raw(wi, wo));
            logv_.push_back(lv);
            if (!fold_) {
                pts_.push_back(raw(wo, wi));
                logv_.push_back(lv);
            }
        }
    }
    double eval(const Vec3d& wi, const Vec3d& wo) const {
        const auto q = fold_ ? embed(wi, wo) : raw(wi, wo);
        std::vector<std::pair<double, std::size_t>> d;
        for (std::size_t k = 0; k < pts_.size(); ++k) {
            double s = 0;
            for (int c = 0; c < 6; ++c) {
                s += (pts_[k][c] - q[c]) * (pts_[k][c] - q[c]);
            }
            d.emplace_back(s, k);
        }
        const std::size_t kn = std::min<std::size_t>(8, d.size());
        std::partial_sort(d.begin(), d.begin() + kn, d.end());
        double wsum = 0, vsum = 0;
        for (std::size_t k = 0; k < kn; ++k) {
            const double w = 1.0 / std::max(d[k].first, 1e-12);
            wsum += w;
            vsum += w * logv_[d[k].second];
        }
        return std::exp(vsum / wsum);
    }
    std::size_t size() const { return fold_ ? pts_.size() : pts_.size() / 2; }

  private:
    static std::array<double, 6> raw(const Vec3d& a, const Vec3d& b) {
        return {a.x(), a.y(), a.z(), b.x(), b.y(), b.z()};
    }
    bool fold_ = true;
    static std::array<double, 6> embed(const Vec3d& wi, const Vec3d& wo) {
        const auto [a, b] = brdf::from_canonical(brdf::to_canonical(wi, wo));
        return {a.x(), a.y(), a.z(), b.x(), b.y(), b.z()};
    }
    std::vector<std::array<double, 6>> pts_;
    std::vector<double> logv_;
};

struct Outcome {
    std::size_t configs = 0;
    double motion_s = 0;
    Errors err;
};

Outcome run_vndf(const brdf::Brdf& truth, const acq::RigConfig& rig, const acq::VndfSpec& spec) {
    std::mt19937 rng(1);
    const auto lim = acq::rig_limits(rig);
    Outcome o;
    brdf::RigPosed pose{};
    auto retro = acq::plan_vndf_retro(spec, lim);
    const std::vector<Rgbd> rv = measure(*retro, truth, &rng);
    std::vector<acq::RetroMeasurement> rm;
    for (std::size_t k = 0; k < rv.size(); ++k) {
        rm.push_back({retro->configs[k].wi, retro->configs[k].wo, lum(rv[k])});
    }
    o.motion_s += motion_s(*retro, rig, &pose);
    auto ndf = acq::vndf_ndf_from_retro(rm, spec);
    auto layout = acq::plan_vndf_layout(ndf->ndf, spec, lim);
    o.motion_s += motion_s(layout->plan, rig, &pose);
    const std::vector<Rgbd> values = measure(layout->plan, truth, &rng);
    auto file = acq::vndf_tensor(*layout, values);
    auto bsdf = brdf::RglBsdf::from_tensor(*file, "vndf");
    if (!bsdf) {
        std::fprintf(stderr, "%s\n", bsdf.error().message.c_str());
        std::abort();
    }
    o.configs = retro->configs.size() + layout->plan.configs.size();
    o.err =
        errors_of(truth, [&](const Vec3d& wi, const Vec3d& wo) { return lum(bsdf->eval(wi, wo)); });
    return o;
}

Outcome run_uniform(const brdf::Brdf& truth, const acq::RigConfig& rig, int n_theta, int n_dphi) {
    std::mt19937 rng(2);
    Outcome o;
    auto plan = acq::plan_uniform({n_theta, 80 * kDeg, n_dphi});
    acq::remove_unreachable(acq::rig_limits(rig), &*plan);
    brdf::RigPosed pose{};
    o.motion_s = motion_s(*plan, rig, &pose);
    Scattered s;
    s.add(*plan, measure(*plan, truth, &rng));
    o.configs = s.size();
    o.err = errors_of(truth, [&](const Vec3d& wi, const Vec3d& wo) { return s.eval(wi, wo); });
    return o;
}

/// A uniform grid of about half the time, then refinement passes of 60 until `motion_budget_s`.
Outcome run_adaptive(const brdf::Brdf& truth, const acq::RigConfig& rig, double motion_budget_s) {
    std::mt19937 rng(3);
    Outcome o;
    const auto lim = acq::rig_limits(rig);
    int n = 4;
    while (n < 40 && run_uniform(truth, rig, n + 1, n).motion_s < 0.5 * motion_budget_s) {
        ++n;
    }
    auto plan = acq::plan_uniform({n, 80 * kDeg, n - 1});
    acq::remove_unreachable(lim, &*plan);
    brdf::RigPosed pose{};
    o.motion_s = motion_s(*plan, rig, &pose);
    Scattered s;
    std::vector<acq::MeasuredPoint> measured;
    auto add = [&](const acq::Plan& p) {
        const std::vector<Rgbd> v = measure(p, truth, &rng);
        s.add(p, v);
        for (std::size_t k = 0; k < p.configs.size(); ++k) {
            measured.push_back({acq::canonical_of(p.configs[k]), lum(v[k])});
        }
    };
    add(*plan);
    acq::RefineSpec rs;
    rs.budget = 60;
    while (o.motion_s < motion_budget_s) {
        acq::Plan refine = acq::plan_refine(measured, rs);
        acq::remove_unreachable(lim, &refine);
        if (refine.configs.empty()) {
            break;
        }
        o.motion_s += motion_s(refine, rig, &pose);
        add(refine);
    }
    o.configs = s.size();
    o.err = errors_of(truth, [&](const Vec3d& wi, const Vec3d& wo) { return s.eval(wi, wo); });
    return o;
}

void report(benchmark::State& state, const char* prefix, const Outcome& o) {
    const std::string p(prefix);
    state.counters[p + "_configs"] = static_cast<double>(o.configs);
    state.counters[p + "_motion_min"] = o.motion_s / 60;
    state.counters[p + "_median"] = o.err.median;
    state.counters[p + "_p90"] = o.err.p90;
    state.counters[p + "_l2"] = o.err.l2;
}

/// One ground truth: the vndf plan at its default resolution, the uniform grid (n x (n - 1)) whose
/// motion time comes closest to it, the adaptive plan with the same motion time; on the glossy
/// truth also the smallest uniform grid whose cosine-weighted error reaches the vndf plan's.
void BM_VndfAgainstUniformAndAdaptive(benchmark::State& state) {
    // 3: the rough truth again with 32 x 32 nodes per theta_i (the vndf plan's resolution).
    const bool fine = state.range(0) == 3;
    const int which = fine ? 1 : static_cast<int>(state.range(0));
    acq::VndfSpec spec;
    spec.resolution = fine ? 32 : spec.resolution;
    const brdf::AnalyticBrdf truth(truth_model(which), truth_name(which));
    const acq::RigConfig rig = sim4();
    Outcome v, u, a;
    int n = 4;
    for (auto _ : state) {
        v = run_vndf(truth, rig, spec);
        n = 4;
        u = run_uniform(truth, rig, n, n - 1);
        while (n < 60) {
            Outcome next = run_uniform(truth, rig, n + 1, n);
            if (std::abs(next.motion_s - v.motion_s) > std::abs(u.motion_s - v.motion_s)) {
                break;
            }
            u = next;
            ++n;
        }
        a = run_adaptive(truth, rig, v.motion_s);
        state.counters["uniform_n_theta"] = n;
    }
    state.SetLabel(fine ? "rough, resolution 32" : truth_name(which));
    report(state, "vndf", v);
    report(state, "uniform", u);
    report(state, "adaptive", a);
    std::printf(
        "%s: vndf %zu configurations, %.1f min motion: median %.4f, p90 %.4f, L2 %.4f | uniform "
        "%d x %d, %zu, %.1f min: median %.4f, p90 %.4f, L2 %.4f | adaptive %zu, %.1f min: median "
        "%.4f, "
        "p90 %.4f, L2 %.4f\n",
        fine ? "rough, vndf resolution 32" : truth_name(which),
        v.configs,
        v.motion_s / 60,
        v.err.median,
        v.err.p90,
        v.err.l2,
        n,
        n - 1,
        u.configs,
        u.motion_s / 60,
        u.err.median,
        u.err.p90,
        u.err.l2,
        a.configs,
        a.motion_s / 60,
        a.err.median,
        a.err.p90,
        a.err.l2);
    if (which == 0) {
        // The uniform grid that reaches the vndf plan's cosine-weighted error, if any below 60.
        for (int m = 4; m <= 60; m += 2) {
            const Outcome g = run_uniform(truth, rig, m, m - 1);
            if (g.err.l2 <= v.err.l2 || m == 60) {
                state.counters["uniform_same_l2_configs"] = static_cast<double>(g.configs);
                state.counters["uniform_same_l2_motion_min"] = g.motion_s / 60;
                std::printf("%s: uniform %d x %d (%zu configurations, %.1f min): L2 %.4f%s\n",
                            truth_name(which),
                            m,
                            m - 1,
                            g.configs,
                            g.motion_s / 60,
                            g.err.l2,
                            g.err.l2 <= v.err.l2
                                ? " (first uniform grid at or below the vndf plan's)"
                                : " (largest grid tried, still above)");
                break;
            }
        }
    }
}
// Anisotropic: brushed GGX alpha 0.05 x 0.2 turned by 30 degrees (the sample mounted at an
// angle) over a Lambert base. The anisotropic vndf plan (retro-reflection at 32 azimuths, 8
// incident azimuths of 8 theta_i x 16 x 16 nodes, an anisotropic dataset.bsdf) against the
// anisotropic grid plan over (theta_i, phi_i, theta_o, phi_o) at the same motion time, its
// measurements interpolated without folding the azimuth.
Outcome run_aniso_grid(const brdf::Brdf& truth,
                       const acq::RigConfig& rig,
                       int n_theta,
                       int n_dphi) {
    std::mt19937 rng(4);
    Outcome o;
    acq::AnisotropicGridSpec g;
    g.n_theta = n_theta;
    g.n_dphi = n_dphi;
    g.theta_max = 80 * kDeg;
    auto plan = acq::plan_anisotropic(g);
    acq::remove_unreachable(acq::rig_limits(rig), &*plan);
    brdf::RigPosed pose{};
    o.motion_s = motion_s(*plan, rig, &pose);
    Scattered s(false);
    s.add(*plan, measure(*plan, truth, &rng));
    o.configs = s.size();
    o.err = errors_of(truth, [&](const Vec3d& wi, const Vec3d& wo) { return s.eval(wi, wo); });
    return o;
}

void BM_AnisotropicVndfAgainstAnisotropicGrid(benchmark::State& state) {
    brdf::ModelD m = truth_model(2);
    m.lobes[0].orientation_deg = 30;
    const brdf::AnalyticBrdf truth(m, "turned brushed");
    const acq::RigConfig rig = sim4();
    acq::VndfSpec spec;
    spec.phi_i_count = acq::kVndfAnisotropicPhiCount;
    spec.ndf_resolution = acq::kVndfAnisotropicNdfResolution;
    Outcome v, iso, g;
    int n = 3;
    for (auto _ : state) {
        v = run_vndf(truth, rig, spec);
        acq::VndfSpec iso_spec;
        iso = run_vndf(truth, rig, iso_spec);
        g = run_aniso_grid(truth, rig, n, n);
        while (n < 30) {
            Outcome next = run_aniso_grid(truth, rig, n + 1, n + 1);
            if (std::abs(next.motion_s - v.motion_s) > std::abs(g.motion_s - v.motion_s)) {
                break;
            }
            g = next;
            ++n;
        }
        state.counters["grid_n"] = n;
    }
    state.SetLabel("turned brushed");
    report(state, "vndf_aniso", v);
    report(state, "vndf_iso", iso);
    report(state, "grid", g);
    std::printf(
        "turned brushed: anisotropic vndf %zu configurations, %.1f min motion: median %.4f, p90 "
        "%.4f, L2 %.4f | isotropic vndf %zu, %.1f min: median %.4f, p90 %.4f, L2 %.4f | "
        "anisotropic grid %d x %d, %zu, %.1f min: median %.4f, p90 %.4f, L2 %.4f\n",
        v.configs,
        v.motion_s / 60,
        v.err.median,
        v.err.p90,
        v.err.l2,
        iso.configs,
        iso.motion_s / 60,
        iso.err.median,
        iso.err.p90,
        iso.err.l2,
        n,
        n,
        g.configs,
        g.motion_s / 60,
        g.err.median,
        g.err.p90,
        g.err.l2);
}
BENCHMARK(BM_AnisotropicVndfAgainstAnisotropicGrid)->Iterations(1)->Unit(benchmark::kSecond);

BENCHMARK(BM_VndfAgainstUniformAndAdaptive)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Arg(3)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
