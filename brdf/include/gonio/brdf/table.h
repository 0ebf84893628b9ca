#pragma once

// Tabulated isotropic BRDFs over the half/difference grid of the MERL database (W. Matusik, H.
// Pfister, M. Brand, L. McMillan, "A Data-Driven Reflectance Model", SIGGRAPH 2003), at any
// resolution (MERL's own is 90 x 90 x 180).
//
// Coordinates (S. Rusinkiewicz, "A New Change of Variables for Efficient BRDF Representation", EGWR
// 1998): theta_h in [0, pi/2], theta_d in [0, pi/2], phi_d folded into [0, pi): phi_d and phi_d +
// pi describe the same pair with wi and wo swapped, equal by reciprocity.
//
// Bins (docs/file-formats-tables.md). With n_h, n_d, n_p bins per axis:
//   i_h = floor(sqrt(theta_h / (pi/2)) * n_h)    clamped to [0, n_h - 1]  (finer near the specular peak)
//   i_d = floor(theta_d / (pi/2) * n_d)          clamped to [0, n_d - 1]
//   i_p = floor(phi_d' / pi * n_p)               clamped to [0, n_p - 1], phi_d' = phi_d + pi if < 0
//   flat index = i_p + n_p * (i_d + n_d * i_h)
// The centre of a bin is the midpoint of its interval in the index variable:
//   theta_h = ((i_h + 1/2) / n_h)^2 pi/2,  theta_d = (i_d + 1/2) / n_d pi/2,  phi_d = (i_p + 1/2) / n_p pi.
// Writing a table from a model evaluates at these centres; nearest lookup returns the bin
// containing the query; trilinear interpolation is linear in the three index variables between
// centres, with theta_h and theta_d clamped at the first/last centre and phi_d periodic with period
// pi.
//
// Values are kept as stored ("raw") together with a per-channel scale so that a file read and
// written again gives the same bytes: f [1/sr] = raw * scale. A bin is valid when its three raw
// values are >= 0; negative raw values mean "not measured". Invalid bins never produce a value: a
// nearest lookup in an invalid bin gives 0 with TableLookup::valid = false; trilinear interpolation
// uses the valid corners only (weights renormalised) and gives 0, valid = false, when none is.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gonio/base/huge_pages.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// Largest BRDF value [1/sr] a table stores (docs/file-formats-tables.md, "Limits"): a million
/// times the peak of a polished metal, small enough that sums and scaled raw values stay finite.
constexpr double kMaxTableValue = 1e12;

/// Resolution of a half/difference table and its index mapping (see the file comment).
struct TableGrid {
    int n_theta_h = 90;
    int n_theta_d = 90;
    int n_phi_d = 180;

    /// MERL's 90 x 90 x 180.
    static TableGrid merl() { return {90, 90, 180}; }

    /// Number of bins.
    std::size_t size() const {
        return static_cast<std::size_t>(n_theta_h) * static_cast<std::size_t>(n_theta_d) *
               static_cast<std::size_t>(n_phi_d);
    }
    /// Flat index of bin (i_h, i_d, i_p).
    std::size_t index(int i_h, int i_d, int i_p) const {
        return static_cast<std::size_t>(i_p) +
               static_cast<std::size_t>(n_phi_d) *
                   (static_cast<std::size_t>(i_d) +
                    static_cast<std::size_t>(n_theta_d) * static_cast<std::size_t>(i_h));
    }
    /// Inverse of index(): {i_h, i_d, i_p}.
    std::array<int, 3> unflatten(std::size_t flat) const {
        const int i_p = static_cast<int>(flat % static_cast<std::size_t>(n_phi_d));
        flat /= static_cast<std::size_t>(n_phi_d);
        const int i_d = static_cast<int>(flat % static_cast<std::size_t>(n_theta_d));
        const int i_h = static_cast<int>(flat / static_cast<std::size_t>(n_theta_d));
        return {i_h, i_d, i_p};
    }

    /// Bin of theta_h (radians); NaN and theta_h <= 0 give bin 0, theta_h >= pi/2 the last bin.
    int theta_h_index(double theta_h) const;
    /// Bin of theta_d (radians), clamped as theta_h_index().
    int theta_d_index(double theta_d) const;
    /// Bin of phi_d (radians, any value in [-pi, pi]); negative phi_d is shifted by pi first;
    /// phi_d = pi (and anything beyond) falls in the last bin, as in the classic MERL reader.
    int phi_d_index(double phi_d) const;

    double theta_h_centre(int i_h) const;
    double theta_d_centre(int i_d) const;
    double phi_d_centre(int i_p) const;

    /// Continuous index coordinates (bin centres at integers): u_h = sqrt(theta_h/(pi/2)) n_h -
    /// 1/2, u_d = theta_d/(pi/2) n_d - 1/2, u_p = phi_d'/pi n_p - 1/2, phi_d' folded into [0, pi).
    std::array<double, 3> continuous_index(double theta_h, double theta_d, double phi_d) const;

    /// wi and wo at the centre of a bin, with phi_h = 0 (the table is isotropic). Either may be at
    /// or below the horizon: the half/difference box contains such pairs.
    std::pair<Vec3d, Vec3d> centre_directions(int i_h, int i_d, int i_p) const;
};

/// How TabulatedBrdf::eval reads between bins.
enum class Interpolation {
    kNearest,    ///< The value of the bin containing the query (the classic MERL reader).
    kTrilinear,  ///< Trilinear in the index variables between bin centres, valid corners only.
};

/// One lookup: the value in 1/sr and whether it comes from valid data (else value is 0).
struct TableLookup {
    Rgbd value = Rgbd::Zero();
    bool valid = false;
};

/// Valid-bin count and per-channel min/max/mean (1/sr) over the valid bins.
struct TableStatistics {
    std::size_t bins = 0;
    std::size_t valid_bins = 0;
    Rgbd min = Rgbd::Zero();
    Rgbd max = Rgbd::Zero();
    Rgbd mean = Rgbd::Zero();
};

/// A table's stored values (see TabulatedBrdf's constructor). Resizing leaves them unwritten, so
/// that a reader or a tabulation writes each of the 35 MB of a MERL table once.
using TableValues = UninitVector<double>;

/// What TabulatedBrdf::set_line() did with its bins.
struct LineStoreCounts {
    std::size_t valid = 0;          ///< stored
    std::size_t no_reflection = 0;  ///< not a reflection configuration: left not measured
    std::size_t non_finite = 0;     ///< a value was NaN or infinite: left not measured
    std::size_t out_of_range = 0;   ///< a value above kMaxTableValue: left not measured
};

/// An isotropic BRDF tabulated over a half/difference grid (see the file comment).
class TabulatedBrdf : public Brdf {
  public:
    /// raw holds 3 * grid.size() values, all red then all green then all blue, each block in flat
    /// index order; every entry finite (checked: readers reject non-finite data before this).
    /// scale converts raw to 1/sr per channel (MERL: 1/1500, 1.15/1500, 1.66/1500; else 1).
    TabulatedBrdf(TableGrid grid, std::array<double, 3> scale, TableValues raw, std::string source);

    /// A table with every bin invalid (raw -1), to be filled with set_bin().
    static TabulatedBrdf empty(TableGrid grid, std::array<double, 3> scale, std::string source);
    /// A table whose bins are not written yet: every bin must be written once (set_line(),
    /// set_bin() or set_bin_invalid()) before the table is read. For a tabulation that writes
    /// every bin: the values are written once, not first as "not measured".
    static TabulatedBrdf unwritten(TableGrid grid, std::array<double, 3> scale, std::string source);

    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override;
    bool isotropic() const override { return true; }
    std::string describe() const override;
    std::string statistics() const override;

    /// Value at (wi, wo) with validity; zero and invalid when either direction is at or below the
    /// horizon.
    TableLookup lookup(const Vec3d& wi, const Vec3d& wo) const;
    /// Value at half/difference angles (radians), with the mode set by set_interpolation().
    TableLookup lookup_half_diff(double theta_h, double theta_d, double phi_d) const;
    TableLookup lookup_nearest(double theta_h, double theta_d, double phi_d) const;
    TableLookup lookup_trilinear(double theta_h, double theta_d, double phi_d) const;

    void set_interpolation(Interpolation mode) { interpolation_ = mode; }
    Interpolation interpolation() const { return interpolation_; }

    const TableGrid& grid() const { return grid_; }
    const std::array<double, 3>& scale() const { return scale_; }
    /// Stored values (see the constructor); unchanged by reading and writing.
    const TableValues& raw() const { return raw_; }
    const std::string& source() const { return source_; }

    bool bin_valid(std::size_t flat) const { return valid_[flat] != 0; }
    /// Value of a bin in 1/sr (meaningful only when valid).
    Rgbd bin_value(std::size_t flat) const;
    /// Stores a value in 1/sr (finite, >= 0, value / scale finite: checked) and marks the bin
    /// valid.
    void set_bin(std::size_t flat, const Rgbd& value);
    /// Marks a bin as not measured (raw -1 in every channel).
    void set_bin_invalid(std::size_t flat);
    /// Writes bins [first, first + count) from three channel arrays in 1/sr, value[c][k] for bin
    /// first + k: a bin whose reflects[k] is 0 (not a reflection configuration), or whose value
    /// is not finite or above kMaxTableValue, is marked not measured; the others are stored as
    /// set_bin() stores them (a negative value, a model's rounding, is stored as 0). Every bin of
    /// the range is written.
    LineStoreCounts set_line(std::size_t first,
                             std::size_t count,
                             const double* const value[3],
                             const std::uint8_t* reflects);

    TableStatistics compute_statistics() const;

  private:
    enum class Storage { kNotMeasured, kUnwritten };
    /// The table of empty() (kNotMeasured: every bin invalid) or of unwritten().
    TabulatedBrdf(TableGrid grid, std::array<double, 3> scale, std::string source, Storage storage);

    TableGrid grid_;
    std::array<double, 3> scale_;
    TableValues raw_;
    UninitVector<std::uint8_t> valid_;
    std::string source_;
    Interpolation interpolation_ = Interpolation::kNearest;
};

/// Folds phi_d into [0, pi): phi_d < 0 is shifted by pi (reciprocity); pi itself stays pi only when
/// given exactly pi (the index mapping clamps it into the last bin).
double fold_phi_d(double phi_d);

}  // namespace gonio::brdf
