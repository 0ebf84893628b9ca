#include "frame_loop.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gonio/brdf/rig_geometry.h"
#include "light_choice.h"

namespace gonio::acquisition::detail {
namespace {

/// A frame read back from the journal, in the result as when it was captured (its spin is 0 in an
/// isotropic campaign).
void account_journaled_frame(const ImageJournalFrame& f, ImageCampaignResult* result) {
    FrameRecord rec;
    rec.light_arm_rad = f.light_arm_rad;
    rec.spin_rad = f.spin_rad;
    rec.placement = f.placement;
    rec.counts = f.counts;
    rec.exposures = f.exposures;
    rec.coverage_after = f.coverage_after;
    result->counts += f.counts;
    result->frames.push_back(rec);
    result->bracketed = result->bracketed || f.bracketed;
    result->captures += f.captures;
    result->exposure_time_s += f.exposure_time_s;
}

/// The pixels of a frame's pose that give samples, counted as the pixels of a frame are.
struct FramePixels {
    const std::vector<SpherePixel>* pixels = nullptr;
    std::vector<std::uint8_t> lit;
};

/// The isotropic path: light positions in the wide view, then zoomed placements; the
/// half/difference table and its coverage.
class IsoFrames {
  public:
    using Candidate = LightCandidate;

    IsoFrames(const ImageCampaignConfig& cfg, double front, ImageCampaignResult* result)
        : cfg_(cfg),
          result_(result),
          choice_(cfg,
                  view_candidates(cfg, result->sphere, std::max(1, cfg.plan_pixel_stride)),
                  front) {
        all_candidates_ = choice_.open();
        result->reachable_bins = reachable_bins(CoverageMap(cfg.layout), all_candidates_);
        pixels_ = sphere_pixels(cfg.camera, result->sphere, cfg.rules, &geometry_counts_);
        view_rules_ = cfg.rules;
    }

    LightChoice& choice() { return choice_; }
    CoverageMap& coverage() { return result_->coverage; }
    /// Where the rig goes for a candidate: its light position, in its view.
    static CaptureRequest pose_of(const LightCandidate& c) {
        CaptureRequest pose;
        pose.light_arm_rad = c.light_arm_rad;
        pose.placement = c.placement;
        return pose;
    }

    /// A journaled frame merged; its placement must be the one the configuration has under that
    /// number.
    Expected<void> resume(const ImageJournalFrame& f, const std::string& journal_path) {
        if (f.placement > 0) {
            const std::size_t k = static_cast<std::size_t>(f.placement);
            if (k > cfg_.placements.size() ||
                std::abs(cfg_.placements[k - 1].magnification - f.magnification) > 1e-9 ||
                std::abs(cfg_.placements[k - 1].offset_m[0] - f.offset_m[0]) > 1e-12 ||
                std::abs(cfg_.placements[k - 1].offset_m[1] - f.offset_m[1]) > 1e-12) {
                return make_error(journal_path + ": a frame of zoomed placement " +
                                  std::to_string(f.placement) + " (magnification " +
                                  std::to_string(f.magnification) +
                                  ") that the rig description does not have (resume with "
                                  "the campaign's own rig)");
            }
        }
        for (const BinAggregate& a : f.bins) {
            result_->table.merge(a);
        }
        choice_.resumed(f);
        return {};
    }
    void resumed_all() { result_->coverage.cover_from(result_->table, cfg_.min_count); }
    /// The result's view of the coverage (the isotropic path's is the result's own).
    void publish() {}

    /// The pixels of the chosen candidate's view, lit by its light.
    FramePixels pixels(const LightCandidate& c, FrameRecord* rec) {
        if (c.placement != view_placement_) {
            const SphereView v = sphere_view(cfg_, result_->sphere, c.placement);
            geometry_counts_ = PixelCounts{};
            pixels_ = sphere_pixels(v.camera, v.sphere, v.rules, &geometry_counts_);
            view_rules_ = v.rules;
            view_placement_ = c.placement;
        }
        rec->counts = geometry_counts_;
        FramePixels p;
        p.pixels = &pixels_;
        p.lit =
            lit_pixels(pixels_, brdf::arm_direction(c.light_arm_rad), view_rules_, &rec->counts);
        return p;
    }

    /// The frame's samples binned into the journal record.
    void bin(const LightCandidate& c,
             const std::array<HdrSamples, 3>& hdr,
             const FramePixels& p,
             PixelCounts* counts,
             ImageJournalFrame* jf) const {
        const brdf::Vec3d l = brdf::arm_direction(c.light_arm_rad);
        FrameBins frame_bins(cfg_.layout);
        bin_pixels(
            hdr,
            p.lit,
            result_->calibration,
            [&](std::size_t i) { return local_directions((*p.pixels)[i], l); },
            &frame_bins,
            counts);
        if (c.placement > 0) {
            const Placement& pl = cfg_.placements[static_cast<std::size_t>(c.placement - 1)];
            jf->placement = c.placement;
            jf->magnification = pl.magnification;
            jf->offset_m = pl.offset_m;
        }
        jf->bins = frame_bins.aggregates();
    }

    /// The record's bins merged into the table and its coverage; the gains of the candidates
    /// sharing a theta_d row with them updated.
    void merge(const ImageJournalFrame& jf) {
        int rows_lo = cfg_.layout.n_theta_d;
        int rows_hi = -1;
        for (const BinAggregate& b : jf.bins) {
            result_->table.merge(b);
            if (result_->table.count(b.bin) >= std::max<std::uint32_t>(cfg_.min_count, 1)) {
                result_->coverage.cover(b.bin);
            }
            const int i_d = cfg_.layout.unflatten(b.bin)[1];
            rows_lo = std::min(rows_lo, i_d);
            rows_hi = std::max(rows_hi, i_d);
        }
        choice_.covered(result_->coverage, rows_lo, rows_hi);
    }

    std::vector<CoverageHole> holes() const {
        return coverage_holes(result_->coverage, all_candidates_, hole_limits(cfg_));
    }

  private:
    const ImageCampaignConfig& cfg_;
    ImageCampaignResult* result_;
    LightChoice choice_;
    std::vector<LightCandidate> all_candidates_;
    // The pixels of the view in use (the wide view first; a zoomed placement's when a frame
    // needs it).
    int view_placement_ = 0;
    PixelCounts geometry_counts_;
    std::vector<SpherePixel> pixels_;
    ExclusionRules view_rules_;
};

/// The anisotropic path: poses (light arm, spin) in the wide view; the 4-D table and its
/// coverage, the result's `coverage` its isotropic projection.
class AnisoFrames {
  public:
    using Candidate = PoseCandidate;

    AnisoFrames(const ImageCampaignConfig& cfg, double front, ImageCampaignResult* result)
        : cfg_(cfg), result_(result), choice_(cfg, aniso_candidates(cfg, result->sphere), front) {
        pixels_ = sphere_pixels(cfg.camera, result->sphere, cfg.rules, &geometry_counts_);
        result->aniso_table.emplace(cfg.aniso_layout);
        result->aniso_coverage.emplace(cfg.aniso_layout);
        result->reachable_bins = reachable_bins(AnisoCoverage(cfg.aniso_layout), choice_.open());
        projected_ = projected_candidates(cfg.aniso_layout, choice_.open());
    }

    PoseChoice& choice() { return choice_; }
    AnisoCoverage& coverage() { return *result_->aniso_coverage; }
    /// Where the rig goes for a candidate: its light position and the holder's spin.
    static CaptureRequest pose_of(const PoseCandidate& c) {
        CaptureRequest pose;
        pose.light_arm_rad = c.light_arm_rad;
        pose.spin_rad = c.spin_rad;
        return pose;
    }

    Expected<void> resume(const ImageJournalFrame& f, const std::string&) {
        for (const AnisoBinAggregate& a : f.aniso_bins) {
            result_->aniso_table->merge(a);
        }
        choice_.resumed(f);
        return {};
    }
    void resumed_all() { coverage().cover_from(*result_->aniso_table, cfg_.min_count); }
    void publish() { result_->coverage = coverage().isotropic(); }

    /// The lit pixels outside the pole caps at the candidate's spin.
    FramePixels pixels(const PoseCandidate& c, FrameRecord* rec) {
        rec->counts = geometry_counts_;
        FramePixels p;
        p.pixels = &pixels_;
        p.lit = lit_pixels(pixels_, brdf::arm_direction(c.light_arm_rad), cfg_.rules, &rec->counts);
        const brdf::Vec3d axis = lathe_axis_world(0, c.spin_rad);
        tangents_.assign(pixels_.size(), brdf::Vec3d::Zero());
        for (std::size_t i = 0; i < pixels_.size(); ++i) {
            if (!p.lit[i]) {
                continue;
            }
            tangents_[i] = lathe_tangent(pixels_[i].normal, axis, cfg_.pole_rad);
            if (tangents_[i] == brdf::Vec3d::Zero()) {
                // Within a pole cap of the turned sphere: the tangent is not known well enough.
                ++rec->counts.pole;
                p.lit[i] = 0;
            }
        }
        return p;
    }

    void bin(const PoseCandidate& c,
             const std::array<HdrSamples, 3>& hdr,
             const FramePixels& p,
             PixelCounts* counts,
             ImageJournalFrame* jf) const {
        const brdf::Vec3d l = brdf::arm_direction(c.light_arm_rad);
        AnisoFrameBins frame_bins(cfg_.aniso_layout);
        bin_pixels(
            hdr,
            p.lit,
            result_->calibration,
            [&](std::size_t i) { return local_directions(pixels_[i], tangents_[i], l); },
            &frame_bins,
            counts);
        jf->anisotropic = true;
        jf->spin_rad = c.spin_rad;
        jf->aniso_bins = frame_bins.aggregates();
    }

    void merge(const ImageJournalFrame& jf) {
        for (const AnisoBinAggregate& b : jf.aniso_bins) {
            result_->aniso_table->merge(b);
            if (result_->aniso_table->count(b.bin) >= std::max<std::uint32_t>(cfg_.min_count, 1)) {
                coverage().cover(b.bin);
            }
        }
        choice_.covered(coverage(), 0, -1);
    }

    std::vector<CoverageHole> holes() const {
        return coverage_holes(result_->coverage, projected_, hole_limits(cfg_));
    }

  private:
    const ImageCampaignConfig& cfg_;
    ImageCampaignResult* result_;
    PoseChoice choice_;
    std::vector<LightCandidate> projected_;
    PixelCounts geometry_counts_;
    std::vector<SpherePixel> pixels_;
    std::vector<brdf::Vec3d> tangents_;
};

/// Step 4: the frames already journaled merged, their poses taken off the candidates.
template <class Path>
Expected<void> resume_frames(ImageJournal& journal,
                             const std::string& journal_path,
                             Path& path,
                             ImageCampaignResult* result) {
    for (const ImageJournalFrame& f : journal.frames()) {
        if (auto r = path.resume(f, journal_path); !r) {
            return r;
        }
        account_journaled_frame(f, result);
    }
    result->resumed_frames = journal.frames().size();
    path.resumed_all();
    // Merged into the table: the journal's copy of their bins is no longer needed.
    journal.release_frames();
    return {};
}

/// One frame at the chosen candidate: captured in the three channels, binned, merged into the
/// table and made durable in the journal before the arms move on.
template <class Path>
Expected<FrameRecord> take_frame(Rig& rig,
                                 const ImageCampaignConfig& cfg,
                                 std::optional<ImageJournal>& journal,
                                 Path& path,
                                 const typename Path::Candidate& c,
                                 ImageCampaignResult* result) {
    const std::uint64_t captures_before = result->captures;
    const double exposure_before = result->exposure_time_s;
    const CaptureRequest pose = Path::pose_of(c);
    FrameRecord rec;
    rec.light_arm_rad = pose.light_arm_rad;
    rec.spin_rad = pose.spin_rad;
    rec.placement = pose.placement;
    const FramePixels p = path.pixels(c, &rec);
    bool bracketed = false;
    auto hdr = capture_channels(rig, cfg, pose, *p.pixels, p.lit, &rec, &bracketed);
    if (!hdr) {
        return tl::unexpected(hdr.error());
    }
    ImageJournalFrame jf;
    jf.light_arm_rad = c.light_arm_rad;
    path.bin(c, *hdr, p, &rec.counts, &jf);
    jf.exposures = rec.exposures;
    jf.counts = rec.counts;
    jf.bracketed = bracketed;
    jf.captures = result->captures - captures_before;
    jf.exposure_time_s = result->exposure_time_s - exposure_before;
    path.merge(jf);
    result->bracketed = result->bracketed || bracketed;
    rec.coverage_after = path.coverage().fraction();
    jf.coverage_after = rec.coverage_after;
    if (journal) {
        // Durable before the arms move on.
        if (auto w = journal->append_frame(jf); !w) {
            return tl::unexpected(w.error());
        }
    }
    return rec;
}

/// Steps 3 to 5 (file comment) on one path.
template <class Path>
Expected<void> frames_on(Path& path,
                         Rig& rig,
                         const ImageCampaignConfig& cfg,
                         std::optional<ImageJournal>& journal,
                         const std::string& journal_path,
                         const ImageProgressFn& progress,
                         const ImageStateFn& state,
                         ImageCampaignResult* result) {
    if (journal) {
        if (auto r = resume_frames(*journal, journal_path, path, result); !r) {
            return r;
        }
    }
    path.publish();
    path.choice().start(path.coverage());
    result->stop_reason = "frame limit";
    if (state) {
        state(*result);
    }
    while (static_cast<int>(result->frames.size()) < cfg.max_frames) {
        const int next = path.choice().next(path.coverage(), &result->stop_reason);
        if (next < 0) {
            break;
        }
        const typename Path::Candidate c = path.choice().take(next);
        const CaptureRequest pose = Path::pose_of(c);
        rig.set_pose(pose.light_arm_rad, pose.spin_rad, pose.placement);
        auto rec = take_frame(rig, cfg, journal, path, c, result);
        if (!rec) {
            return tl::unexpected(rec.error());
        }
        result->counts += rec->counts;
        result->frames.push_back(*rec);
        path.publish();
        if (progress) {
            progress(result->frames.size() - 1, *rec);
        }
        if (state) {
            state(*result);
        }
    }
    result->target_met = path.coverage().fraction() >= cfg.coverage_target;
    if (result->target_met) {
        result->stop_reason = "coverage target met";
    }
    result->holes = path.holes();
    return {};
}

}  // namespace

Expected<void> run_frames(Rig& rig,
                          const ImageCampaignConfig& cfg,
                          std::optional<ImageJournal>& journal,
                          const std::string& journal_path,
                          double front,
                          const ImageProgressFn& progress,
                          const ImageStateFn& state,
                          ImageCampaignResult* result) {
    if (cfg.anisotropic) {
        AnisoFrames path(cfg, front, result);
        return frames_on(path, rig, cfg, journal, journal_path, progress, state, result);
    }
    IsoFrames path(cfg, front, result);
    return frames_on(path, rig, cfg, journal, journal_path, progress, state, result);
}

}  // namespace gonio::acquisition::detail
