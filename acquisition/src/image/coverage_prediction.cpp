#include <algorithm>
#include <cmath>
#include <type_traits>

#include "gonio/acquisition/image/image_campaign.h"
#include "light_choice.h"

namespace gonio::acquisition {
namespace {

/// The campaign's choice of frames (run_image_campaign, step 5) on predicted bins: each chosen
/// candidate's bins are covered as its frame would cover them.
template <class Choice, class Coverage>
void predict_frames(const ImageCampaignConfig& cfg,
                    Choice& choice,
                    Coverage& coverage,
                    ImageCoveragePrediction* p) {
    choice.start(coverage);
    p->stop_reason = "frame limit";
    while (static_cast<int>(p->light_arm_rad.size()) < cfg.max_frames) {
        const int next = choice.next(coverage, &p->stop_reason);
        if (next < 0) {
            break;
        }
        const double light = choice.light();
        [[maybe_unused]] const double spin = choice.spin();
        const auto chosen = choice.take(next);
        p->light_travel_rad += std::abs(chosen.light_arm_rad - light);
        coverage.cover_all(chosen.bins);
        choice.covered(coverage, chosen);
        p->light_arm_rad.push_back(chosen.light_arm_rad);
        p->predicted_coverage.push_back(coverage.fraction());
        if constexpr (std::is_same_v<Coverage, AnisoCoverage>) {
            p->spin_travel_rad += std::abs(chosen.spin_rad - spin);
            p->spin_rad.push_back(chosen.spin_rad);
        } else {
            p->placement.push_back(chosen.placement);
            p->zoomed_frames += chosen.placement != 0 ? 1 : 0;
        }
    }
    p->target_met = coverage.fraction() >= cfg.coverage_target;
    if (p->target_met) {
        p->stop_reason = "coverage target met";
    }
    p->covered_bins = coverage.covered_bins();
}

/// predict_image_coverage() of an anisotropic campaign: the poses run_image_campaign would choose.
void predict_aniso(const ImageCampaignConfig& cfg,
                   const SphereGeometry& sphere,
                   ImageCoveragePrediction* p) {
    detail::PoseChoice choice(cfg, detail::aniso_candidates(cfg, sphere), detail::front_light(cfg));
    p->candidates = choice.open().size();
    AnisoCoverage coverage(cfg.aniso_layout);
    p->valid_bins = coverage.valid_bins();
    p->reachable_bins = detail::reachable_bins(AnisoCoverage(cfg.aniso_layout), choice.open());
    const std::vector<LightCandidate> projected =
        detail::projected_candidates(cfg.aniso_layout, choice.open());
    predict_frames(cfg, choice, coverage, p);
    p->holes = coverage_holes(coverage.isotropic(), projected, detail::hole_limits(cfg));
}

/// predict_image_coverage() of an isotropic campaign: its light positions and placements.
void predict_iso(const ImageCampaignConfig& cfg,
                 const SphereGeometry& sphere,
                 ImageCoveragePrediction* p) {
    // Every pixel (the campaign bins every pixel of a frame, whatever the stride it plans with).
    detail::LightChoice choice(
        cfg, detail::view_candidates(cfg, sphere, 1), detail::front_light(cfg));
    const std::vector<LightCandidate> all_candidates = choice.open();
    p->candidates = all_candidates.size();
    p->candidates_zoomed = static_cast<std::size_t>(
        std::count_if(all_candidates.begin(), all_candidates.end(), [](const LightCandidate& c) {
            return c.placement != 0;
        }));
    CoverageMap coverage(cfg.layout);
    p->valid_bins = coverage.valid_bins();
    p->reachable_bins = detail::reachable_bins(CoverageMap(cfg.layout), all_candidates);
    predict_frames(cfg, choice, coverage, p);
    p->holes = coverage_holes(coverage, all_candidates, detail::hole_limits(cfg));
}

}  // namespace

Expected<ImageCoveragePrediction> predict_image_coverage(const ImageCampaignConfig& cfg) {
    if (!(cfg.silhouette.radius_m > 0) || !(cfg.lights.step_rad > 0)) {
        return make_error(
            "image coverage prediction: the sphere radius and lights.step_rad must "
            "be > 0");
    }
    auto sphere = detail::nominal_sphere(cfg);
    if (!sphere) {
        return tl::unexpected(sphere.error());
    }
    ImageCoveragePrediction p;
    PixelCounts counts;
    p.sphere_pixels = sphere_pixels(cfg.camera, *sphere, cfg.rules, &counts).size();
    if (cfg.anisotropic) {
        predict_aniso(cfg, *sphere, &p);
    } else {
        predict_iso(cfg, *sphere, &p);
    }
    return p;
}

}  // namespace gonio::acquisition
