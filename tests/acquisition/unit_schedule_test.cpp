// Scheduling degenerate plans: a single pose, or poses that all coincide, put every pose in one
// grid cell; the nearest-neighbour search must still end (a resumed campaign often has one
// configuration left).

#include <gtest/gtest.h>

#include "gonio/acquisition/plans/schedule.h"

namespace gonio::acquisition {
namespace {

std::array<AxisDynamics, kNumAxes> dynamics() {
    std::array<AxisDynamics, kNumAxes> d;
    for (auto& a : d) {
        a.speed = 0.5;  // rad/s
        a.accel = 1.0;  // rad/s^2
        a.settle_s = 0.01;
    }
    return d;
}

TEST(Schedule, SinglePoseIsVisitedFromTheStart) {
    const brdf::RigPosed start{0, 0.7, 0, 0};
    const std::vector<brdf::RigPosed> poses = {brdf::RigPosed{0.3, 0.9, -0.2, 0.1}};
    const Schedule s = schedule(poses, start, dynamics(), ScheduleOptions{});
    ASSERT_EQ(s.order, std::vector<std::size_t>({0}));
    const double t = path_time(poses, {0}, start, dynamics());
    EXPECT_GT(t, 0);
    EXPECT_DOUBLE_EQ(s.planned_s, t);
    // The only move into the pose is the one from the start.
    EXPECT_DOUBLE_EQ(s.lower_bound_s, t);
}

TEST(Schedule, CoincidentPosesAreAllVisited) {
    const brdf::RigPosed start{0, 0, 0, 0};
    const brdf::RigPosed p{0.2, 0.4, 0.1, -0.3};
    const std::vector<brdf::RigPosed> poses = {p, p, p};
    const Schedule s = schedule(poses, start, dynamics(), ScheduleOptions{});
    ASSERT_EQ(s.order.size(), 3u);
    EXPECT_EQ(std::vector<std::size_t>(s.order.begin(), s.order.end()),
              std::vector<std::size_t>({0, 1, 2}));
}

}  // namespace
}  // namespace gonio::acquisition
