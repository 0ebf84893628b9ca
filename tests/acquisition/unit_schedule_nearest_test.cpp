// The scheduler's nearest-neighbour search and lower bound against a brute-force reference: on
// random pose sets (continuous, on a lattice with many equal costs, with duplicates, with an axis
// that never moves) the lower bound and the nearest-neighbour tour (2-opt off) are exactly those
// of a scan over every pose, ties going to the smaller index.

#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "gonio/acquisition/plans/schedule.h"

namespace gonio::acquisition {
namespace {

/// Axes with different speeds, accelerations and settle times, so that the slowest axis and the
/// longest settle differ between moves and both trapezoid branches occur.
std::array<AxisDynamics, kNumAxes> mixed_dynamics() {
    std::array<AxisDynamics, kNumAxes> d;
    d[0] = AxisDynamics{0.52, 1.05, 0.005};
    d[1] = AxisDynamics{0.52, 1.05, 0.005};
    d[2] = AxisDynamics{0.35, 0.30, 0.020};
    d[3] = AxisDynamics{0.70, 2.00, 0.010};
    return d;
}

struct Reference {
    double lower_bound = 0;
    std::vector<std::size_t> order;
};

Reference brute_force(const std::vector<brdf::RigPosed>& poses,
                      const brdf::RigPosed& start,
                      const std::array<AxisDynamics, kNumAxes>& dyn) {
    Reference r;
    const std::size_t n = poses.size();
    for (std::size_t i = 0; i < n; ++i) {
        double c = std::numeric_limits<double>::infinity();
        for (std::size_t j = 0; j < n; ++j) {
            if (j != i) {
                c = std::min(c, move_time(poses[i], poses[j], dyn));
            }
        }
        r.lower_bound += std::min(c, move_time(start, poses[i], dyn));
    }
    std::vector<bool> used(n, false);
    brdf::RigPosed cur = start;
    for (std::size_t step = 0; step < n; ++step) {
        std::size_t best = n;
        double best_cost = std::numeric_limits<double>::infinity();
        for (std::size_t j = 0; j < n; ++j) {
            if (used[j]) {
                continue;
            }
            const double c = move_time(cur, poses[j], dyn);
            if (c < best_cost) {  // strict: the first (smallest index) of equal costs stays
                best_cost = c;
                best = j;
            }
        }
        used[best] = true;
        r.order.push_back(best);
        cur = poses[best];
    }
    return r;
}

enum class Kind { kContinuous, kLattice, kDuplicates, kFixedSpin };

std::vector<brdf::RigPosed> random_poses(std::size_t n, Kind kind, std::mt19937& rng) {
    std::uniform_real_distribution<double> arm(-2.5, 2.5);
    std::uniform_real_distribution<double> tilt(-1.2, 1.2);
    std::uniform_int_distribution<int> step(-6, 6);
    std::vector<brdf::RigPosed> out;
    while (out.size() < n) {
        brdf::RigPosed p;
        switch (kind) {
            case Kind::kLattice:
                // Steps of 0.1 rad: many moves of exactly equal cost.
                p = brdf::RigPosed{
                    0.1 * step(rng), 0.1 * step(rng), 0.1 * step(rng), 0.1 * step(rng)};
                break;
            case Kind::kDuplicates:
                p = brdf::RigPosed{arm(rng), arm(rng), tilt(rng), arm(rng)};
                out.push_back(p);  // every pose twice (zero-cost moves)
                break;
            case Kind::kFixedSpin:
                p = brdf::RigPosed{arm(rng), arm(rng), tilt(rng), 0.0};
                break;
            case Kind::kContinuous:
                p = brdf::RigPosed{arm(rng), arm(rng), tilt(rng), arm(rng)};
                break;
        }
        out.push_back(p);
    }
    out.resize(n);
    return out;
}

TEST(ScheduleNearest, MatchesBruteForceOnRandomPoseSets) {
    const auto dyn = mixed_dynamics();
    std::mt19937 rng(20261202);
    ScheduleOptions nn_only;
    nn_only.budget_s = 0;
    nn_only.window = 0;  // no 2-opt: the order is the nearest-neighbour tour
    int cases = 0;
    for (Kind kind : {Kind::kContinuous, Kind::kLattice, Kind::kDuplicates, Kind::kFixedSpin}) {
        for (std::size_t n : {1u, 2u, 3u, 7u, 9u, 17u, 40u, 120u, 300u}) {
            for (int rep = 0; rep < 3; ++rep) {
                const auto poses = random_poses(n, kind, rng);
                // The start is off the poses' lattice for the continuous sets, on it otherwise.
                const brdf::RigPosed start =
                    kind == Kind::kContinuous ? brdf::RigPosed{3.0, -2.9, 1.5, 0.3} : poses[0];
                const Reference ref = brute_force(poses, start, dyn);
                const Schedule s = schedule(poses, start, dyn, nn_only);
                SCOPED_TRACE("kind " + std::to_string(static_cast<int>(kind)) + " n " +
                             std::to_string(n) + " rep " + std::to_string(rep));
                EXPECT_EQ(s.lower_bound_s, ref.lower_bound);
                ASSERT_EQ(s.order, ref.order);
                EXPECT_EQ(s.planned_s, path_time(poses, ref.order, start, dyn));
                EXPECT_EQ(s.two_opt_moves, 0);
                ++cases;
            }
        }
    }
    EXPECT_EQ(cases, 4 * 9 * 3);
}

TEST(ScheduleNearest, TwoOptKeepsAPermutationAndNeverLengthensTheTour) {
    const auto dyn = mixed_dynamics();
    std::mt19937 rng(7);
    const auto poses = random_poses(500, Kind::kContinuous, rng);
    const brdf::RigPosed start{};
    ScheduleOptions nn_only;
    nn_only.budget_s = 0;
    nn_only.window = 0;
    const Schedule nn = schedule(poses, start, dyn, nn_only);
    ScheduleOptions improve;
    improve.budget_s = 5;  // converges long before
    const Schedule s = schedule(poses, start, dyn, improve);
    std::vector<std::size_t> sorted = s.order;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t k = 0; k < sorted.size(); ++k) {
        ASSERT_EQ(sorted[k], k);
    }
    EXPECT_GT(s.two_opt_moves, 0);
    EXPECT_LT(s.planned_s, nn.planned_s);
    EXPECT_EQ(s.lower_bound_s, nn.lower_bound_s);
    EXPECT_GE(s.planned_s, s.lower_bound_s);
    EXPECT_DOUBLE_EQ(s.planned_s, path_time(poses, s.order, start, dyn));
}

}  // namespace
}  // namespace gonio::acquisition
