#pragma once

// Shared checks of the image-mode tests: how far a measured table is from the ground truth.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "gonio/acquisition/image_binning.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/coords.h"

namespace gonio::tools::image_test {

/// |mean / truth - 1| in channel `c` of every bin with at least `min_count` samples whose mean
/// directions are both more than acos(0.2) = 78 deg from the horizon-grazing limit (cos >= 0.2).
inline std::vector<double> table_relative_errors(const acquisition::BinnedTable& t,
                                                 const brdf::Brdf& truth,
                                                 int c,
                                                 std::size_t min_count = 10) {
    std::vector<double> rel;
    for (std::size_t b = 0; b < t.size(); ++b) {
        if (t.count(b) < min_count) {
            continue;
        }
        const auto [wi, wo] = brdf::from_half_diff(t.mean_position(b));
        if (wi.z() < 0.2 || wo.z() < 0.2) {
            continue;
        }
        rel.push_back(std::abs(t.mean(b)[c] / truth.eval(wi, wo)[c] - 1));
    }
    return rel;
}

/// The median (the upper one for an even count); NaN for none.
inline double median(std::vector<double> v) {
    if (v.empty()) {
        return std::nan("");
    }
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
}

}  // namespace gonio::tools::image_test
