#pragma once

// Motion-time scheduling: the order in which to visit a set of poses so that the total move time
// (slowest axis's trapezoidal time plus settle, see move_time) is small. Nearest neighbour through
// a k-d tree over the axis coordinates (exact; about O(n log n) for dense plans), then 2-opt
// restricted to a window of the tour, within a time budget. Also the raster-order duration and a
// lower bound, for the operator's comparison.

#include <cstddef>
#include <vector>

#include "gonio/acquisition/shared/kinematics.h"

namespace gonio::acquisition {

struct ScheduleOptions {
    double budget_s = 0.5;  ///< Wall-clock budget of the 2-opt improvement.
    int window = 64;        ///< Largest segment 2-opt reverses.
};

struct Schedule {
    std::vector<std::size_t> order;  ///< Indices into the pose list, visiting order.
    double planned_s = 0;            ///< Total motion time of `order` from the start pose.
    double raster_s = 0;             ///< Total motion time of the plan's own order.
    double lower_bound_s = 0;        ///< Sum over poses of the cheapest move into each.
    int two_opt_moves = 0;           ///< Improving 2-opt moves applied.
};

/// Total motion time of visiting poses[order[0]], poses[order[1]], ... starting from `start`.
double path_time(const std::vector<brdf::RigPosed>& poses,
                 const std::vector<std::size_t>& order,
                 const brdf::RigPosed& start,
                 const std::array<AxisDynamics, kNumAxes>& dyn);

/// Orders the poses from `start`. A valid lower bound on any visiting order: each pose must be
/// entered once, by a move at least as long as the cheapest move into it from the start or from
/// another pose.
Schedule schedule(const std::vector<brdf::RigPosed>& poses,
                  const brdf::RigPosed& start,
                  const std::array<AxisDynamics, kNumAxes>& dyn,
                  const ScheduleOptions& opt = {});

}  // namespace gonio::acquisition
