#include "gonio/acquisition/point/stated_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "gonio/base/check.h"
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

brdf::Rgbd largest_difference_quotient(const std::vector<brdf::Sample>& samples,
                                       std::size_t i,
                                       const std::vector<std::size_t>& near,
                                       bool isotropic) {
    brdf::Rgbd slope = brdf::Rgbd::Zero();
    for (const std::size_t j : near) {
        const double d = configuration_distance(samples[i], samples[j], isotropic);
        // A repeat of the same configuration (a drift reference) says nothing of the slope.
        if (j != i && d > kSameConfiguration) {
            slope = slope.max((samples[j].value - samples[i].value).abs() / d);
        }
    }
    return slope;
}

std::vector<brdf::Rgbd> brdf_slopes(const std::vector<brdf::Sample>& samples, bool isotropic) {
    const std::size_t n = samples.size();
    std::vector<brdf::Rgbd> slopes(n, brdf::Rgbd::Zero());
    std::vector<std::pair<double, std::size_t>> by_distance;
    std::vector<std::size_t> near;
    for (std::size_t i = 0; i < n; ++i) {
        by_distance.clear();
        for (std::size_t j = 0; j < n; ++j) {
            const double d =
                j == i ? 0.0 : configuration_distance(samples[i], samples[j], isotropic);
            if (d > kSameConfiguration) {
                by_distance.emplace_back(d, j);
            }
        }
        const std::size_t k = std::min<std::size_t>(kSlopeNeighbours, by_distance.size());
        std::partial_sort(by_distance.begin(),
                          by_distance.begin() + static_cast<std::ptrdiff_t>(k),
                          by_distance.end());
        near.clear();
        for (std::size_t m = 0; m < k; ++m) {
            near.push_back(by_distance[m].second);
        }
        slopes[i] = largest_difference_quotient(samples, i, near, isotropic);
    }
    return slopes;
}

double budget_direction_sigma(const brdf::RigErrorBudget& budget) {
    return std::hypot(brdf::arm_direction_sigma_rad(budget.light_arm),
                      brdf::arm_direction_sigma_rad(budget.detector_arm));
}

void add_error_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      const std::vector<brdf::Rgbd>& slopes,
                      std::vector<brdf::Sample>* samples) {
    GONIO_CHECK_MSG(slopes.size() == samples->size(),
                    slopes.size() << " slopes for " << samples->size() << " samples");
    const double u_rel = brdf::relative_sigma(budget, hours_since_white);
    const double u_dir = budget_direction_sigma(budget);
    if (u_rel == 0 && u_dir == 0 && budget.stray_light == 0) {
        return;  // the quiet rig: the detector's noise alone
    }
    for (std::size_t i = 0; i < samples->size(); ++i) {
        brdf::Sample& s = (*samples)[i];
        const double u_stray = brdf::stray_light_brdf(budget, std::cos(s.theta_i));
        const brdf::Rgbd rel = s.value.abs() * u_rel;
        const brdf::Rgbd dir = slopes[i] * u_dir;
        s.sigma = (s.sigma.square() + rel.square() + dir.square() + u_stray * u_stray).sqrt();
        GONIO_CHECK_MSG(s.sigma.allFinite(),
                        "stated sigma " << s.sigma.transpose() << " of value "
                                        << s.value.transpose() << ", slope "
                                        << slopes[i].transpose());
    }
}

void add_error_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      bool isotropic,
                      std::vector<brdf::Sample>* samples) {
    const std::vector<brdf::Rgbd> slopes =
        budget_direction_sigma(budget) > 0
            ? brdf_slopes(*samples, isotropic)
            : std::vector<brdf::Rgbd>(samples->size(), brdf::Rgbd::Zero());
    add_error_budget(budget, hours_since_white, slopes, samples);
}

}  // namespace gonio::acquisition
