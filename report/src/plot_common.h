#pragma once

// Small helpers shared by the plot files (private to the module).

#include <string>
#include <utility>
#include <vector>

namespace gonio::report::plot_detail {

/// Up to n values picked evenly (first and last included) from sorted (value, count) pairs.
std::vector<double> pick_evenly(const std::vector<std::pair<double, int>>& sorted, std::size_t n);

/// The file name of a path (for titles); "data" when empty.
std::string short_name(const std::string& source);

/// Maps BRDF values to a radius in pixels, linearly from 0 or logarithmically over whole decades.
struct RadialScale {
    bool log = false;
    double min_value = 0;  ///< value drawn at the origin (0 for linear, 10^k for log)
    double max_value = 1;  ///< value drawn on the outer ring
    double radius_px = 1;
    std::vector<double> ticks;

    /// vmin_pos: smallest positive value to show (log only); vmax: largest value (> 0).
    static RadialScale make(double vmin_pos, double vmax, bool log, double radius_px);
    /// Radius of a value: clamped to [0, radius_px]; values at or below min_value at the origin.
    double radius(double v) const;
};

/// What the BRDF axis shows, for subtitles: "log10 scale (values span a to b, n decades)" or
/// "linear scale from 0".
std::string scale_caption(bool log, double vmin_pos, double vmax);

/// A log-axis lower bound: the decade at or below a third of a decade under the smallest positive
/// value (so that it stands off the origin), but at most 5 decades below the largest.
double log_floor(double vmin_pos, double vmax);

}  // namespace gonio::report::plot_detail
