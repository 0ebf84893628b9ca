#pragma once

// Which valid bins of an image table hold data: the part the half/difference table's coverage
// (image_planner.h: CoverageMap) and the 4-D table's (image_aniso.h: AnisoCoverage) share, and
// the coverage of (theta_h, theta_d) cells over the half/difference grid that both report.

#include <cstdint>
#include <vector>

#include "gonio/brdf/table.h"

namespace gonio::acquisition {

class BinCoverage {
  public:
    /// Bins of the table (valid or not).
    std::size_t size() const { return covered_.size(); }
    std::size_t valid_bins() const { return valid_count_; }
    std::size_t covered_bins() const { return covered_count_; }
    /// Covered fraction of the valid bins, in [0, 1] (1 for a layout without valid bins, which
    /// positive bin counts never give: nothing to cover).
    double fraction() const;
    bool valid(std::size_t bin) const { return valid_[bin] != 0; }
    bool covered(std::size_t bin) const { return covered_[bin] != 0; }
    /// Marks a bin covered (ignored for invalid bins).
    void cover(std::size_t bin);
    /// Marks each bin of the list covered.
    void cover_all(const std::vector<std::uint32_t>& bins);
    /// Number of valid, not yet covered bins in the list.
    std::size_t gain(const std::vector<std::uint32_t>& bins) const;

  protected:
    /// `valid`: one flag per bin of the table.
    explicit BinCoverage(std::vector<std::uint8_t> valid);
    /// Marks every bin whose `count(bin)` is at least max(min_count, 1).
    template <class Count>
    void cover_counts(Count count, std::uint32_t min_count) {
        const std::uint32_t m = min_count > 1 ? min_count : 1;
        for (std::size_t b = 0; b < covered_.size(); ++b) {
            if (count(b) >= m) {
                cover(b);
            }
        }
    }

  private:
    std::vector<std::uint8_t> valid_;
    std::vector<std::uint8_t> covered_;
    std::size_t valid_count_ = 0;
    std::size_t covered_count_ = 0;
};

/// Per (theta_h, theta_d) cell of the half/difference grid `grid`: the covered share of its valid
/// bins, -1 for a cell without one; row-major with theta_d rows. `tally(bin, &valid, &covered)`
/// adds the counts of one half/difference bin of the cell (a 4-D table adds its phi_h bins).
template <class Tally>
std::vector<double> cell_fractions(const brdf::TableGrid& grid, Tally tally) {
    std::vector<double> out(static_cast<std::size_t>(grid.n_theta_h) * grid.n_theta_d, -1.0);
    for (int i_d = 0; i_d < grid.n_theta_d; ++i_d) {
        for (int i_h = 0; i_h < grid.n_theta_h; ++i_h) {
            std::size_t valid = 0;
            std::size_t covered = 0;
            for (int i_p = 0; i_p < grid.n_phi_d; ++i_p) {
                tally(grid.index(i_h, i_d, i_p), &valid, &covered);
            }
            if (valid > 0) {
                out[static_cast<std::size_t>(i_d) * grid.n_theta_h + i_h] =
                    static_cast<double>(covered) / static_cast<double>(valid);
            }
        }
    }
    return out;
}

}  // namespace gonio::acquisition
