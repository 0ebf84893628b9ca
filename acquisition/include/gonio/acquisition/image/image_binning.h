#pragma once

// Binning of per-pixel BRDF samples into the Rusinkiewicz half/difference table used by the MERL
// database (W. Matusik, H. Pfister, M. Brand, L. McMillan, "A Data-Driven Reflectance Model",
// SIGGRAPH 2003; layout of the distributed files: 90 theta_h x 90 theta_d x 180 phi_d bins).
//
// The bins and their index mapping are those of brdf/table.h (TableGrid): square-root spacing in
// theta_h (dense near the specular peak), linear in theta_d, phi_d folded into [0, pi) by
// reciprocity. Coarser layouts (45 x 45 x 90, ...) keep the same mapping.
//
// Each bin keeps a running mean and variance per channel (B. P. Welford, "Note on a method for
// calculating corrected sums of squares and products", Technometrics 4(3), 1962): memory is the
// table's size whatever the number of frames. The sample variance of a bin holds the noise and the
// BRDF's own variation across the bin; the bin also keeps the mean of the per-pixel noise-model
// variance, so that both the empirical and the model standard error of the mean are available.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/acquisition/image/bin_statistics.h"
#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/table.h"

namespace gonio::acquisition {

/// Bin counts of a half/difference table: the grid of brdf/table.h (same index mapping).
using TableLayout = brdf::TableGrid;

/// MERL divided by `factor` along each axis (factor 2: 45 x 45 x 90).
inline TableLayout coarse_layout(int factor) {
    return {90 / factor, 90 / factor, 180 / factor};
}

/// Flat bin index of a half/difference configuration (TableGrid's mapping, clamped).
std::size_t bin_index(const TableLayout& layout, double theta_h, double theta_d, double phi_d);

/// Centre of a bin in (theta_h, theta_d, phi_d), radians (TableGrid's centres, phi_h = 0).
brdf::HalfDiff<double> bin_centre(const TableLayout& layout, std::size_t index);

/// True when the bin's centre, with phi_h = 0, has both directions strictly above the horizon:
/// the MERL notion of a valid bin (the others can hold no measurement).
bool bin_valid(const TableLayout& layout, std::size_t index);

/// The samples one frame put into one bin, summarised (count, mean, sum of squared deviations,
/// mean model variance, mean position): what the image-mode frame journal stores and what
/// BinnedTable::merge() adds, so that a table rebuilt from the journal equals the one the campaign
/// held.
struct BinAggregate {
    std::uint32_t bin = 0;
    std::uint32_t count = 0;
    std::array<float, 3> mean{};       ///< 1/sr
    std::array<float, 3> m2{};         ///< Sum of squared deviations from the mean, 1/sr^2.
    std::array<float, 3> model_var{};  ///< Mean per-sample noise-model variance, 1/sr^2.
    std::array<float, 3> position{};   ///< Mean theta_h, theta_d, folded phi_d, radians.
};

/// Collects one frame's samples and summarises them per bin (Welford within each bin).
class FrameBins {
  public:
    explicit FrameBins(TableLayout layout) : layout_(layout) {}
    /// Adds one sample (as BinnedTable::add).
    void add(const brdf::Vec3d& wi,
             const brdf::Vec3d& wo,
             const brdf::Rgbd& value,
             const brdf::Rgbd& model_variance);
    std::size_t samples() const { return samples_.size(); }
    /// One aggregate per touched bin, in increasing bin order.
    std::vector<BinAggregate> aggregates() const;

  private:
    struct Entry {
        std::uint32_t bin;
        float position[3];
        double value[3];
        double model_var[3];
    };
    TableLayout layout_;
    std::vector<Entry> samples_;
};

/// Welford accumulator over a half/difference table.
class BinnedTable {
  public:
    explicit BinnedTable(TableLayout layout);

    const TableLayout& layout() const { return layout_; }
    std::size_t size() const { return stats_.size(); }

    /// Adds one sample: the configuration (wi, wo unit vectors in the local frame), the BRDF value
    /// (1/sr) and the per-pixel noise-model variance (1/sr^2, >= 0). Non-finite values are a bug
    /// of the caller and abort.
    void add(const brdf::Vec3d& wi,
             const brdf::Vec3d& wo,
             const brdf::Rgbd& value,
             const brdf::Rgbd& model_variance);
    /// Same, with the bin already known (and its half/difference angles for the bin's mean
    /// position).
    void add_to_bin(std::size_t bin,
                    const brdf::HalfDiff<double>& hd,
                    const brdf::Rgbd& value,
                    const brdf::Rgbd& model_variance);

    /// Adds a group of samples summarised by FrameBins (T. F. Chan, G. H. Golub, R. J. LeVeque,
    /// "Updating formulae and a pairwise algorithm for computing sample variances", 1979: with
    /// delta = mean_b - mean_a, M2 = M2_a + M2_b + delta^2 n_a n_b / n). Aborts on a bin outside
    /// the table or a non-finite value (a journal is checked before its records reach here).
    void merge(const BinAggregate& a);

    std::uint32_t count(std::size_t bin) const { return stats_.count(bin); }
    brdf::Rgbd mean(std::size_t bin) const { return stats_.mean(bin); }
    /// Unbiased sample variance of the bin's values (zero with fewer than two samples).
    brdf::Rgbd sample_variance(std::size_t bin) const { return stats_.sample_variance(bin); }
    /// Standard error of the bin mean from the noise model: sqrt(mean model variance / n).
    brdf::Rgbd model_standard_error(std::size_t bin) const {
        return stats_.model_standard_error(bin);
    }
    /// Standard error of the bin mean: the larger of the empirical sqrt(s^2 / n) (n >= 2) and the
    /// noise-model value, so that a bin of few samples is not overconfident.
    brdf::Rgbd standard_error(std::size_t bin) const { return stats_.standard_error(bin); }
    /// Mean (theta_h, theta_d, phi_d) of the samples in the bin (phi_h = 0).
    brdf::HalfDiff<double> mean_position(std::size_t bin) const;

    /// Number of bins holding at least `min_count` samples.
    std::size_t filled_bins(std::uint32_t min_count = 1) const { return stats_.filled(min_count); }
    std::uint64_t total_samples() const { return stats_.total(); }

    /// One dataset sample per filled bin: directions from the bin's mean position (phi_i = 0 by
    /// isotropy), value = bin mean, sigma = standard_error(), flags kFlagHdr when `hdr`; with
    /// `bins`, each row's bin appended to it. (The campaign's dataset adds the rig's error budget
    /// to these sigmas: bin_uncertainty.h.)
    brdf::Dataset to_dataset(const std::string& source,
                             std::uint32_t min_count,
                             bool hdr,
                             std::vector<std::size_t>* bins = nullptr) const;

  private:
    TableLayout layout_;
    detail::BinStatistics stats_;
    std::vector<float> position_;  // 3 per bin, running mean of theta_h, theta_d, phi_d
};

/// The table's means as a tabulated BRDF (bins with fewer than `min_count` samples invalid), with
/// the MERL channel scales so that brdf::write_merl writes a MERL file.
brdf::TabulatedBrdf to_tabulated(const BinnedTable& table,
                                 std::uint32_t min_count,
                                 const std::string& source);

/// Coverage per (theta_h, theta_d) cell: fraction of its valid phi_d bins that hold at least
/// `min_count` samples, or -1 when the cell has no valid bin. Row-major, theta_d rows.
std::vector<double> coverage_cells(const BinnedTable& table, std::uint32_t min_count = 1);

}  // namespace gonio::acquisition
