#pragma once

// Planning of image-mode light positions. The camera stays on the detector arm; the light arm
// moves. For a sphere lit by a distant source and seen from far away, every frame samples (nearly)
// one theta_d = angle(wi, wo) / 2 slice of the half/difference domain, fully in (theta_h, phi_d)
// where both the light and the camera see the surface; which bins a light position reaches is
// predicted exactly by running the frame's per-pixel geometry (sphere_geometry.h) without
// capturing.
//
// Greedy coverage: the coverage map holds which valid bins (image_binning.h: bin_valid) already
// have data; the next light position is the candidate that adds the most uncovered valid bins
// (where coverage is poorest), ties broken by the smallest light-arm move; the campaign may instead
// take the nearest candidate adding nearly as many (light-arm moves dominate its duration).
// Planning stops when the covered fraction of the valid bins reaches the target, when no candidate
// adds a bin, or at the frame limit. Valid bins that stay empty are reported as holes with their
// reason.

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/acquisition/image/bin_coverage.h"
#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/image/sphere_geometry.h"

namespace gonio::acquisition {

struct LightRange {
    double min_rad = -brdf::kPi;  ///< Light-arm soft limits, radians (rig_geometry.h angles).
    double max_rad = brdf::kPi;
    double step_rad = brdf::kPi / 180;  ///< Spacing of the candidate positions.
    /// Blind zone: no light position closer than this to the detector arm (the lamp would
    /// shadow the sample or hit the camera).
    double blind_zone_rad = 5 * brdf::kPi / 180;
};

/// The light positions of the range (min, min + step, ... up to max) outside the blind zone
/// around `detector_arm_rad`, in that order.
std::vector<double> light_positions(const LightRange& range, double detector_arm_rad);

/// One candidate light position and the valid bins a frame there would fill.
struct LightCandidate {
    double light_arm_rad = 0;
    std::vector<std::uint32_t> bins;  ///< Sorted, unique.
    /// theta_d rows its bins lie in (one row for a telecentric camera; a perspective camera's
    /// view directions spread a frame over neighbouring rows). A frame changes the gain only of
    /// candidates sharing a row with it.
    int theta_d_lo = 0;
    int theta_d_hi = -1;
    /// Camera placement (placement.h): 0 the wide view, k the rig's k-th zoomed placement.
    int placement = 0;
};

/// The candidates allowed by the range and blind zone around `detector_arm_rad`, with their
/// predicted bins (every `pixel_stride`-th pixel row and column is evaluated). Candidates reaching
/// no valid bin are dropped.
std::vector<LightCandidate> light_candidates(const CameraModel& camera,
                                             const SphereGeometry& sphere,
                                             const ExclusionRules& rules,
                                             const TableLayout& layout,
                                             double detector_arm_rad,
                                             const LightRange& range,
                                             int pixel_stride = 1);

/// The same at the given light positions (radians), in that order (no range or blind zone
/// applied): a zoomed placement's candidates are the positions whose highlight it sees.
std::vector<LightCandidate> light_candidates_at(const CameraModel& camera,
                                                const SphereGeometry& sphere,
                                                const ExclusionRules& rules,
                                                const TableLayout& layout,
                                                const std::vector<double>& light_arm_rad,
                                                int pixel_stride = 1);

/// Which valid bins of the half/difference table hold data (BinCoverage: fraction, cover, gain).
class CoverageMap : public BinCoverage {
  public:
    explicit CoverageMap(const TableLayout& layout);
    const TableLayout& layout() const { return layout_; }
    /// Marks every bin of the table holding at least `min_count` samples.
    void cover_from(const BinnedTable& table, std::uint32_t min_count);

  private:
    TableLayout layout_;
};

/// Covered share of the valid bins of each (theta_h, theta_d) cell, -1 for a cell without one;
/// row-major with theta_d rows (as coverage_cells() of a table).
std::vector<double> coverage_cells(const CoverageMap& coverage);

/// Index into `candidates` of the next light position, or -1 when no candidate adds a bin. Among
/// the candidates whose gain is at least `gain_fraction` (in (0, 1]) of the largest gain, the one
/// with the smallest light-arm move from `current_light_rad` (1: the largest gain, ties by the
/// move; smaller values trade a little coverage per frame for much shorter moves).
int next_light(const std::vector<LightCandidate>& candidates,
               const CoverageMap& coverage,
               double current_light_rad,
               double gain_fraction = 1.0);

/// New-bin counts of every candidate (CoverageMap::gain), kept up to date by update_gains().
std::vector<std::size_t> candidate_gains(const std::vector<LightCandidate>& candidates,
                                         const CoverageMap& coverage);

/// Recomputes the gains of the candidates sharing a theta_d row with [theta_d_lo, theta_d_hi]
/// (the rows a frame covered): the others cannot have changed. Gains of removed candidates must
/// be removed alongside (same indices as `candidates`).
void update_gains(const std::vector<LightCandidate>& candidates,
                  const CoverageMap& coverage,
                  int theta_d_lo,
                  int theta_d_hi,
                  std::vector<std::size_t>* gains);

/// next_light() over precomputed gains (candidate_gains, update_gains): the same choice without
/// scanning every candidate's bins, so that a 90 x 90 x 180 campaign's hundreds of candidates of
/// ten thousand bins each cost little per frame.
int next_light(const std::vector<LightCandidate>& candidates,
               const std::vector<std::size_t>& gains,
               double current_light_rad,
               double gain_fraction = 1.0);

struct CoveragePlan {
    std::vector<double> light_arm_rad;       ///< In the order chosen.
    std::vector<double> predicted_coverage;  ///< Covered fraction after each light.
    std::size_t valid_bins = 0;
    std::size_t reachable_bins = 0;  ///< Valid bins that some candidate reaches.
    bool target_met = false;
};

/// Greedy plan over predicted coverage (no capture), starting from `start`.
CoveragePlan plan_lights(const std::vector<LightCandidate>& candidates,
                         const TableLayout& layout,
                         double coverage_target,
                         int max_lights,
                         double start_light_rad);

/// What bounds the reachable part of the table, for naming why a bin stays empty.
struct HoleLimits {
    double blind_zone_rad = 0;  ///< Light-detector separations below this are not allowed.
    /// Largest light-detector separation the light arm's limits allow (pi: opposite arms).
    double max_separation_rad = brdf::kPi;
    double max_theta_i = brdf::kPi / 2;  ///< The exclusion rules' limits.
    double max_theta_o = brdf::kPi / 2;
};

/// A group of empty valid bins: one theta_d cell with its empty bin count and the reason.
struct CoverageHole {
    double theta_d_min = 0;  ///< radians
    double theta_d_max = 0;
    double theta_h_min = 0;  ///< over the empty bins of the cell
    double theta_h_max = 0;
    std::size_t bins = 0;
    std::string reason;  ///< "blind zone", "excluded (grazing or limits)", "not measured"
};

/// Holes of the coverage: valid empty bins grouped by theta_d cell. A bin no candidate reaches is
/// "blind zone" when its theta_d is below half the blind zone, else "excluded (grazing or
/// limits)"; a reachable bin still empty is "not measured".
std::vector<CoverageHole> coverage_holes(const CoverageMap& coverage,
                                         const std::vector<LightCandidate>& candidates,
                                         double blind_zone_rad);

/// The same with every reason told apart, for each empty valid bin in this order:
/// - "blind zone": theta_d below half the blind zone (the lamp cannot be that close to the camera);
/// - "arm limits": theta_d above half the largest separation the light arm reaches;
/// - "grazing (beyond max_theta)": the bin's centre needs theta_i and theta_o (in either order,
///   by reciprocity) beyond the exclusion rules' limits;
/// - "finer than a pixel": allowed by all of the above yet no candidate's predicted pixels fall in
///   it (the smallest theta_h bins, narrower than one pixel's footprint on the sphere);
/// - "not measured": some candidate reaches it, no frame was taken there (or its pixels were lost).
std::vector<CoverageHole> coverage_holes(const CoverageMap& coverage,
                                         const std::vector<LightCandidate>& candidates,
                                         const HoleLimits& limits);

/// Writes the coverage of (theta_h, theta_d) cells (coverage_cells()) as a PNG: theta_h along x,
/// theta_d down y, `scale` pixels per cell, colour from dark blue (0) to yellow (1), cells with no
/// valid bin grey.
Expected<void> write_coverage_png(const std::string& path,
                                  const std::vector<double>& cells,
                                  const TableLayout& layout,
                                  int scale = 4);

}  // namespace gonio::acquisition
