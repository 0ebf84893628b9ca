#include "gonio/acquisition/image/bin_uncertainty.h"

#include <array>
#include <cstdint>
#include <vector>

#include "gonio/acquisition/image/image_campaign.h"
#include "gonio/acquisition/point/stated_uncertainty.h"

namespace gonio::acquisition {

namespace {

/// The bins one step from `flat` along each axis of a row-major grid of `dims` (the last axis
/// varies fastest), passed to `visit`.
template <std::size_t N, class Visit>
void grid_neighbours(const std::array<int, N>& dims, std::size_t flat, Visit visit) {
    std::size_t stride = 1;
    for (std::size_t k = N; k-- > 0;) {
        const auto n = static_cast<std::size_t>(dims[k]);
        const std::size_t i = (flat / stride) % n;
        if (i > 0) {
            visit(flat - stride);
        }
        if (i + 1 < n) {
            visit(flat + stride);
        }
        stride *= n;
    }
}

/// The slope at every row of a table's dataset: largest_difference_quotient over the rows of the
/// neighbouring bins that have one. `bins[i]` is row i's bin; O(table size + rows).
template <std::size_t N>
std::vector<brdf::Rgbd> table_slopes(const std::vector<brdf::Sample>& rows,
                                     const std::vector<std::size_t>& bins,
                                     const std::array<int, N>& dims,
                                     bool isotropic) {
    std::size_t size = 1;
    for (int n : dims) {
        size *= static_cast<std::size_t>(n);
    }
    constexpr std::uint32_t kNoRow = UINT32_MAX;
    std::vector<std::uint32_t> row_of(size, kNoRow);
    for (std::size_t i = 0; i < bins.size(); ++i) {
        row_of[bins[i]] = static_cast<std::uint32_t>(i);
    }
    std::vector<brdf::Rgbd> slopes(rows.size(), brdf::Rgbd::Zero());
    std::vector<std::size_t> near;
    for (std::size_t i = 0; i < rows.size(); ++i) {
        near.clear();
        grid_neighbours(dims, bins[i], [&](std::size_t b) {
            if (row_of[b] != kNoRow) {
                near.push_back(row_of[b]);
            }
        });
        slopes[i] = largest_difference_quotient(rows, i, near, isotropic);
    }
    return slopes;
}

/// Adds the budget to the rows of `d` (`bins` their bins in a grid of `dims`).
template <std::size_t N>
void add_table_budget(const brdf::RigErrorBudget& budget,
                      double hours_since_white,
                      const std::vector<std::size_t>& bins,
                      const std::array<int, N>& dims,
                      bool isotropic,
                      brdf::Dataset* d) {
    const std::vector<brdf::Rgbd> slopes =
        budget_direction_sigma(budget) > 0
            ? table_slopes(d->samples, bins, dims, isotropic)
            : std::vector<brdf::Rgbd>(d->samples.size(), brdf::Rgbd::Zero());
    add_error_budget(budget, hours_since_white, slopes, &d->samples);
}

/// The table's dataset with the budget's terms in every sigma, its bins in a grid of `dims`.
template <typename Table, std::size_t N>
brdf::Dataset table_stated_dataset(const Table& table,
                                   const std::array<int, N>& dims,
                                   bool isotropic,
                                   const std::string& source,
                                   std::uint32_t min_count,
                                   bool hdr,
                                   const brdf::RigErrorBudget& budget,
                                   double hours_since_white) {
    std::vector<std::size_t> bins;
    brdf::Dataset d = table.to_dataset(source, min_count, hdr, &bins);
    add_table_budget(budget, hours_since_white, bins, dims, isotropic, &d);
    return d;
}

}  // namespace

brdf::Dataset stated_dataset(const BinnedTable& table,
                             const std::string& source,
                             std::uint32_t min_count,
                             bool hdr,
                             const brdf::RigErrorBudget& budget,
                             double hours_since_white) {
    const TableLayout& l = table.layout();
    return table_stated_dataset(table,
                                std::array<int, 3>{l.n_theta_h, l.n_theta_d, l.n_phi_d},
                                true,
                                source,
                                min_count,
                                hdr,
                                budget,
                                hours_since_white);
}

brdf::Dataset stated_dataset(const AnisoTable& table,
                             const std::string& source,
                             std::uint32_t min_count,
                             bool hdr,
                             const brdf::RigErrorBudget& budget,
                             double hours_since_white) {
    const AnisoLayout& l = table.layout();
    // AnisoLayout::index: the isotropic bin (theta_h, theta_d, phi_d) then phi_h fastest.
    return table_stated_dataset(table,
                                std::array<int, 4>{l.n_theta_h, l.n_theta_d, l.n_phi_d, l.n_phi_h},
                                false,
                                source,
                                min_count,
                                hdr,
                                budget,
                                hours_since_white);
}

double image_rig_hours(const ImageCampaignResult& result, const ImageCampaignConfig& config) {
    double seconds = result.exposure_time_s;
    brdf::RigPosed at;
    at.detector = config.detector_arm_rad;
    for (std::size_t k = 0; k < result.frames.size(); ++k) {
        brdf::RigPosed next = at;
        next.light = result.frames[k].light_arm_rad;
        next.spin = result.frames[k].spin_rad;
        // The first frame's move starts wherever the set-up left the arm: not counted.
        seconds += k == 0 ? 0.0 : move_time(at, next, config.dynamics);
        at = next;
    }
    return seconds / 3600.0;
}

brdf::Dataset image_campaign_dataset(const ImageCampaignResult& result,
                                     const ImageCampaignConfig& config) {
    const double hours = image_rig_hours(result, config);
    if (result.aniso_table.has_value() && result.aniso_coverage.has_value()) {
        return stated_dataset(*result.aniso_table,
                              "anisotropic image-mode campaign",
                              config.min_count,
                              result.bracketed,
                              config.error_budget,
                              hours);
    }
    return stated_dataset(result.table,
                          "image-mode campaign",
                          config.min_count,
                          result.bracketed,
                          config.error_budget,
                          hours);
}

}  // namespace gonio::acquisition
