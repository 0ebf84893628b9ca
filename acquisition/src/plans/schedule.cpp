#include "gonio/acquisition/plans/schedule.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

namespace gonio::acquisition {

using brdf::RigPosed;

namespace {

using Coords = std::array<double, kNumAxes>;

Coords coords(const RigPosed& p) {
    return {p.light, p.detector, p.tilt, p.spin};
}

/// move_time with the axis constants hoisted: the same operations in the same order as
/// trapezoid_time and move_time, so the same result to the last bit.
class MoveCost {
  public:
    explicit MoveCost(const std::array<AxisDynamics, kNumAxes>& dyn) {
        for (int k = 0; k < kNumAxes; ++k) {
            speed_[k] = dyn[k].speed;
            accel_[k] = dyn[k].accel;
            cruise_d_[k] = dyn[k].speed * dyn[k].speed / dyn[k].accel;
            ramp_t_[k] = dyn[k].speed / dyn[k].accel;
            settle_[k] = dyn[k].settle_s;
        }
    }

    double speed(int k) const { return speed_[k]; }

    /// trapezoid_time of axis k for a distance d >= 1e-12.
    double axis_time(int k, double d) const {
        if (d >= cruise_d_[k]) {
            return d / speed_[k] + ramp_t_[k];
        }
        return 2 * std::sqrt(d / accel_[k]);
    }

    double operator()(const Coords& a, const Coords& b) const {
        double t = 0;
        double settle = 0;
        for (int k = 0; k < kNumAxes; ++k) {
            const double d = std::abs(b[k] - a[k]);
            if (d < 1e-12) {
                continue;
            }
            t = std::max(t, axis_time(k, d));
            settle = std::max(settle, settle_[k]);
        }
        return t + settle;
    }

    /// A lower bound of the cost from q to any point whose coordinates lie in [lo, hi] per axis.
    double bound(const Coords& q, const Coords& lo, const Coords& hi) const {
        double t = 0;
        double settle = 0;
        for (int k = 0; k < kNumAxes; ++k) {
            // Rounding is monotone: lo - q <= b - q for every b >= lo (and likewise above hi).
            const double d = q[k] < lo[k] ? lo[k] - q[k] : (q[k] > hi[k] ? q[k] - hi[k] : 0.0);
            if (d < 1e-12) {
                // This axis may stay put: it adds neither motion nor settle.
                continue;
            }
            t = std::max(t, axis_time(k, d));
            settle = std::max(settle, settle_[k]);
        }
        return t + settle;
    }

  private:
    Coords speed_{}, accel_{}, cruise_d_{}, ramp_t_{}, settle_{};
};

/// A k-d tree over the poses' axis coordinates for nearest-neighbour queries under move_time, with
/// removal. Each node keeps the bounding box of its poses; a subtree is skipped when the cost bound
/// to its box exceeds the best cost found (by a margin far above rounding, so that a pose tied with
/// the best is always seen). The answer is the exact nearest pose, ties going to the smaller index,
/// as a scan of every pose would give.
class KdTree {
  public:
    KdTree(const std::vector<RigPosed>& poses, const MoveCost& cost) : cost_(cost) {
        const std::size_t n = poses.size();
        index_.resize(n);
        std::iota(index_.begin(), index_.end(), 0u);
        pts_.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            pts_[i] = coords(poses[i]);
        }
        nodes_.reserve(2 * (n / kLeaf + 1));
        if (n > 0) {
            build(0, static_cast<std::uint32_t>(n), -1);
        }
        // pts_ in tree order from here on.
        std::vector<Coords> ordered(n);
        for (std::size_t p = 0; p < n; ++p) {
            ordered[p] = pts_[index_[p]];
        }
        pts_ = std::move(ordered);
        pos_.resize(n);
        for (std::size_t p = 0; p < n; ++p) {
            pos_[index_[p]] = static_cast<std::uint32_t>(p);
        }
        leaf_of_.resize(n);
        for (std::size_t v = 0; v < nodes_.size(); ++v) {
            if (nodes_[v].left < 0) {
                for (std::uint32_t p = nodes_[v].begin; p < nodes_[v].end; ++p) {
                    leaf_of_[index_[p]] = static_cast<std::int32_t>(v);
                }
            }
        }
    }

    std::size_t remaining() const { return nodes_.empty() ? 0 : nodes_[0].alive; }

    /// Nearest remaining pose to q (by move_time); `exclude` is skipped. Returns n when none.
    std::size_t nearest(const Coords& q, std::size_t exclude, double* cost) const {
        best_ = index_.size();
        best_cost_ = std::numeric_limits<double>::infinity();
        if (!nodes_.empty()) {
            search(0, q, exclude);
        }
        *cost = best_cost_;
        return best_;
    }

    void remove(std::size_t i) {
        std::int32_t v = leaf_of_[i];
        Node& leaf = nodes_[static_cast<std::size_t>(v)];
        // The leaf's live poses are [begin, begin + alive): swap i with the last live one.
        const std::uint32_t p = pos_[i];
        const std::uint32_t last = leaf.begin + leaf.alive - 1;
        const std::uint32_t j = index_[last];
        std::swap(index_[p], index_[last]);
        std::swap(pts_[p], pts_[last]);
        pos_[j] = p;
        pos_[i] = last;
        while (v >= 0) {
            --nodes_[static_cast<std::size_t>(v)].alive;
            v = nodes_[static_cast<std::size_t>(v)].parent;
        }
    }

  private:
    static constexpr std::uint32_t kLeaf = 8;

    struct Node {
        Coords lo, hi;
        std::uint32_t begin = 0, end = 0, alive = 0;
        std::int32_t left = -1, right = -1, parent = -1;
    };

    std::int32_t build(std::uint32_t begin, std::uint32_t end, std::int32_t parent) {
        const auto v = static_cast<std::int32_t>(nodes_.size());
        nodes_.emplace_back();
        Node node;
        node.begin = begin;
        node.end = end;
        node.alive = end - begin;
        node.parent = parent;
        node.lo.fill(std::numeric_limits<double>::infinity());
        node.hi.fill(-std::numeric_limits<double>::infinity());
        for (std::uint32_t p = begin; p < end; ++p) {
            const Coords& c = pts_[index_[p]];
            for (int k = 0; k < kNumAxes; ++k) {
                node.lo[k] = std::min(node.lo[k], c[k]);
                node.hi[k] = std::max(node.hi[k], c[k]);
            }
        }
        if (end - begin > kLeaf) {
            // Split at the median of the axis with the widest spread in time (angle / speed).
            int axis = 0;
            double widest = -1;
            for (int k = 0; k < kNumAxes; ++k) {
                const double w = (node.hi[k] - node.lo[k]) / cost_.speed(k);
                if (w > widest) {
                    widest = w;
                    axis = k;
                }
            }
            if (widest > 0) {
                const std::uint32_t mid = begin + (end - begin) / 2;
                std::nth_element(index_.begin() + begin,
                                 index_.begin() + mid,
                                 index_.begin() + end,
                                 [&](std::uint32_t a, std::uint32_t b) {
                                     return pts_[a][axis] < pts_[b][axis];
                                 });
                node.left = build(begin, mid, v);
                node.right = build(mid, end, v);
            }
        }
        nodes_[static_cast<std::size_t>(v)] = node;
        return v;
    }

    void search(std::int32_t v, const Coords& q, std::size_t exclude) const {
        const Node& node = nodes_[static_cast<std::size_t>(v)];
        if (node.left < 0) {
            for (std::uint32_t p = node.begin; p < node.begin + node.alive; ++p) {
                const std::uint32_t i = index_[p];
                if (i == exclude) {
                    continue;
                }
                const double c = cost_(q, pts_[p]);
                if (c < best_cost_ || (c == best_cost_ && i < best_)) {
                    best_cost_ = c;
                    best_ = i;
                }
            }
            return;
        }
        const Node& l = nodes_[static_cast<std::size_t>(node.left)];
        const Node& r = nodes_[static_cast<std::size_t>(node.right)];
        const double bl = l.alive > 0 ? cost_.bound(q, l.lo, l.hi) : kSkip;
        const double br = r.alive > 0 ? cost_.bound(q, r.lo, r.hi) : kSkip;
        // Nearer box first; a box is skipped only when clearly beyond the best cost.
        const bool left_first = bl <= br;
        const std::int32_t first = left_first ? node.left : node.right;
        const std::int32_t second = left_first ? node.right : node.left;
        const double b1 = left_first ? bl : br;
        const double b2 = left_first ? br : bl;
        if (b1 < kSkip && !(b1 > best_cost_ + kMargin)) {
            search(first, q, exclude);
        }
        if (b2 < kSkip && !(b2 > best_cost_ + kMargin)) {
            search(second, q, exclude);
        }
    }

    static constexpr double kSkip = std::numeric_limits<double>::max();
    /// Far above the rounding of the bound (a few ulps of seconds), far below any real difference.
    static constexpr double kMargin = 1e-9;

    const MoveCost& cost_;
    std::vector<Node> nodes_;
    std::vector<std::uint32_t> index_;  ///< Pose index at each tree position.
    std::vector<std::uint32_t> pos_;    ///< Tree position of each pose.
    std::vector<std::int32_t> leaf_of_;
    std::vector<Coords> pts_;  ///< Coordinates in tree order (pose order while building).
    mutable std::size_t best_ = 0;
    mutable double best_cost_ = 0;
};

}  // namespace

double path_time(const std::vector<RigPosed>& poses,
                 const std::vector<std::size_t>& order,
                 const RigPosed& start,
                 const std::array<AxisDynamics, kNumAxes>& dyn) {
    double t = 0;
    RigPosed cur = start;
    for (std::size_t i : order) {
        t += move_time(cur, poses[i], dyn);
        cur = poses[i];
    }
    return t;
}

Schedule schedule(const std::vector<RigPosed>& poses,
                  const RigPosed& start,
                  const std::array<AxisDynamics, kNumAxes>& dyn,
                  const ScheduleOptions& opt) {
    Schedule s;
    const std::size_t n = poses.size();
    const MoveCost cost(dyn);
    std::vector<Coords> pts(n);
    for (std::size_t i = 0; i < n; ++i) {
        pts[i] = coords(poses[i]);
    }
    const Coords from = coords(start);
    {
        Coords cur = from;
        for (const Coords& c : pts) {
            s.raster_s += cost(cur, c);
            cur = c;
        }
    }
    if (n == 0) {
        return s;
    }
    // Lower bound: cheapest move into each pose (from the start or another pose).
    KdTree tree(poses, cost);
    for (std::size_t i = 0; i < n; ++i) {
        double c = 0;
        tree.nearest(pts[i], i, &c);
        s.lower_bound_s += std::min(c, cost(from, pts[i]));
    }
    // Nearest neighbour.
    Coords cur = from;
    s.order.reserve(n);
    while (tree.remaining() > 0) {
        double c = 0;
        const std::size_t next = tree.nearest(cur, n, &c);
        tree.remove(next);
        s.order.push_back(next);
        cur = pts[next];
    }
    // 2-opt on the open path t[0] = start, t[1..n] = order, within a window and a time budget.
    std::vector<Coords> t(n + 1);
    t[0] = from;
    for (std::size_t k = 0; k < n; ++k) {
        t[k + 1] = pts[s.order[k]];
    }
    std::vector<std::size_t> idx(s.order);
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(opt.budget_s));
    bool improved = true;
    std::size_t checks = 0;
    bool out_of_time = false;
    while (improved && !out_of_time) {
        improved = false;
        for (std::size_t i = 1; i + 1 <= n && !out_of_time; ++i) {
            const double c_prev = cost(t[i - 1], t[i]);
            const std::size_t jmax = std::min(n, i + static_cast<std::size_t>(opt.window));
            for (std::size_t j = i + 1; j <= jmax; ++j) {
                const bool last = (j == n);
                const double before = c_prev + (last ? 0.0 : cost(t[j], t[j + 1]));
                const double after = cost(t[i - 1], t[j]) + (last ? 0.0 : cost(t[i], t[j + 1]));
                if (after < before - 1e-9) {
                    std::reverse(t.begin() + i, t.begin() + j + 1);
                    std::reverse(idx.begin() + (i - 1), idx.begin() + j);
                    ++s.two_opt_moves;
                    improved = true;
                    break;
                }
            }
            if (++checks % 256 == 0 && std::chrono::steady_clock::now() > deadline) {
                out_of_time = true;
            }
        }
    }
    s.order = idx;
    {
        Coords c0 = from;
        for (std::size_t k : s.order) {
            s.planned_s += cost(c0, pts[k]);
            c0 = pts[k];
        }
    }
    return s;
}

}  // namespace gonio::acquisition
