#include "gonio/acquisition/point/stated_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "gonio/brdf/coords.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {

namespace {

using brdf::Vec3d;

/// The pair turned to phi_i = 0 and mirrored to phi_o >= 0 (an isotropic BRDF's invariances).
std::pair<Vec3d, Vec3d> folded(const Vec3d& wi, const Vec3d& wo) {
    const double phi_i = std::atan2(wi.y(), wi.x());
    const Vec3d i = brdf::rotate_z(wi, -phi_i);
    Vec3d o = brdf::rotate_z(wo, -phi_i);
    if (o.y() < 0) {
        o.y() = -o.y();
    }
    return {i, o};
}

double pair_distance(const Vec3d& ai, const Vec3d& ao, const Vec3d& bi, const Vec3d& bo) {
    const double di = brdf::angle_between(ai, bi);
    const double dout = brdf::angle_between(ao, bo);
    return std::sqrt(di * di + dout * dout);
}

}  // namespace

double configuration_distance(const brdf::Sample& a, const brdf::Sample& b, bool isotropic) {
    if (!isotropic) {
        return pair_distance(a.wi(), a.wo(), b.wi(), b.wo());
    }
    const auto [ai, ao] = folded(a.wi(), a.wo());
    const auto [bi, bo] = folded(b.wi(), b.wo());
    const auto [ri, ro] = folded(b.wo(), b.wi());  // light and detector exchanged
    return std::min(pair_distance(ai, ao, bi, bo), pair_distance(ai, ao, ri, ro));
}

std::vector<brdf::Rgbd> brdf_slopes(const std::vector<brdf::Sample>& samples, bool isotropic) {
    const std::size_t n = samples.size();
    std::vector<brdf::Rgbd> slopes(n, brdf::Rgbd::Zero());
    std::vector<std::pair<double, std::size_t>> near;
    for (std::size_t i = 0; i < n; ++i) {
        near.clear();
        for (std::size_t j = 0; j < n; ++j) {
            const double d =
                j == i ? 0.0 : configuration_distance(samples[i], samples[j], isotropic);
            // A repeat of the same configuration (a drift reference) says nothing of the slope.
            if (d > 1e-6) {
                near.emplace_back(d, j);
            }
        }
        const std::size_t k = std::min<std::size_t>(kSlopeNeighbours, near.size());
        std::partial_sort(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(k), near.end());
        for (std::size_t m = 0; m < k; ++m) {
            const auto& [d, j] = near[m];
            const brdf::Rgbd q = (samples[j].value - samples[i].value).abs() / d;
            slopes[i] = slopes[i].max(q);
        }
    }
    return slopes;
}

void add_error_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      bool isotropic,
                      std::vector<brdf::Sample>* samples) {
    const double u_rel = brdf::relative_sigma(budget, hours_since_white);
    const double u_dir = std::hypot(brdf::arm_direction_sigma_rad(budget.light_arm),
                                    brdf::arm_direction_sigma_rad(budget.detector_arm));
    if (u_rel == 0 && u_dir == 0 && budget.stray_light == 0) {
        return;  // the quiet rig: the detector's noise alone
    }
    const std::vector<brdf::Rgbd> slopes =
        u_dir > 0 ? brdf_slopes(*samples, isotropic)
                  : std::vector<brdf::Rgbd>(samples->size(), brdf::Rgbd::Zero());
    for (std::size_t i = 0; i < samples->size(); ++i) {
        brdf::Sample& s = (*samples)[i];
        const double u_stray = brdf::stray_light_brdf(budget, std::cos(s.theta_i));
        const brdf::Rgbd rel = s.value.abs() * u_rel;
        const brdf::Rgbd dir = slopes[i] * u_dir;
        s.sigma = (s.sigma.square() + rel.square() + dir.square() + u_stray * u_stray).sqrt();
    }
}

}  // namespace gonio::acquisition
