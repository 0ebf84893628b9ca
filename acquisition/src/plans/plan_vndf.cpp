// The adaptive plan of Dupuy and Jakob: retro-reflection, the NDF, the VNDF-warped nodes and the
// RGL file of their measurements (see plan_vndf.h).

#include "gonio/acquisition/plans/plan_vndf.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

namespace gonio::acquisition {

using brdf::kPi;
using brdf::Vec3d;

namespace {

constexpr double kDeg = kPi / 180.0;

double polar(const Vec3d& w) {
    return std::atan2(std::hypot(w.x(), w.y()), w.z());
}

std::string deg_text(double rad) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", rad / kDeg);
    return buf;
}

// The k-th of `count` retro-reflection azimuths over [-pi, pi).
double retro_azimuth(int k, int count) {
    return -kPi + 2.0 * kPi * static_cast<double>(k) / static_cast<double>(count);
}

// (u, f(w, w) cos(theta)) points of one azimuth on the u grid of n nodes (the horizon node 0):
// held below the first point, log-linear in tan^2(theta) between points, f held beyond the last.
std::vector<double> retro_row(std::vector<std::pair<double, double>> pts, std::size_t n) {
    std::sort(pts.begin(), pts.end());
    // Between nodes the logarithm of f cos is interpolated linearly in tan^2(theta): exact for a
    // Beckmann peak (log D linear in tan^2) and close for GGX, where interpolation in u would
    // round the peak off between its first nodes.
    double max_value = 0;
    for (const auto& p : pts) {
        max_value = std::max(max_value, p.second);
    }
    const double tiny = std::max(max_value, 1e-300) * 1e-12;
    auto tan2 = [](double u) {
        const double t = std::tan(brdf::rgl_u_to_theta(u));
        return t * t;
    };
    std::vector<double> grid(n, 0.0);
    const double u_last = pts.back().first;
    const double theta_last = brdf::rgl_u_to_theta(u_last);
    for (std::size_t j = 0; j + 1 < n; ++j) {
        const double u = static_cast<double>(j) / static_cast<double>(n - 1);
        if (u <= pts.front().first) {
            grid[j] = pts.front().second;
        } else if (u >= u_last) {
            // Beyond the last node: f held, so f cos follows cos(theta) to 0 at the horizon.
            const double cos_last = std::cos(theta_last);
            grid[j] = cos_last > 0 ? pts.back().second *
                                         std::max(0.0, std::cos(brdf::rgl_u_to_theta(u))) / cos_last
                                   : 0.0;
        } else {
            const auto hi =
                std::lower_bound(pts.begin(),
                                 pts.end(),
                                 std::make_pair(u, -std::numeric_limits<double>::infinity()));
            const auto lo = hi - 1;
            const double x0 = tan2(lo->first), x1 = tan2(hi->first);
            const double t = x1 > x0 ? (tan2(u) - x0) / (x1 - x0) : 0.0;
            const double l0 = std::log(std::max(lo->second, tiny));
            const double l1 = std::log(std::max(hi->second, tiny));
            grid[j] = std::exp(l0 + t * (l1 - l0));
        }
    }
    grid[n - 1] = 0.0;  // the horizon
    return grid;
}

void renumber(Plan* plan) {
    for (std::size_t k = 0; k < plan->configs.size(); ++k) {
        plan->configs[k].index = static_cast<std::uint32_t>(k);
    }
}

}  // namespace

Expected<void> check_vndf_spec(const VndfSpec& s) {
    auto range = [](const char* field, int v, int lo, int hi) -> Expected<void> {
        if (v < lo || v > hi) {
            return make_error("vndf plan: " + std::string(field) + " = " + std::to_string(v) +
                              " (must be within " + std::to_string(lo) + " to " +
                              std::to_string(hi) + ")");
        }
        return {};
    };
    for (auto r : {range("retro_count", s.retro_count, 4, 512),
                   range("theta_i_count", s.theta_i_count, 2, 64),
                   range("resolution", s.resolution, 4, 128),
                   range("ndf_resolution", s.ndf_resolution, 16, 512),
                   range("retro_phi_count", s.retro_phi_count, 4, 128)}) {
        if (!r) {
            return r;
        }
    }
    if (s.phi_i_count != 0) {
        if (auto r = range("phi_i_count", s.phi_i_count, 2, 64); !r) {
            return make_error(r.error().message + " (0 for an isotropic plan)");
        }
        if (s.ndf_resolution > 128) {
            return make_error("vndf plan: ndf_resolution = " + std::to_string(s.ndf_resolution) +
                              " with phi_i_count = " + std::to_string(s.phi_i_count) +
                              " (an anisotropic NDF grid is at most 128 x 128 nodes)");
        }
    }
    if (!(s.theta_max > 10 * kDeg && s.theta_max <= 89 * kDeg)) {
        return make_error("vndf plan: theta_max = " + deg_text(s.theta_max) +
                          " deg (must be within (10, 89] deg)");
    }
    return {};
}

double vndf_retro_separation(const RigLimits& limits) {
    return limits.blind_angle + kVndfRetroMargin;
}

Expected<Plan> plan_vndf_retro(const VndfSpec& spec, const RigLimits& limits) {
    if (auto ok = check_vndf_spec(spec); !ok) {
        return tl::unexpected(ok.error());
    }
    Plan plan;
    plan.kind = "vndf-retro";
    const double delta = vndf_retro_separation(limits);
    const double theta_max = std::min(spec.theta_max, limits.max_theta);
    const double c = std::cos(delta / 2), s = std::sin(delta / 2);
    const bool aniso = spec.phi_i_count >= 2;
    // u = 1 is the horizon: f cos vanishes there and nothing is measured. An anisotropic plan
    // takes every elevation at retro_phi_count azimuths over the full turn (the pole once).
    for (int j = 0; j + 1 < spec.retro_count; ++j) {
        const double theta = brdf::rgl_u_to_theta(static_cast<double>(j) / (spec.retro_count - 1));
        const int azimuths = aniso && j > 0 ? spec.retro_phi_count : 1;
        for (int k = 0; k < azimuths; ++k) {
            const double phi = aniso ? retro_azimuth(k, spec.retro_phi_count) : 0.0;
            const Vec3d w(
                std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            const Vec3d e(-std::sin(phi), std::cos(phi), 0.0);
            PlannedConfig p;
            p.wi = c * w + s * e;
            p.wo = c * w - s * e;
            p.isotropic = !aniso;
            // The elevation of wi and wo is a little below theta (their half vector is w).
            if (polar(p.wi) > theta_max) {
                plan.unreachable.push_back(
                    {p.wi,
                     p.wo,
                     "retro-reflection at theta " + deg_text(theta) + " deg, phi " + deg_text(phi) +
                         " deg: beyond the largest polar angle " + deg_text(theta_max) + " deg"});
                continue;
            }
            plan.configs.push_back(p);
        }
    }
    plan.naive_count = plan.configs.size();
    renumber(&plan);
    remove_unreachable(limits, &plan);
    return plan;
}

namespace {

/// (u, f(w, w) cos(theta)) of each measurement, checked.
Expected<std::vector<std::pair<double, double>>> retro_points(
    const std::vector<RetroMeasurement>& retro) {
    std::vector<std::pair<double, double>> pts;
    for (std::size_t k = 0; k < retro.size(); ++k) {
        const RetroMeasurement& r = retro[k];
        const Vec3d wi = r.wi.normalized(), wo = r.wo.normalized();
        const double ti = polar(wi), to = polar(wo);
        if (!std::isfinite(r.value) || r.value < 0 || !wi.allFinite() || !wo.allFinite()) {
            return make_error("NDF from retro-reflection: measurement " + std::to_string(k) +
                              " has value " + std::to_string(r.value) +
                              " (must be finite and >= 0)");
        }
        if (std::abs(ti - to) > kVndfRetroElevationTolerance || !(wi.z() > 0) || !(wo.z() > 0)) {
            return make_error("NDF from retro-reflection: measurement " + std::to_string(k) +
                              " has theta_i " + deg_text(ti) + " deg, theta_o " + deg_text(to) +
                              " deg (a retro-reflection pair has equal elevations above the "
                              "horizon)");
        }
        const Vec3d w = (wi + wo).normalized();
        const double theta = polar(w);
        // f(w, w) cos(theta) from the pair whose half vector is w (plan_vndf.h).
        pts.emplace_back(brdf::rgl_theta_to_u(theta), r.value * wi.z() * wo.z() / w.z());
    }
    return pts;
}

/// The logarithm of one retro_row per measured azimuth (the nearest planned one; the pole belongs
/// to all), by azimuth index (empty rows unmeasured); `measured` lists the indices with a row.
std::vector<std::vector<double>> log_rows_by_azimuth(
    const std::vector<RetroMeasurement>& retro,
    const std::vector<std::pair<double, double>>& pts,
    const VndfSpec& spec,
    double tiny,
    std::vector<int>* measured) {
    const std::size_t n = static_cast<std::size_t>(spec.ndf_resolution);
    const int K = spec.retro_phi_count;
    std::vector<std::vector<std::pair<double, double>>> by_azimuth(static_cast<std::size_t>(K));
    std::vector<std::pair<double, double>> pole;
    // The pole node, as measured (the axes' read-back positions), within half the first
    // elevation step of the normal.
    const double pole_theta = 0.5 * brdf::rgl_u_to_theta(1.0 / (spec.retro_count - 1));
    for (std::size_t k = 0; k < pts.size(); ++k) {
        const Vec3d w = (retro[k].wi.normalized() + retro[k].wo.normalized()).normalized();
        if (polar(w) < pole_theta) {
            pole.push_back(pts[k]);
            continue;
        }
        const double phi = std::atan2(w.y(), w.x());
        const long idx = std::lround((phi + kPi) / (2.0 * kPi) * K);
        by_azimuth[static_cast<std::size_t>(((idx % K) + K) % K)].push_back(pts[k]);
    }
    std::vector<std::vector<double>> logs(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k) {
        auto& row = by_azimuth[static_cast<std::size_t>(k)];
        if (row.empty()) {
            continue;
        }
        row.insert(row.end(), pole.begin(), pole.end());
        for (double v : retro_row(row, n)) {
            logs[static_cast<std::size_t>(k)].push_back(std::log(std::max(v, tiny)));
        }
        measured->push_back(k);
    }
    return logs;
}

/// The n x n grid over (azimuth, u) from the measured azimuths' log rows: the periodic
/// Catmull-Rom cubic through the four rows around each grid row's azimuth when every azimuth was
/// measured (the log of a microfacet NDF is smooth in the azimuth; linear interpolation cuts the
/// narrow axis of an anisotropic lobe by tens of percent), else linear between the measured
/// azimuths around it, periodically.
std::vector<double> azimuth_grid(const std::vector<std::vector<double>>& logs,
                                 const std::vector<int>& measured,
                                 std::size_t n) {
    const int K = static_cast<int>(logs.size());
    const bool every_azimuth = static_cast<int>(measured.size()) == K;
    auto row_of = [&](int k) -> const std::vector<double>& {
        return logs[static_cast<std::size_t>(((k % K) + K) % K)];
    };
    std::vector<double> grid(n * n, 0.0);
    for (std::size_t r = 0; r < n; ++r) {
        // The grid row's azimuth in units of the retro azimuth step, in [0, K].
        const double phi = brdf::rgl_u_to_phi(static_cast<double>(r) / static_cast<double>(n - 1));
        const double x = (phi + kPi) / (2.0 * kPi) * K;
        double* out_row = grid.data() + r * n;
        if (every_azimuth) {
            const int i = std::min(static_cast<int>(std::floor(x)), K - 1);
            const double t = x - i;
            const auto &p0 = row_of(i - 1), &p1 = row_of(i), &p2 = row_of(i + 1),
                       &p3 = row_of(i + 2);
            const double t2 = t * t, t3 = t2 * t;
            for (std::size_t j = 0; j + 1 < n; ++j) {
                const double v = 0.5 * (2 * p1[j] + (p2[j] - p0[j]) * t +
                                        (2 * p0[j] - 5 * p1[j] + 4 * p2[j] - p3[j]) * t2 +
                                        (3 * p1[j] - p0[j] - 3 * p2[j] + p3[j]) * t3);
                out_row[j] = std::exp(v);
            }
            continue;
        }
        int lo = measured.back() - K, hi = measured.front() + K;
        for (int m : measured) {
            if (m <= x) {
                lo = m;
            }
        }
        for (auto it = measured.rbegin(); it != measured.rend(); ++it) {
            if (*it >= x) {
                hi = *it;
            }
        }
        const auto& a = row_of(lo);
        const auto& b = row_of(hi);
        const double t = hi > lo ? (x - lo) / static_cast<double>(hi - lo) : 0.0;
        for (std::size_t j = 0; j + 1 < n; ++j) {
            out_row[j] = std::exp(a[j] + t * (b[j] - a[j]));
        }
    }
    return grid;
}

}  // namespace

Expected<VndfNdf> vndf_ndf_from_retro(const std::vector<RetroMeasurement>& retro,
                                      const VndfSpec& spec) {
    if (auto ok = check_vndf_spec(spec); !ok) {
        return tl::unexpected(ok.error());
    }
    if (retro.empty()) {
        return make_error("NDF from retro-reflection: no measurement");
    }
    auto pts = retro_points(retro);
    if (!pts) {
        return tl::unexpected(pts.error());
    }
    double max_value = 0;
    double u_max = 0;
    for (const auto& p : *pts) {
        max_value = std::max(max_value, p.second);
        u_max = std::max(u_max, p.first);
    }
    if (!(max_value > 0)) {
        return make_error(
            "NDF from retro-reflection: every retro-reflection value is 0; no microfacet "
            "distribution to extract");
    }
    const std::size_t n = static_cast<std::size_t>(spec.ndf_resolution);
    brdf::RglWriteOptions o;
    o.ndf_resolution = n;
    std::vector<double> grid;
    if (spec.phi_i_count < 2) {
        grid = retro_row(*pts, n);
    } else {
        o.phi_i_count = static_cast<std::size_t>(spec.phi_i_count);
        std::vector<int> measured;
        const std::vector<std::vector<double>> logs =
            log_rows_by_azimuth(retro, *pts, spec, max_value * 1e-12, &measured);
        if (measured.empty()) {
            return make_error(
                "NDF from retro-reflection: an anisotropic plan needs measurements away from the "
                "normal; only the pole was measured");
        }
        grid = azimuth_grid(logs, measured, n);
    }
    Expected<brdf::RglNdf> ndf = brdf::rgl_ndf_from_retro(grid, o);
    if (!ndf) {
        return tl::unexpected(ndf.error());
    }
    VndfNdf out;
    out.ndf = std::move(*ndf);
    out.measured = retro.size();
    out.theta_last = brdf::rgl_u_to_theta(u_max);
    return out;
}

brdf::RglWriteOptions vndf_file_options(const VndfSpec& spec, const RigLimits& limits) {
    brdf::RglWriteOptions o;
    o.theta_i_count = static_cast<std::size_t>(spec.theta_i_count);
    o.ndf_resolution = static_cast<std::size_t>(spec.ndf_resolution);
    o.rgb_resolution = static_cast<std::size_t>(spec.resolution);
    o.max_theta_i = std::min(spec.theta_max, limits.max_theta);
    o.phi_i_count = spec.phi_i_count >= 2 ? static_cast<std::size_t>(spec.phi_i_count) : 0;
    o.description = o.phi_i_count ? "measured by gonio (vndf plan, anisotropic)"
                                  : "measured by gonio (vndf plan)";
    return o;
}

Expected<VndfLayout> plan_vndf_layout(const brdf::RglNdf& ndf,
                                      const VndfSpec& spec,
                                      const RigLimits& limits) {
    if (auto ok = check_vndf_spec(spec); !ok) {
        return tl::unexpected(ok.error());
    }
    Expected<brdf::RglLayout> layout = brdf::rgl_layout(ndf, vndf_file_options(spec, limits));
    if (!layout) {
        return tl::unexpected(layout.error());
    }
    VndfLayout out;
    out.layout = std::move(*layout);
    out.plan.kind = "vndf";
    const std::size_t N = out.layout.options.rgb_resolution;
    const double theta_max = std::min(spec.theta_max, limits.max_theta);
    // The representative of a node: column 0 is the normal half vector in every row; rows r and
    // N - 1 - r are mirror images (isotropy; row N - 1 repeats row 0's azimuth). Anisotropic: no
    // mirror; row N - 1 is row 0, the last phi_i node the first, and at theta_i = 0 every phi_i
    // node has the same nodes.
    const bool aniso = out.layout.phi_i.size() > 1;
    const std::size_t P = aniso ? out.layout.phi_i.size() - 1 : 1;
    using Key = std::tuple<std::size_t, std::size_t, std::size_t, std::size_t>;
    std::map<Key, int> config_of;  // representative -> index into candidates, or -1
    std::vector<PlannedConfig> candidates;
    out.node_config.assign(out.layout.nodes.size(), -1);
    std::vector<int> candidate_of_node(out.layout.nodes.size(), -1);
    for (std::size_t i = 0; i < out.layout.nodes.size(); ++i) {
        const brdf::RglNode& node = out.layout.nodes[i];
        std::size_t row = node.column == 0 ? 0 : std::min(node.row, N - 1 - node.row);
        std::size_t phi = 0;
        if (aniso) {
            row = node.column == 0 || node.row == N - 1 ? 0 : node.row;
            phi = node.theta_index == 0 ? 0 : node.phi_index % P;
        }
        const Key key{phi, node.theta_index, row, node.column};
        auto it = config_of.find(key);
        if (it == config_of.end()) {
            int idx = -1;
            if (!(node.wo.z() > 0.0)) {
                ++out.below_horizon;
            } else if (polar(node.wo) > theta_max) {
                out.plan.unreachable.push_back(
                    {node.wi,
                     node.wo,
                     (aniso ? "phi_i node " + std::to_string(phi) + ", " : std::string()) +
                         "theta_i node " + std::to_string(node.theta_index) + ", row " +
                         std::to_string(row) + ", column " + std::to_string(node.column) +
                         ": theta_o " + deg_text(polar(node.wo)) +
                         " deg beyond the largest polar angle " + deg_text(theta_max) + " deg"});
            } else {
                PlannedConfig p;
                p.wi = node.wi;
                p.wo = node.wo;
                p.isotropic = !aniso;
                idx = static_cast<int>(candidates.size());
                candidates.push_back(p);
            }
            it = config_of.emplace(key, idx).first;
        }
        candidate_of_node[i] = it->second;
    }
    // Reachability: the candidates in order, those the arms cannot reach listed with why.
    std::vector<int> config_of_candidate(candidates.size(), -1);
    const std::array<AxisDynamics, kNumAxes> dyn{};
    const brdf::RigPosed rest{};
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        const PlannedConfig& c = candidates[k];
        auto s = solve(Target{c.wi, c.wo, c.isotropic, true}, limits, dyn, rest);
        if (!s) {
            out.plan.unreachable.push_back({c.wi, c.wo, s.error().message});
            continue;
        }
        config_of_candidate[k] = static_cast<int>(out.plan.configs.size());
        out.plan.configs.push_back(c);
    }
    for (std::size_t i = 0; i < out.node_config.size(); ++i) {
        const int cand = candidate_of_node[i];
        out.node_config[i] = cand < 0 ? -1 : config_of_candidate[static_cast<std::size_t>(cand)];
    }
    out.plan.naive_count = out.layout.nodes.size();
    renumber(&out.plan);
    return out;
}

Expected<brdf::TensorFile> vndf_tensor(const VndfLayout& L,
                                       const std::vector<brdf::Rgbd>& f_r,
                                       VndfFileReport* report) {
    if (f_r.size() != L.plan.configs.size()) {
        return make_error("vndf file: " + std::to_string(f_r.size()) + " measurements for " +
                          std::to_string(L.plan.configs.size()) + " configurations");
    }
    const auto& nodes = L.layout.nodes;
    const std::size_t N = L.layout.options.rgb_resolution;
    const std::size_t plane = N * N;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    VndfFileReport rep;
    rep.nodes = nodes.size();
    std::vector<brdf::Rgbd> values(nodes.size(), brdf::Rgbd::Constant(nan));
    std::vector<bool> own(nodes.size(), false);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const int c = L.node_config[i];
        if (c >= 0 && f_r[static_cast<std::size_t>(c)].allFinite()) {
            values[i] = f_r[static_cast<std::size_t>(c)].max(0.0);
            own[i] = true;
        }
    }
    // The stored quantity is f_r cos(theta_o) / factor; a filled node takes the neighbour's stored
    // value, so it is carried over in that form.
    std::vector<bool> filled(nodes.size(), false);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const brdf::RglNode& node = nodes[i];
        if (own[i]) {
            ++rep.measured;
            continue;
        }
        if (!(node.wo.z() > 0.0)) {
            ++rep.below_horizon;
            continue;
        }
        const std::size_t slice = node.phi_index * L.layout.theta_i.size() + node.theta_index;
        const std::size_t base = slice * plane;
        double best = std::numeric_limits<double>::infinity();
        std::size_t pick = nodes.size();
        for (std::size_t q = base; q < base + plane; ++q) {
            if (!own[q]) {
                continue;
            }
            const double dr = static_cast<double>(nodes[q].row) - static_cast<double>(node.row);
            const double dc =
                static_cast<double>(nodes[q].column) - static_cast<double>(node.column);
            const double d = dr * dr + dc * dc;
            if (d < best) {
                best = d;
                pick = q;
            }
        }
        if (pick == nodes.size()) {
            return make_error("vndf file: phi_i node " + std::to_string(node.phi_index) +
                              ", theta_i node " + std::to_string(node.theta_index) + " (" +
                              deg_text(L.layout.theta_i[node.theta_index]) +
                              " deg) has no measured node to take a value from");
        }
        const brdf::RglNode& src = nodes[pick];
        const brdf::Rgbd stored = values[pick] * src.wo.z() / src.factor;
        values[i] = stored * node.factor / node.wo.z();
        filled[i] = true;
        ++rep.filled;
    }
    Expected<brdf::TensorFile> file = brdf::rgl_tensor(L.layout, values);
    if (!file) {
        return file;
    }
    // rgl_tensor sets the bit of every stored node: clear it where the value was taken over.
    for (brdf::TensorField& f : file->fields) {
        if (f.name != "valid") {
            continue;
        }
        for (std::size_t i = 0; i < nodes.size(); ++i) {
            if (filled[i]) {
                f.data[i / 8] = static_cast<std::uint8_t>(f.data[i / 8] & ~(0x80u >> (i % 8)));
            }
        }
    }
    if (report != nullptr) {
        *report = rep;
    }
    return file;
}

}  // namespace gonio::acquisition
