#include "light_choice.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition::detail {

Expected<SphereGeometry> nominal_sphere(const ImageCampaignConfig& cfg) {
    SphereGeometry sphere;
    sphere.radius_m = cfg.silhouette.radius_m;
    const Eigen::Vector2d c_px = cfg.camera.project(sphere.centre);
    if (!c_px.allFinite()) {
        return make_error("image coverage prediction: the camera does not see the rig origin");
    }
    sphere.silhouette.cx = c_px.x();
    sphere.silhouette.cy = c_px.y();
    if (cfg.camera.projection == Projection::kOrthographic) {
        sphere.silhouette.r = sphere.radius_m * cfg.camera.intrinsics.fx;
    } else {
        // The outline of a sphere at distance d subtends asin(R / d) from the camera centre.
        const double d = (sphere.centre - cfg.camera.centre_world()).norm();
        if (!(d > sphere.radius_m)) {
            return make_error("image coverage prediction: the camera is inside the sphere");
        }
        sphere.silhouette.r = cfg.camera.intrinsics.fx * std::tan(std::asin(sphere.radius_m / d));
    }
    return sphere;
}

/// What bounds the reachable part of the table under this configuration.
HoleLimits hole_limits(const ImageCampaignConfig& cfg) {
    HoleLimits limits;
    limits.blind_zone_rad = cfg.lights.blind_zone_rad;
    limits.max_separation_rad =
        std::min(brdf::kPi,
                 std::max(brdf::arm_separation(cfg.lights.min_rad, cfg.detector_arm_rad),
                          brdf::arm_separation(cfg.lights.max_rad, cfg.detector_arm_rad)));
    limits.max_theta_i = cfg.rules.max_theta_i;
    limits.max_theta_o = cfg.rules.max_theta_o;
    return limits;
}

double front_light(const ImageCampaignConfig& cfg) {
    double best = cfg.lights.min_rad;
    double best_sep = 1e9;
    for (const double a : light_positions(cfg.lights, cfg.detector_arm_rad)) {
        const double sep = brdf::arm_separation(a, cfg.detector_arm_rad);
        if (sep < best_sep) {
            best = a;
            best_sep = sep;
        }
    }
    return best;
}

std::size_t min_gain(const ImageCampaignConfig& cfg, std::size_t valid_bins) {
    return std::max<std::size_t>(
        1, static_cast<std::size_t>(cfg.min_gain_fraction * static_cast<double>(valid_bins)));
}

SphereView sphere_view(const ImageCampaignConfig& cfg,
                       const SphereGeometry& wide_sphere,
                       int placement) {
    SphereView v;
    if (placement == 0) {
        v.camera = cfg.camera;
        v.sphere = wide_sphere;
        v.rules = cfg.rules;
        return v;
    }
    GONIO_CHECK(placement > 0 && placement <= static_cast<int>(cfg.placements.size()));
    const Placement& p = cfg.placements[static_cast<std::size_t>(placement - 1)];
    v.camera = placement_camera(cfg.camera, p);
    v.sphere = placement_sphere(wide_sphere, v.camera, p.magnification);
    v.rules = placement_rules(cfg.rules, p.magnification);
    return v;
}

/// Every view's candidates: the wide view's light positions, then each zoomed placement's at
/// the positions whose highlight it sees (placement_sees_highlight).
std::vector<LightCandidate> view_candidates(const ImageCampaignConfig& cfg,
                                            const SphereGeometry& sphere,
                                            int pixel_stride) {
    std::vector<LightCandidate> out = light_candidates(
        cfg.camera, sphere, cfg.rules, cfg.layout, cfg.detector_arm_rad, cfg.lights, pixel_stride);
    if (cfg.placements.empty()) {
        return out;
    }
    const std::vector<double> lights = light_positions(cfg.lights, cfg.detector_arm_rad);
    for (int k = 1; k <= static_cast<int>(cfg.placements.size()); ++k) {
        const SphereView v = sphere_view(cfg, sphere, k);
        std::vector<double> seen;
        for (double a : lights) {
            if (placement_sees_highlight(v.camera, v.sphere, brdf::arm_direction(a))) {
                seen.push_back(a);
            }
        }
        std::vector<LightCandidate> c =
            light_candidates_at(v.camera, v.sphere, v.rules, cfg.layout, seen, pixel_stride);
        for (LightCandidate& x : c) {
            x.placement = k;
            out.push_back(std::move(x));
        }
    }
    return out;
}

std::vector<PoseCandidate> aniso_candidates(const ImageCampaignConfig& cfg,
                                            const SphereGeometry& sphere) {
    return pose_candidates(cfg.camera,
                           sphere,
                           cfg.rules,
                           cfg.aniso_layout,
                           cfg.detector_arm_rad,
                           cfg.lights,
                           cfg.spins,
                           cfg.pole_rad,
                           std::max(1, cfg.plan_pixel_stride));
}

std::vector<LightCandidate> projected_candidates(const AnisoLayout& layout,
                                                 const std::vector<PoseCandidate>& poses) {
    std::vector<LightCandidate> out;
    for (const PoseCandidate& c : poses) {
        LightCandidate p;
        p.light_arm_rad = c.light_arm_rad;
        for (std::uint32_t b : c.bins) {
            p.bins.push_back(static_cast<std::uint32_t>(layout.iso_bin(b)));
        }
        std::sort(p.bins.begin(), p.bins.end());
        p.bins.erase(std::unique(p.bins.begin(), p.bins.end()), p.bins.end());
        out.push_back(std::move(p));
    }
    return out;
}

void LightChoice::start(const CoverageMap& coverage) {
    gains_ = candidate_gains(open_, coverage);
}

int LightChoice::next(const CoverageMap& coverage, std::string* stop_reason) {
    if (coverage.fraction() >= cfg_.coverage_target) {
        *stop_reason = "coverage target met";
        return -1;
    }
    const std::size_t least = min_gain(cfg_, coverage.valid_bins());
    // The gains of one view kind (wide or zoomed), the others' zero.
    auto of_kind = [&](bool zoomed) {
        std::vector<std::size_t> g(gains_.size(), 0);
        for (std::size_t k = 0; k < open_.size(); ++k) {
            if ((open_[k].placement != 0) == zoomed) {
                g[k] = gains_[k];
            }
        }
        return g;
    };
    if (!zoom_phase_) {
        // Wide frames first; once the wide view's choice adds less than the stop rule's share,
        // only zoomed candidates are chosen from then on.
        const int next = next_light(open_, of_kind(false), light_, cfg_.light_gain_fraction);
        if (next >= 0 && gains_[static_cast<std::size_t>(next)] >= least) {
            return next;
        }
        if (cfg_.placements.empty()) {
            *stop_reason = "no light position adds enough bins";
            return -1;
        }
        zoom_phase_ = true;
    }
    const int next = next_light(open_, of_kind(true), light_, cfg_.light_gain_fraction);
    if (next < 0 || gains_[static_cast<std::size_t>(next)] < least) {
        *stop_reason = "no light position adds enough bins";
        return -1;
    }
    return next;
}

void LightChoice::covered(const CoverageMap& coverage, int theta_d_lo, int theta_d_hi) {
    update_gains(open_, coverage, theta_d_lo, theta_d_hi, &gains_);
}

void LightChoice::resumed(const ImageJournalFrame& f) {
    OpenCandidates::resumed(f);
    // A campaign holding a zoomed frame is in its zoomed phase.
    zoom_phase_ = zoom_phase_ || f.placement > 0;
}

void PoseChoice::start(const AnisoCoverage& coverage) {
    gains_.assign(open_.size(), 0);
    covered(coverage, 0, -1);
}

int PoseChoice::next(const AnisoCoverage& coverage, std::string* stop_reason) {
    if (coverage.fraction() >= cfg_.coverage_target) {
        *stop_reason = "coverage target met";
        return -1;
    }
    const int next = next_pose(open_, gains_, light_, spin_, cfg_.light_gain_fraction);
    if (next < 0 ||
        gains_[static_cast<std::size_t>(next)] < min_gain(cfg_, coverage.valid_bins())) {
        *stop_reason = "no pose adds enough bins";
        return -1;
    }
    return next;
}

void PoseChoice::covered(const AnisoCoverage& coverage, int, int) {
    for (std::size_t k = 0; k < open_.size(); ++k) {
        gains_[k] = coverage.gain(open_[k].bins);
    }
}

}  // namespace gonio::acquisition::detail
