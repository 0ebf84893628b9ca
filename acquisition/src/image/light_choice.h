#pragma once

// The choice of an image campaign's frames (step 5 of run_image_campaign, and its prediction,
// predict_image_coverage): the candidate poses of each view with their predicted bins, and the
// rule that picks the next one among those still open. Isotropic campaigns choose light positions
// (the wide view first, then zoomed placements) on the half/difference coverage; anisotropic
// ones choose poses (light arm, spin) on the 4-D coverage.

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gonio/acquisition/image/image_campaign.h"
#include "gonio/acquisition/image/image_journal.h"

namespace gonio::acquisition::detail {

/// The nominal sample sphere: radius `silhouette.radius_m` at the rig origin, as the camera model
/// sees it (what the prediction and the memory estimate plan with before any frame).
Expected<SphereGeometry> nominal_sphere(const ImageCampaignConfig& cfg);

/// What bounds the reachable part of the table under this configuration.
HoleLimits hole_limits(const ImageCampaignConfig& cfg);

/// The allowed light position closest to the detector (front lighting for the silhouette).
double front_light(const ImageCampaignConfig& cfg);

/// The smallest gain worth a frame: the stop rule's share of the valid bins, at least 1.
std::size_t min_gain(const ImageCampaignConfig& cfg, std::size_t valid_bins);

/// A view of the sample sphere: the wide view (placement 0) or a zoomed placement, with the
/// sphere and the exclusion rules in its pixels.
struct SphereView {
    CameraModel camera;
    SphereGeometry sphere;
    ExclusionRules rules;
};
SphereView sphere_view(const ImageCampaignConfig& cfg,
                       const SphereGeometry& wide_sphere,
                       int placement);

/// Every view's candidates: the wide view's light positions, then each zoomed placement's at
/// the positions whose highlight it sees (placement_sees_highlight).
std::vector<LightCandidate> view_candidates(const ImageCampaignConfig& cfg,
                                            const SphereGeometry& sphere,
                                            int pixel_stride);

/// The candidate poses of an anisotropic campaign (pose_candidates at the plan's pixel stride).
std::vector<PoseCandidate> aniso_candidates(const ImageCampaignConfig& cfg,
                                            const SphereGeometry& sphere);

/// The poses' candidates projected on the half/difference table (their isotropic bins), for
/// naming the holes of the 4-D coverage's isotropic projection.
std::vector<LightCandidate> projected_candidates(const AnisoLayout& layout,
                                                 const std::vector<PoseCandidate>& poses);

/// The valid bins some candidate reaches.
template <class Coverage, class Candidate>
std::size_t reachable_bins(Coverage coverage, const std::vector<Candidate>& candidates) {
    for (const Candidate& c : candidates) {
        coverage.cover_all(c.bins);
    }
    return coverage.covered_bins();
}

/// The candidates still open with their gains on the campaign's coverage, and the pose the arms
/// are at. Candidate: LightCandidate (isotropic) or PoseCandidate (anisotropic).
template <class Candidate>
class OpenCandidates {
  public:
    OpenCandidates(std::vector<Candidate> candidates, double light)
        : open_(std::move(candidates)), light_(light) {}

    const std::vector<Candidate>& open() const { return open_; }
    double light() const { return light_; }
    double spin() const { return spin_; }
    /// Takes the k-th candidate off the list: the arms go there.
    Candidate take(int k) {
        const std::size_t i = static_cast<std::size_t>(k);
        Candidate c = std::move(open_[i]);
        open_.erase(open_.begin() + k);
        if (!gains_.empty()) {
            gains_.erase(gains_.begin() + k);
        }
        arrive(c);
        return c;
    }
    /// A journaled frame: its pose is taken off the candidates and the arms are there.
    void resumed(const ImageJournalFrame& f) {
        open_.erase(
            std::remove_if(
                open_.begin(), open_.end(), [&](const Candidate& c) { return same_pose(c, f); }),
            open_.end());
        light_ = f.light_arm_rad;
        spin_ = f.spin_rad;
    }

  protected:
    static bool same_pose(const LightCandidate& c, const ImageJournalFrame& f) {
        return std::abs(c.light_arm_rad - f.light_arm_rad) < 1e-9 && c.placement == f.placement;
    }
    static bool same_pose(const PoseCandidate& c, const ImageJournalFrame& f) {
        return std::abs(c.light_arm_rad - f.light_arm_rad) < 1e-9 &&
               std::abs(c.spin_rad - f.spin_rad) < 1e-9;
    }
    void arrive(const LightCandidate& c) { light_ = c.light_arm_rad; }
    void arrive(const PoseCandidate& c) {
        light_ = c.light_arm_rad;
        spin_ = c.spin_rad;
    }

    std::vector<Candidate> open_;
    std::vector<std::size_t> gains_;
    double light_ = 0;
    double spin_ = 0;
};

/// The isotropic rule (next_campaign_light): the nearest wide light position adding at least
/// light_gain_fraction of the best wide gain, until none adds the stop rule's share; then the
/// zoomed placements' the same way. Gains are kept up to date row by row (update_gains).
class LightChoice : public OpenCandidates<LightCandidate> {
  public:
    LightChoice(const ImageCampaignConfig& cfg,
                std::vector<LightCandidate> candidates,
                double front)
        : OpenCandidates(std::move(candidates), front), cfg_(cfg) {}
    /// The gains on the coverage to start from (after the resumed frames).
    void start(const CoverageMap& coverage);
    /// Index of the next candidate, or -1 with the reason the campaign stops.
    int next(const CoverageMap& coverage, std::string* stop_reason);
    /// After bins of the theta_d rows [lo, hi] were covered.
    void covered(const CoverageMap& coverage, int theta_d_lo, int theta_d_hi);
    /// After the chosen candidate's predicted bins were covered.
    void covered(const CoverageMap& coverage, const LightCandidate& chosen) {
        covered(coverage, chosen.theta_d_lo, chosen.theta_d_hi);
    }
    /// A frame of a zoomed placement puts the campaign in its zoomed phase.
    void resumed(const ImageJournalFrame& f);

  private:
    const ImageCampaignConfig& cfg_;
    bool zoom_phase_ = false;
};

/// The anisotropic rule: the nearest pose (light and spin move) adding at least
/// light_gain_fraction of the best gain, until the target or no pose adds the stop rule's share.
class PoseChoice : public OpenCandidates<PoseCandidate> {
  public:
    PoseChoice(const ImageCampaignConfig& cfg, std::vector<PoseCandidate> candidates, double front)
        : OpenCandidates(std::move(candidates), front), cfg_(cfg) {}
    void start(const AnisoCoverage& coverage);
    int next(const AnisoCoverage& coverage, std::string* stop_reason);
    /// After bins were covered (every gain is recomputed: a spin moves bins across all rows).
    void covered(const AnisoCoverage& coverage, int theta_d_lo, int theta_d_hi);
    void covered(const AnisoCoverage& coverage, const PoseCandidate&) { covered(coverage, 0, -1); }

  private:
    const ImageCampaignConfig& cfg_;
};

}  // namespace gonio::acquisition::detail
