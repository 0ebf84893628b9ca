#include "gonio/acquisition/plans/plan.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {

using brdf::Canonical;
using brdf::kPi;
using brdf::Vec3d;

namespace {

constexpr double kDeg = kPi / 180.0;

/// Rounded canonical key so that numerically equal configurations compare equal.
std::tuple<long long, long long, long long> key_of(const Canonical<double>& c) {
    const double q = 1e-7;
    // At theta_i = 0 (or theta_r = 0) the azimuth difference is meaningless.
    const double dphi = (c.theta_i < 1e-9 || c.theta_r < 1e-9) ? 0.0 : c.delta_phi;
    return {std::llround(c.theta_i / q), std::llround(c.theta_r / q), std::llround(dphi / q)};
}

PlannedConfig make_config(const Canonical<double>& c) {
    PlannedConfig p;
    const auto [wi, wo] = brdf::from_canonical(c);
    p.wi = wi;
    p.wo = wo;
    p.isotropic = true;
    return p;
}

void renumber(Plan* plan) {
    for (std::size_t k = 0; k < plan->configs.size(); ++k) {
        plan->configs[k].index = static_cast<std::uint32_t>(k);
    }
}

// A direction: [x, y, z] (any length > 0) or {"theta_deg", "phi_deg"}.
Vec3d dir_from_json(const nlohmann::json& j, const std::string& where) {
    if (j.is_array()) {
        if (j.size() != 3) {
            json_fail(where + ": expected [x, y, z], got an array of " + std::to_string(j.size()));
        }
        Vec3d v;
        for (int c = 0; c < 3; ++c) {
            if (!j[c].is_number() || !std::isfinite(j[c].get<double>()) ||
                std::abs(j[c].get<double>()) > 1e6) {
                json_fail(where + "[" + std::to_string(c) + "]: must be a number in [-1e6, 1e6]");
            }
            v[c] = j[c].get<double>();
        }
        if (!(v.norm() > 1e-9)) {
            json_fail(where + ": zero vector");
        }
        return v.normalized();
    }
    JsonObject f(j, where);
    if (!f.has("theta_deg")) {
        json_fail(where + ": expected [x, y, z] or {\"theta_deg\", \"phi_deg\"}");
    }
    const double theta = f.number("theta_deg", 0, 0, 89.999, "deg") * kDeg;
    const double phi = f.number("phi_deg", 0.0, -360, 360, "deg") * kDeg;
    f.finish();
    return brdf::spherical_to_cartesian(theta, phi);
}

/// Distance between two canonical configurations: the larger of the angles between their light
/// directions and between their view directions, both pairs aligned to phi_i = 0.
double canonical_distance(const Canonical<double>& a, const Canonical<double>& b) {
    const auto [ai, ao] = brdf::from_canonical(a);
    const auto [bi, bo] = brdf::from_canonical(b);
    return std::max(brdf::angle_between(ai, bi), brdf::angle_between(ao, bo));
}

std::array<double, 6> embed(const Canonical<double>& c) {
    const auto [wi, wo] = brdf::from_canonical(c);
    return {wi.x(), wi.y(), wi.z(), wo.x(), wo.y(), wo.z()};
}

}  // namespace

Canonical<double> canonical_of(const PlannedConfig& c) {
    return brdf::to_canonical(c.wi, c.wo);
}

Expected<Plan> plan_uniform(const UniformGridSpec& s) {
    if (s.n_theta < 2 || s.n_dphi < 2) {
        return make_error("uniform plan: n_theta = " + std::to_string(s.n_theta) +
                          ", n_dphi = " + std::to_string(s.n_dphi) + " (both must be >= 2)");
    }
    if (!(s.theta_max > 0 && s.theta_max < kPi / 2)) {
        return make_error("uniform plan: theta_max outside (0, 90) deg");
    }
    // Counted before anything is allocated: theta_i <= theta_r pairs times azimuths.
    const double configs = 0.5 * s.n_theta * (s.n_theta + 1.0) * s.n_dphi;
    if (s.n_theta > kMaxPlanAxis || s.n_dphi > kMaxPlanAxis || configs > kMaxPlanConfigs) {
        return make_error("uniform plan: n_theta = " + std::to_string(s.n_theta) + ", n_dphi = " +
                          std::to_string(s.n_dphi) + " give about " + show_number(configs) +
                          " configurations; at most " + std::to_string(kMaxPlanAxis) +
                          " per axis and " + std::to_string(kMaxPlanConfigs) + " in all");
    }
    if (auto ok = check_memory(configs * sizeof(PlannedConfig) * 2, "uniform plan"); !ok) {
        return tl::unexpected(ok.error());
    }
    Plan plan;
    plan.kind = "uniform";
    for (int a = 0; a < s.n_theta; ++a) {
        const double theta_i = s.theta_max * a / (s.n_theta - 1);
        for (int b = a; b < s.n_theta; ++b) {  // reciprocity: theta_i <= theta_r
            const double theta_r = s.theta_max * b / (s.n_theta - 1);
            for (int c = 0; c < s.n_dphi; ++c) {
                if (a == 0 && c > 0) {
                    // theta_i = 0: wi is the normal, the azimuth difference is meaningless.
                    break;
                }
                const double dphi = kPi * c / (s.n_dphi - 1);
                plan.configs.push_back(make_config({theta_i, theta_r, dphi}));
            }
        }
    }
    const std::uint64_t n_phi = 2 * static_cast<std::uint64_t>(s.n_dphi - 1);
    const std::uint64_t n_t = static_cast<std::uint64_t>(s.n_theta);
    plan.naive_count = n_t * n_t * n_phi * n_phi;
    renumber(&plan);
    return plan;
}

Expected<Plan> plan_half_diff(const HalfDiffSpec& s) {
    if (s.n_theta_h < 1 || s.n_theta_d < 1 || s.n_phi_d < 1) {
        return make_error("half-diff plan: every count must be >= 1");
    }
    const double configs = static_cast<double>(s.n_theta_h) * s.n_theta_d * s.n_phi_d;
    if (s.n_theta_h > kMaxPlanAxis || s.n_theta_d > kMaxPlanAxis || s.n_phi_d > kMaxPlanAxis ||
        configs > kMaxPlanConfigs) {
        return make_error("half-diff plan: " + std::to_string(s.n_theta_h) + " x " +
                          std::to_string(s.n_theta_d) + " x " + std::to_string(s.n_phi_d) + " = " +
                          show_number(configs) + " configurations; at most " +
                          std::to_string(kMaxPlanAxis) + " per axis and " +
                          std::to_string(kMaxPlanConfigs) + " in all");
    }
    if (auto ok = check_memory(configs * (sizeof(PlannedConfig) + 64) * 2, "half-diff plan"); !ok) {
        return tl::unexpected(ok.error());
    }
    Plan plan;
    plan.kind = "half-diff";
    std::set<std::tuple<long long, long long, long long>> seen;
    for (int a = 0; a < s.n_theta_h; ++a) {
        const double u = static_cast<double>(a) / s.n_theta_h;
        const double theta_h = u * u * kPi / 2;
        for (int b = 0; b < s.n_theta_d; ++b) {
            const double theta_d = (kPi / 2) * b / s.n_theta_d;
            for (int c = 0; c < s.n_phi_d; ++c) {
                const double phi_d = kPi * c / s.n_phi_d;
                const auto [wi, wo] =
                    brdf::from_half_diff(brdf::HalfDiff<double>{theta_h, 0.0, theta_d, phi_d});
                const double ti = std::acos(std::clamp(wi.z(), -1.0, 1.0));
                const double to = std::acos(std::clamp(wo.z(), -1.0, 1.0));
                if (!(ti <= s.theta_max && to <= s.theta_max)) {
                    // Below the horizon or beyond the largest polar angle: not a measurable pair.
                    continue;
                }
                const Canonical<double> canon = brdf::to_canonical(wi, wo);
                if (!seen.insert(key_of(canon)).second) {
                    continue;
                }
                plan.configs.push_back(make_config(canon));
            }
        }
    }
    const std::uint64_t n = static_cast<std::uint64_t>(s.n_theta_h) * s.n_theta_d * s.n_phi_d;
    // The naive grid at this resolution: all of phi_h in [0, 2 pi) and phi_d in [0, 2 pi).
    plan.naive_count = n * 2 * static_cast<std::uint64_t>(s.n_phi_d) * 2;
    renumber(&plan);
    return plan;
}

Expected<Scene> read_scene(const std::string& path) {
    Expected<std::string> text = read_input_file(path, kMaxJsonBytes);
    if (!text) {
        return make_error(text.error().message + " (scene file)");
    }
    Scene sc;
    try {
        const nlohmann::json j = parse_json_checked(*text, path);
        JsonObject top(j, "");
        sc.name = top.string("name", path, kMaxNameLength);
        sc.margin = top.number("margin_deg", 5.0, 0, 90, "deg") * kDeg;
        if (top.has("pairs")) {
            const nlohmann::json& pairs = top.raw("pairs");
            if (!pairs.is_array()) {
                json_fail("pairs: expected an array, got " + json_type(pairs));
            }
            if (pairs.size() > kMaxScenePairs) {
                json_fail("pairs: " + std::to_string(pairs.size()) + " pairs, at most " +
                          std::to_string(kMaxScenePairs) + " allowed");
            }
            for (std::size_t k = 0; k < pairs.size(); ++k) {
                const std::string w = "pairs[" + std::to_string(k) + "]";
                JsonObject pf(pairs[k], w);
                sc.pairs.emplace_back(dir_from_json(pf.raw("light"), w + ".light"),
                                      dir_from_json(pf.raw("view"), w + ".view"));
                pf.finish();
                if (sc.pairs.back().first.z() <= 0 || sc.pairs.back().second.z() <= 0) {
                    json_fail(w + ": direction at or below the horizon");
                }
            }
        }
        if (top.has("theta_i_deg") || top.has("theta_r_deg")) {
            auto range = [&](const char* key, double* lo, double* hi) {
                if (!top.has(key)) {
                    json_fail(std::string(key) + ": missing (give both ranges)");
                }
                const nlohmann::json& r = top.raw(key);
                if (!r.is_array() || r.size() != 2 || !r[0].is_number() || !r[1].is_number()) {
                    json_fail(std::string(key) + ": expected [min, max] in deg");
                }
                const double a = r[0].get<double>();
                const double b = r[1].get<double>();
                if (!(a >= 0 && b <= 90 && a <= b)) {
                    json_fail(std::string(key) + " = [" + show_number(a) + ", " + show_number(b) +
                              "]: must satisfy 0 <= min <= max <= 90 deg");
                }
                *lo = a * kDeg;
                *hi = b * kDeg;
            };
            sc.has_ranges = true;
            range("theta_i_deg", &sc.theta_i_min, &sc.theta_i_max);
            range("theta_r_deg", &sc.theta_r_min, &sc.theta_r_max);
        }
        top.finish();
    } catch (const JsonFailure& f) {
        const bool named = f.message.compare(0, path.size(), path) == 0;
        return make_error(named ? f.message : path + ": " + f.message);
    }
    if (sc.pairs.empty() && !sc.has_ranges) {
        return make_error(path + ": a scene needs \"pairs\" or \"theta_i_deg\"/\"theta_r_deg\"");
    }
    return sc;
}

double roi_weight(const Scene& sc, const PlannedConfig& c) {
    const Canonical<double> cc = canonical_of(c);
    // Distance (rad) from the region the scene names exactly: a listed pair, or the theta ranges.
    double distance = std::numeric_limits<double>::infinity();
    for (const auto& [l, v] : sc.pairs) {
        distance = std::min(distance, canonical_distance(cc, brdf::to_canonical(l, v)));
    }
    if (sc.has_ranges) {
        auto outside_by = [&](double ti, double tr) {
            return std::max({0.0,
                             sc.theta_i_min - ti,
                             ti - sc.theta_i_max,
                             sc.theta_r_min - tr,
                             tr - sc.theta_r_max});
        };
        // Reciprocity: the canonical pair may be the scene's pair either way round.
        distance = std::min(
            {distance, outside_by(cc.theta_i, cc.theta_r), outside_by(cc.theta_r, cc.theta_i)});
    }
    if (distance > sc.margin) {
        return 0.0;
    }
    if (sc.margin <= 0) {
        return 1.0;  // no margin: only the exact region, at full weight
    }
    return 1.0 - (1.0 - kRoiMarginEdgeWeight) * distance / sc.margin;
}

bool in_roi(const Scene& sc, const PlannedConfig& c) {
    return roi_weight(sc, c) > 0;
}

void apply_roi(const Scene& sc, Plan* plan) {
    std::vector<PlannedConfig> kept;
    for (PlannedConfig c : plan->configs) {
        if (const double w = roi_weight(sc, c); w > 0) {
            c.flags |= brdf::kFlagRoi;
            c.weight *= w;
            kept.push_back(c);
        } else {
            ++plan->outside_roi;
        }
    }
    plan->configs = std::move(kept);
    renumber(plan);
}

void remove_unreachable(const RigLimits& lim, Plan* plan) {
    std::vector<PlannedConfig> kept;
    kept.reserve(plan->configs.size());
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const brdf::RigPosed rest{};
    for (const PlannedConfig& c : plan->configs) {
        Target t{c.wi, c.wo, c.isotropic, true};
        auto s = solve(t, lim, dyn, rest);
        if (s) {
            kept.push_back(c);
        } else {
            plan->unreachable.push_back({c.wi, c.wo, s.error().message});
        }
    }
    plan->configs = std::move(kept);
    renumber(plan);
}

Plan plan_refine(const std::vector<MeasuredPoint>& measured, const RefineSpec& spec) {
    Plan plan;
    plan.kind = "refine";
    const std::size_t n = measured.size();
    std::vector<std::array<double, 6>> emb(n);
    for (std::size_t k = 0; k < n; ++k) {
        emb[k] = embed(measured[k].c);
    }
    auto dist2 = [&](std::size_t a, std::size_t b) {
        double d = 0;
        for (int q = 0; q < 6; ++q) {
            d += (emb[a][q] - emb[b][q]) * (emb[a][q] - emb[b][q]);
        }
        return d;
    };
    // Scale of the values: a small floor keeps log() finite at zero (black regions, grazing).
    double vmax = 0;
    for (const MeasuredPoint& m : measured) {
        vmax = std::max(vmax, m.value);
    }
    const double eps = std::max(vmax * 1e-4, 1e-12);
    struct Link {
        double score;
        std::size_t a, b;
    };
    std::vector<Link> links;
    std::set<std::pair<std::size_t, std::size_t>> seen_links;
    for (std::size_t a = 0; a < n; ++a) {
        std::vector<std::pair<double, std::size_t>> nb;
        for (std::size_t b = 0; b < n; ++b) {
            if (b != a) {
                nb.emplace_back(dist2(a, b), b);
            }
        }
        const std::size_t kn = std::min<std::size_t>(nb.size(), spec.neighbours);
        std::partial_sort(nb.begin(), nb.begin() + kn, nb.end());
        for (std::size_t q = 0; q < kn; ++q) {
            const std::size_t b = nb[q].second;
            const auto key = std::minmax(a, b);
            if (!seen_links.insert(key).second) {
                continue;
            }
            const double score =
                std::abs(std::log(measured[a].value + eps) - std::log(measured[b].value + eps));
            links.push_back({score, key.first, key.second});
        }
    }
    std::stable_sort(
        links.begin(), links.end(), [](const Link& x, const Link& y) { return x.score > y.score; });
    std::vector<Canonical<double>> placed;
    for (const MeasuredPoint& m : measured) {
        placed.push_back(m.c);
    }
    for (const Link& l : links) {
        if (static_cast<int>(plan.configs.size()) >= spec.budget || l.score < spec.threshold) {
            break;
        }
        const Canonical<double>& ca = measured[l.a].c;
        const Canonical<double>& cb = measured[l.b].c;
        Canonical<double> mid{(ca.theta_i + cb.theta_i) / 2,
                              (ca.theta_r + cb.theta_r) / 2,
                              (ca.delta_phi + cb.delta_phi) / 2};
        if (mid.theta_i > mid.theta_r) {
            std::swap(mid.theta_i, mid.theta_r);
        }
        bool close = false;
        for (const Canonical<double>& p : placed) {
            if (canonical_distance(p, mid) < spec.min_spacing) {
                close = true;
                break;
            }
        }
        if (close) {
            continue;
        }
        placed.push_back(mid);
        plan.configs.push_back(make_config(mid));
    }
    renumber(&plan);
    return plan;
}

}  // namespace gonio::acquisition
