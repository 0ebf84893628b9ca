#include "gonio/acquisition/schedule.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>

namespace gonio::acquisition {

using brdf::RigPosed;

namespace {

std::array<double, kNumAxes> coords(const RigPosed& p) {
    return {p.light, p.detector, p.tilt, p.spin};
}

/// Buckets of poses on a grid in "time" coordinates (angle / speed per axis) for nearest-neighbour
/// queries under move_time.
class BucketGrid {
  public:
    BucketGrid(const std::vector<RigPosed>& poses, const std::array<AxisDynamics, kNumAxes>& dyn)
        : poses_(poses), dyn_(dyn) {
        const std::size_t n = poses.size();
        std::array<double, kNumAxes> lo, hi;
        lo.fill(std::numeric_limits<double>::infinity());
        hi.fill(-std::numeric_limits<double>::infinity());
        for (const RigPosed& p : poses) {
            const auto c = coords(p);
            for (int k = 0; k < kNumAxes; ++k) {
                lo[k] = std::min(lo[k], c[k] / dyn[k].speed);
                hi[k] = std::max(hi[k], c[k] / dyn[k].speed);
            }
        }
        double volume = 1;
        dims_ = 0;
        for (int k = 0; k < kNumAxes; ++k) {
            lo_[k] = lo[k];
            active_[k] = n > 0 && hi[k] - lo[k] > 1e-9;
            if (active_[k]) {
                volume *= hi[k] - lo[k];
                ++dims_;
            }
        }
        // About two poses per occupied cell.
        h_ = dims_ == 0 ? 1.0 : std::pow(volume * 2.0 / std::max<std::size_t>(n, 1), 1.0 / dims_);
        h_ = std::max(h_, 1e-6);
        min_settle_ = std::numeric_limits<double>::infinity();
        for (int k = 0; k < kNumAxes; ++k) {
            min_settle_ = std::min(min_settle_, dyn[k].settle_s);
        }
        for (std::size_t i = 0; i < n; ++i) {
            cells_[key(cell_of(poses[i]))].push_back(static_cast<std::uint32_t>(i));
        }
        alive_.resize(n);
        std::iota(alive_.begin(), alive_.end(), 0u);
        where_.resize(n);
        std::iota(where_.begin(), where_.end(), 0u);
    }

    std::size_t remaining() const { return alive_.size(); }

    /// Nearest remaining pose to p (by move_time); `exclude` is skipped. Returns n when none.
    std::size_t nearest(const RigPosed& p, std::size_t exclude, double* cost) const {
        const std::size_t none = poses_.size();
        std::size_t best = none;
        double best_cost = std::numeric_limits<double>::infinity();
        auto consider = [&](std::uint32_t i) {
            if (i == exclude) {
                return;
            }
            const double c = move_time(p, poses_[i], dyn_);
            if (c < best_cost || (c == best_cost && i < best)) {
                best_cost = c;
                best = i;
            }
        };
        const auto c0 = cell_of(p);
        for (int r = 0;; ++r) {
            // Past this ring a linear scan is cheaper than enumerating empty cells.
            double ring_cells = std::pow(2.0 * r + 1, dims_);
            // dims_ == 0: every pose shares one cell, which need not be p's (p may be the start
            // pose, off the grid), and the rings never grow: scan the remaining poses.
            if (dims_ == 0 || ring_cells > 8.0 * static_cast<double>(alive_.size()) + 64) {
                for (std::uint32_t i : alive_) {
                    consider(i);
                }
                break;
            }
            visit_ring(c0, r, [&](std::uint64_t k) {
                auto it = cells_.find(k);
                if (it != cells_.end()) {
                    for (std::uint32_t i : it->second) {
                        consider(i);
                    }
                }
            });
            // Any pose beyond ring r is at least r cells away along some axis.
            if (best != none && best_cost <= ring_bound(r)) {
                break;
            }
        }
        *cost = best_cost;
        return best;
    }

    void remove(std::size_t i) {
        auto& v = cells_[key(cell_of(poses_[i]))];
        v.erase(std::find(v.begin(), v.end(), static_cast<std::uint32_t>(i)));
        const std::uint32_t pos = where_[i];
        const std::uint32_t last = alive_.back();
        alive_[pos] = last;
        where_[last] = pos;
        alive_.pop_back();
    }

  private:
    using Cell = std::array<int, kNumAxes>;

    Cell cell_of(const RigPosed& p) const {
        const auto c = coords(p);
        Cell out;
        for (int k = 0; k < kNumAxes; ++k) {
            out[k] = static_cast<int>(std::floor((c[k] / dyn_[k].speed - lo_[k]) / h_));
        }
        return out;
    }
    static std::uint64_t key(const Cell& c) {
        std::uint64_t k = 0;
        for (int q = 0; q < kNumAxes; ++q) {
            k = (k << 16) | static_cast<std::uint16_t>(c[q] + 32768);
        }
        return k;
    }
    /// Smallest move_time to a pose whose cell is more than r cells away on some axis.
    double ring_bound(int r) const {
        double b = std::numeric_limits<double>::infinity();
        for (int k = 0; k < kNumAxes; ++k) {
            if (active_[k]) {
                b = std::min(b,
                             trapezoid_time(r * h_ * dyn_[k].speed, dyn_[k].speed, dyn_[k].accel));
            }
        }
        if (dims_ == 0) {
            // Every pose in one cell: ring 0 held them all.
            return std::numeric_limits<double>::infinity();
        }
        return b + min_settle_;
    }
    template <class F>
    void visit_ring(const Cell& c0, int r, F&& f) const {
        Cell d{};
        std::array<int, kNumAxes> span{};
        for (int k = 0; k < kNumAxes; ++k) {
            // Axes whose poses all share one coordinate have a single cell.
            span[k] = active(k) ? r : 0;
            d[k] = -span[k];
        }
        while (true) {
            int m = 0;
            for (int k = 0; k < kNumAxes; ++k) {
                m = std::max(m, std::abs(d[k]));
            }
            if (m == r) {
                Cell c;
                for (int k = 0; k < kNumAxes; ++k) {
                    c[k] = c0[k] + d[k];
                }
                f(key(c));
            }
            int k = 0;
            while (k < kNumAxes && d[k] == span[k]) {
                d[k] = -span[k];
                ++k;
            }
            if (k == kNumAxes) {
                break;
            }
            ++d[k];
        }
    }
    /// An axis along which the poses spread; along the others every pose shares one cell.
    bool active(int k) const { return active_[k]; }

    const std::vector<RigPosed>& poses_;
    std::array<AxisDynamics, kNumAxes> dyn_;
    std::array<double, kNumAxes> lo_{};
    std::array<bool, kNumAxes> active_{};
    int dims_ = 0;
    double h_ = 1;
    double min_settle_ = 0;
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
    std::vector<std::uint32_t> alive_;
    std::vector<std::uint32_t> where_;
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
    std::vector<std::size_t> raster(n);
    std::iota(raster.begin(), raster.end(), 0);
    s.raster_s = path_time(poses, raster, start, dyn);
    if (n == 0) {
        return s;
    }
    // Lower bound: cheapest move into each pose (from the start or another pose).
    {
        BucketGrid all(poses, dyn);
        for (std::size_t i = 0; i < n; ++i) {
            double c = 0;
            all.nearest(poses[i], i, &c);
            s.lower_bound_s += std::min(c, move_time(start, poses[i], dyn));
        }
    }
    // Nearest neighbour.
    BucketGrid grid(poses, dyn);
    RigPosed cur = start;
    s.order.reserve(n);
    while (grid.remaining() > 0) {
        double c = 0;
        const std::size_t next = grid.nearest(cur, n, &c);
        grid.remove(next);
        s.order.push_back(next);
        cur = poses[next];
    }
    // 2-opt on the open path t[0] = start, t[1..n] = order, within a window and a time budget.
    std::vector<RigPosed> t(n + 1);
    t[0] = start;
    for (std::size_t k = 0; k < n; ++k) {
        t[k + 1] = poses[s.order[k]];
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
            const double c_prev = move_time(t[i - 1], t[i], dyn);
            const std::size_t jmax = std::min(n, i + static_cast<std::size_t>(opt.window));
            for (std::size_t j = i + 1; j <= jmax; ++j) {
                const bool last = (j == n);
                const double before = c_prev + (last ? 0.0 : move_time(t[j], t[j + 1], dyn));
                const double after =
                    move_time(t[i - 1], t[j], dyn) + (last ? 0.0 : move_time(t[i], t[j + 1], dyn));
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
    s.planned_s = path_time(poses, s.order, start, dyn);
    return s;
}

}  // namespace gonio::acquisition
