#pragma once

// Anisotropic image mode (docs/image-acquisition.md, "Anisotropic samples"): a turned sphere of
// the material (sphere_geometry.h: its tangent is the circle of latitude about the lathe axis),
// photographed at several spins of the sample holder and light-arm positions. Every usable pixel
// gives (wi, wo) in the material's own frame (normal and tangent), binned into a 4-D table.
//
// The 4-D table: the full Rusinkiewicz half/difference coordinates (S. Rusinkiewicz, "A New
// Change of Variables for Efficient BRDF Representation", EGWR 1998) in the material frame,
// (theta_h, phi_h, theta_d, phi_d). theta_h, theta_d and phi_d are binned as the isotropic table
// (brdf/table.h: square-root spacing in theta_h, linear in theta_d, phi_d folded into [0, pi) by
// reciprocity: exchanging wi and wo keeps h and turns d by pi about it, phi_d -> phi_d + pi); phi_h
// is linear over [0, 2 pi): no symmetry of the material is assumed. A bin is valid when its
// isotropic part is (image_binning.h: bin_valid; a turn about the normal keeps both cosines).
//
// Each bin keeps the Welford mean and variance of its values per channel, the mean noise-model
// variance and the mean directions of its samples (wi and wo, after the reciprocity fold that
// puts phi_d in [0, pi), so that the pair stays a pair).
//
// The dataset gets one sample per filled bin: the bin's mean value, at the directions of its
// representative pixel, the one whose value lies closest to the bin's mean (in units of its noise
// sigma). The mean of a curved BRDF over a bin is not its value at the samples' mean directions:
// to second order they differ by half the curvature times the spread of the directions, several
// percent in a bin across a glossy peak and far more than the noise of a bin of tens of pixels,
// which biases a fit by many of its sigmas. The representative pixel is a place in the bin where
// the BRDF takes the bin's mean value up to that pixel's noise, whatever the curvature; its sigma
// is the bin mean's standard error with that pixel's noise and its distance from the mean added
// in quadrature. Representatives of merged groups: the one closer to the merged mean.
//
// Planning: a candidate is a pose (light arm, spin); its predicted bins come from the frame's
// per-pixel geometry, as the isotropic planner's (image_planner.h). The spin turns every pixel's
// tangent, which moves its samples along phi_h; the light arm moves them across theta_d. The
// campaign takes, among the candidates adding at least a fraction of the best candidate's new
// valid bins, the one with the shortest move, until the covered fraction of the valid 4-D bins
// reaches the target or no candidate adds enough.

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/acquisition/image/bin_coverage.h"
#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/image/image_planner.h"
#include "gonio/acquisition/image/sphere_geometry.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {

/// Bin counts of the 4-D table (file comment).
struct AnisoLayout {
    int n_theta_h = 12;
    int n_phi_h = 24;
    int n_theta_d = 8;
    int n_phi_d = 12;

    /// The isotropic part (theta_h x theta_d x phi_d) with brdf/table.h's mapping.
    TableLayout iso() const { return {n_theta_h, n_theta_d, n_phi_d}; }
    std::size_t size() const { return iso().size() * static_cast<std::size_t>(n_phi_h); }
    /// Flat index of (isotropic bin, phi_h bin).
    std::size_t index(std::size_t iso_bin, int i_phi_h) const {
        return iso_bin * static_cast<std::size_t>(n_phi_h) + static_cast<std::size_t>(i_phi_h);
    }
    std::size_t iso_bin(std::size_t flat) const { return flat / static_cast<std::size_t>(n_phi_h); }
    int phi_h_index(double phi_h) const;
    /// Each count in [1, 720].
    bool sane() const;
    std::string describe() const;  ///< "12x24x8x12 (theta_h x phi_h x theta_d x phi_d)"
};

/// The 4-D bin of a pair of unit vectors in the material frame; *swapped is set when the
/// reciprocity fold exchanged them (phi_d was in [pi, 2 pi)).
std::size_t aniso_bin(const AnisoLayout& layout,
                      const brdf::Vec3d& wi,
                      const brdf::Vec3d& wo,
                      bool* swapped = nullptr);

/// Whether the bin's isotropic part is valid (file comment).
bool aniso_bin_valid(const AnisoLayout& layout, std::size_t bin);

/// One frame's samples in one 4-D bin, summarised: what the journal stores.
struct AnisoBinAggregate {
    std::uint32_t bin = 0;
    std::uint32_t count = 0;
    std::array<float, 3> mean{};       ///< 1/sr
    std::array<float, 3> m2{};         ///< Sum of squared deviations from the mean, 1/sr^2.
    std::array<float, 3> model_var{};  ///< Mean noise-model variance, 1/sr^2.
    std::array<float, 3> wi{};         ///< Mean wi (after the fold), material frame, not unit.
    std::array<float, 3> wo{};         ///< Mean wo (after the fold).
    std::array<float, 3> rep_wi{};     ///< The representative pixel's wi (after the fold), unit.
    std::array<float, 3> rep_wo{};     ///< Its wo.
    std::array<float, 3> rep_value{};  ///< Its value, 1/sr.
};

/// Collects one frame's samples and summarises them per bin (Welford within each bin).
class AnisoFrameBins {
  public:
    explicit AnisoFrameBins(AnisoLayout layout) : layout_(layout) {}
    /// One sample: directions in the material frame, the BRDF value and its noise-model variance
    /// (finite: a non-finite value is a bug of the caller and aborts).
    void add(const brdf::Vec3d& wi,
             const brdf::Vec3d& wo,
             const brdf::Rgbd& value,
             const brdf::Rgbd& model_variance);
    std::size_t samples() const { return samples_.size(); }
    /// One aggregate per touched bin, in increasing bin order.
    std::vector<AnisoBinAggregate> aggregates() const;

  private:
    struct Entry {
        std::uint32_t bin;
        double value[3];
        double model_var[3];
        float dirs[6];  ///< wi, then wo (after the fold).
    };
    AnisoLayout layout_;
    std::vector<Entry> samples_;
};

/// Welford accumulator over the 4-D table.
class AnisoTable {
  public:
    explicit AnisoTable(AnisoLayout layout);
    const AnisoLayout& layout() const { return layout_; }
    std::size_t size() const { return stats_.size(); }

    /// Adds a group of samples (Chan, Golub and LeVeque's pairwise update, as
    /// BinnedTable::merge). Aborts on a bin outside the table or a non-finite value.
    void merge(const AnisoBinAggregate& a);

    std::uint32_t count(std::size_t bin) const { return stats_.count(bin); }
    brdf::Rgbd mean(std::size_t bin) const { return stats_.mean(bin); }
    /// Unbiased sample variance (zero with fewer than two samples).
    brdf::Rgbd sample_variance(std::size_t bin) const { return stats_.sample_variance(bin); }
    /// The larger of the empirical sqrt(s^2 / n) (n >= 2) and the noise model's sqrt(var / n).
    brdf::Rgbd standard_error(std::size_t bin) const { return stats_.standard_error(bin); }
    /// Mean directions of the bin's samples, unit (zero for an empty bin).
    std::pair<brdf::Vec3d, brdf::Vec3d> mean_directions(std::size_t bin) const;
    /// The representative pixel's directions (file comment), unit (zero for an empty bin).
    std::pair<brdf::Vec3d, brdf::Vec3d> representative_directions(std::size_t bin) const;
    /// The representative pixel's value.
    brdf::Rgbd representative_value(std::size_t bin) const;
    /// Mean noise-model variance of one sample, 1/sr^2.
    brdf::Rgbd model_variance(std::size_t bin) const { return stats_.model_variance(bin); }
    /// Sigma of the bin's dataset sample: sqrt(standard_error^2 + model_variance +
    /// (representative_value - mean)^2) per channel (file comment).
    brdf::Rgbd dataset_sigma(std::size_t bin) const;
    std::size_t filled_bins(std::uint32_t min_count = 1) const {
        return stats_.filled(std::max<std::uint32_t>(min_count, 1));
    }
    std::uint64_t total_samples() const { return stats_.total(); }

    /// One sample per bin with at least `min_count` samples: full directions (theta_i, phi_i,
    /// theta_o, phi_o) of the representative pixel, value = mean, sigma = dataset_sigma(),
    /// kFlagHdr when `hdr`.
    brdf::Dataset to_dataset(const std::string& source,
                             std::uint32_t min_count,
                             bool hdr,
                             std::vector<std::size_t>* bins = nullptr) const;

  private:
    AnisoLayout layout_;
    detail::BinStatistics stats_;
    std::vector<float> dirs_;  // 6 per bin: running mean of wi, then wo
    std::vector<float> rep_;   // 9 per bin: representative wi, wo, value
};

/// Which valid 4-D bins hold data (BinCoverage: fraction, cover, gain).
class AnisoCoverage : public BinCoverage {
  public:
    explicit AnisoCoverage(const AnisoLayout& layout);
    const AnisoLayout& layout() const { return layout_; }
    /// Marks every bin of the table holding at least `min_count` samples.
    void cover_from(const AnisoTable& table, std::uint32_t min_count);
    /// Covered fraction of the valid bins of each (theta_h, theta_d) cell over phi_h and phi_d,
    /// -1 for a cell without valid bins; row-major with theta_d rows (as coverage_cells()).
    std::vector<double> cells() const;
    /// The isotropic projection: the (theta_h, theta_d, phi_d) bins some phi_h bin of which is
    /// covered.
    CoverageMap isotropic() const;

  private:
    AnisoLayout layout_;
};

/// The holder's spin positions a campaign may use: min, min + step, ... up to max (a full turn
/// counts its start once).
struct SpinRange {
    double min_rad = -brdf::kPi;
    double max_rad = brdf::kPi;
    double step_rad = 7.5 * brdf::kPi / 180;
};

/// The spin positions of a range (file comment of SpinRange).
std::vector<double> spin_positions(const SpinRange& range);

/// One candidate pose and the valid 4-D bins a frame there would fill.
struct PoseCandidate {
    double light_arm_rad = 0;
    double spin_rad = 0;
    std::vector<std::uint32_t> bins;  ///< Sorted, unique.
};

/// Every (light, spin) pose of the ranges outside the blind zone, with its predicted bins (every
/// `pixel_stride`-th pixel row and column, pixels outside the pole caps `pole_rad`, lit within
/// max_theta_i); poses reaching no valid bin are dropped. The holder's tilt stays at 0.
std::vector<PoseCandidate> pose_candidates(const CameraModel& camera,
                                           const SphereGeometry& sphere,
                                           const ExclusionRules& rules,
                                           const AnisoLayout& layout,
                                           double detector_arm_rad,
                                           const LightRange& lights,
                                           const SpinRange& spins,
                                           double pole_rad,
                                           int pixel_stride = 1);

/// Index of the next pose among the candidates with their gains (new valid bins), or -1 when none
/// adds a bin: among the candidates whose gain is at least `gain_fraction` of the largest, the
/// one with the smallest move |d light| + |d spin| (radians) from the current pose.
int next_pose(const std::vector<PoseCandidate>& candidates,
              const std::vector<std::size_t>& gains,
              double current_light_rad,
              double current_spin_rad,
              double gain_fraction);

}  // namespace gonio::acquisition
