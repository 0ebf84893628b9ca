// Anisotropic point plans: the four-dimensional grid of (theta_i, phi_i, theta_o, phi_o) in the
// sample's frame, folded by reciprocity and by the symmetry the operator declares.

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/base/limits.h"
#include "gonio/base/strings.h"

namespace gonio::acquisition {

namespace {

using brdf::kPi;
using brdf::Vec3d;

/// A direction of the grid by its indices: polar index a (0 = the normal) and azimuth index k of
/// n_phi around the circle (0 at the normal).
struct GridDir {
    int a = 0;
    int k = 0;
};

/// The key of a configuration: (a_i, k_i, a_o, k_o) with the azimuth index reduced modulo n_phi
/// and set to 0 at the normal, where the azimuth means nothing.
using Key = std::array<int, 4>;

Key key_of(GridDir i, GridDir o, int n_phi) {
    auto norm = [n_phi](GridDir d) {
        d.k = d.a == 0 ? 0 : ((d.k % n_phi) + n_phi) % n_phi;
        return d;
    };
    i = norm(i);
    o = norm(o);
    return {i.a, i.k, o.a, o.k};
}

/// The smallest key of the configuration's orbit under the group the plan folds by: the
/// exchange of light and view (reciprocity, f(wi, wo) = f(wo, wi)) and the declared symmetry of
/// the material:
///   mirror:  reflection across the sample's x axis, phi -> -phi on both directions;
///   2-fold:  a half turn about the normal, phi -> phi + pi on both directions.
Key orbit_key(GridDir i, GridDir o, int n_phi, SampleSymmetry sym) {
    std::vector<std::pair<GridDir, GridDir>> orbit = {{i, o}};
    switch (sym) {
        case SampleSymmetry::kNone:
            break;
        case SampleSymmetry::kMirror:
            orbit.push_back({{i.a, -i.k}, {o.a, -o.k}});
            break;
        case SampleSymmetry::kTwoFold:
            orbit.push_back({{i.a, i.k + n_phi / 2}, {o.a, o.k + n_phi / 2}});
            break;
    }
    Key best = key_of(i, o, n_phi);
    for (const auto& [a, b] : orbit) {
        best = std::min(best, key_of(a, b, n_phi));
        best = std::min(best, key_of(b, a, n_phi));
    }
    return best;
}

}  // namespace

const char* to_string(SampleSymmetry s) {
    switch (s) {
        case SampleSymmetry::kNone:
            return "none";
        case SampleSymmetry::kMirror:
            return "mirror";
        case SampleSymmetry::kTwoFold:
            return "2-fold";
    }
    return "?";
}

Expected<SampleSymmetry> parse_symmetry(const std::string& name) {
    if (name == "none") {
        return SampleSymmetry::kNone;
    }
    if (name == "mirror") {
        return SampleSymmetry::kMirror;
    }
    if (name == "2-fold") {
        return SampleSymmetry::kTwoFold;
    }
    return make_error("symmetry \"" + excerpt(name) + "\": expected none, mirror or 2-fold");
}

Expected<Plan> plan_anisotropic(const AnisotropicGridSpec& s) {
    if (s.n_theta < 2 || s.n_dphi < 2) {
        return make_error("anisotropic plan: n_theta = " + std::to_string(s.n_theta) +
                          ", n_dphi = " + std::to_string(s.n_dphi) + " (both must be >= 2)");
    }
    if (!(s.theta_max > 0 && s.theta_max < kPi / 2)) {
        return make_error("anisotropic plan: theta_max outside (0, 90) deg");
    }
    // Azimuths at the step of pi / (n_dphi - 1) around the whole circle, as the naive grid of the
    // uniform plan; directions: the normal and n_theta - 1 rings of n_phi.
    const int n_phi = 2 * (s.n_dphi - 1);
    const double dirs = 1.0 + (s.n_theta - 1.0) * n_phi;
    // Counted before anything is allocated: at most every ordered pair.
    const double pairs = dirs * dirs;
    if (s.n_theta > kMaxPlanAxis || s.n_dphi > kMaxPlanAxis || pairs / 2 > kMaxPlanConfigs) {
        return make_error("anisotropic plan: n_theta = " + std::to_string(s.n_theta) +
                          ", n_dphi = " + std::to_string(s.n_dphi) + " give about " +
                          show_number(pairs / 2) + " configurations; at most " +
                          std::to_string(kMaxPlanAxis) + " per axis and " +
                          std::to_string(kMaxPlanConfigs) + " in all");
    }
    if (auto ok = check_memory(pairs * (sizeof(PlannedConfig) + sizeof(Key)), "anisotropic plan");
        !ok) {
        return tl::unexpected(ok.error());
    }
    std::vector<GridDir> grid = {{0, 0}};
    for (int a = 1; a < s.n_theta; ++a) {
        for (int k = 0; k < n_phi; ++k) {
            grid.push_back({a, k});
        }
    }
    auto direction = [&](GridDir d) {
        const double theta = s.theta_max * d.a / (s.n_theta - 1);
        return brdf::spherical_to_cartesian(theta, 2 * kPi * d.k / n_phi);
    };
    Plan plan;
    plan.kind = "anisotropic";
    std::set<Key> seen;
    for (const GridDir& gi : grid) {
        for (const GridDir& go : grid) {
            if (!seen.insert(orbit_key(gi, go, n_phi, s.symmetry)).second) {
                // Another member of the orbit is already planned: the material gives the same
                // value there.
                continue;
            }
            PlannedConfig c;
            c.wi = direction(gi);
            c.wo = direction(go);
            // The spin axis turns the sample so that both directions land where asked.
            c.isotropic = false;
            plan.configs.push_back(c);
        }
    }
    const std::uint64_t n_t = static_cast<std::uint64_t>(s.n_theta);
    const std::uint64_t n_p = static_cast<std::uint64_t>(n_phi);
    plan.naive_count = n_t * n_t * n_p * n_p;
    for (std::size_t k = 0; k < plan.configs.size(); ++k) {
        plan.configs[k].index = static_cast<std::uint32_t>(k);
    }
    return plan;
}

}  // namespace gonio::acquisition
