#pragma once

// Conversions into and out of half/difference tables:
// - any Brdf -> table, by evaluation at the bin centres (table.h);
// - a table's valid bins -> dataset samples (one per bin, at its centre);
// - scattered samples (a measurement) -> table, by kernel-weighted averaging in the index space of
//   the half/difference grid; bins with no sample within the kernel radius stay invalid.

#include <array>
#include <cstddef>
#include <string>

#include "gonio/base/error.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {

struct TabulateOptions {
    TableGrid grid = TableGrid::merl();
    std::array<double, 3> scale = kMerlScale;
    /// Threads of the project's pool (gonio/base/thread_pool.h) to use; 0 = all of them.
    unsigned threads = 0;
};

/// Counts of a tabulation.
struct TabulateReport {
    std::size_t bins = 0;
    std::size_t valid_bins = 0;
    std::size_t below_horizon =
        0;                       ///< Bins whose centre pair has wi or wo at or below the horizon.
    std::size_t non_finite = 0;  ///< Bins where the BRDF returned NaN/Inf (left invalid, counted).
    std::size_t out_of_range = 0;  ///< Bins whose value exceeds kMaxTableValue (left invalid).
};

/// Evaluates brdf at every bin centre (wi, wo from TableGrid::centre_directions). Bins whose centre
/// has a direction at or below the horizon are left invalid: the BRDF is not defined there. brdf
/// must be safe to evaluate from several threads at once (const eval without shared mutable state).
TabulatedBrdf tabulate(const Brdf& brdf,
                       const TabulateOptions& options = {},
                       TabulateReport* report = nullptr);

/// One sample per valid bin whose centre pair lies above the horizon, at the bin centre (phi_i = 0,
/// phi_o = azimuth of wo), value in 1/sr. dataset.source names the table.
Dataset table_to_dataset(const TabulatedBrdf& table);

struct ResampleOptions {
    TableGrid grid = TableGrid::merl();
    std::array<double, 3> scale = kMerlScale;
    /// Kernel radius in bins (index units of the three axes, phi_d periodic). A bin gets a value
    /// when at least one sample lies strictly within the radius of its centre.
    double radius_bins = 1.5;
};

struct ResampleReport {
    std::size_t samples_used = 0;
    std::size_t bins = 0;
    std::size_t filled_bins = 0;
    std::size_t empty_bins = 0;     ///< Above the horizon but no sample within the radius: invalid.
    std::size_t below_horizon = 0;  ///< Centre pair at or below the horizon: invalid.
};

/// Scattered samples -> table. Each sample is mapped to half/difference angles (phi_d folded into
/// [0, pi), reciprocity) and then to continuous index coordinates u (TableGrid::continuous_index);
/// a bin centre c receives the weighted mean of the samples with |u - c| < r (Euclidean in index
/// units, phi_d periodic), with the weight (1 - |u - c|^2 / r^2)^2 (a compact, smooth kernel).
/// Errors: radius not in (0, 16], an empty dataset, a sample value above kMaxTableValue, a grid
/// whose working memory exceeds gonio::max_memory_bytes().
Expected<TabulatedBrdf> resample_dataset(const Dataset& data,
                                         const ResampleOptions& options = {},
                                         ResampleReport* report = nullptr);

}  // namespace gonio::brdf
