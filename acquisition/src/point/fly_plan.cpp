#include "gonio/acquisition/point/fly_plan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

namespace gonio::acquisition {

namespace {

constexpr double kDeg = brdf::kPi / 180;
/// Travel at cruise speed before the first trigger and after the last frame's end, beyond the
/// ramps: the drive's speed has settled on its cruise when the first exposure starts.
constexpr double kCruiseMarginRad = 0.2 * kDeg;

using Key = std::tuple<int, long long, long long, long long>;

/// The three other axes of a pose, in units of kFlySameAxisRad: poses with one key stand alike.
Key stand_key(const brdf::RigPosed& p, int axis) {
    const double c[kNumAxes] = {p.light, p.detector, p.tilt, p.spin};
    long long k[3];
    int n = 0;
    for (int a = 0; a < kNumAxes; ++a) {
        if (a != axis) {
            k[n++] = std::llround(c[a] / kFlySameAxisRad);
        }
    }
    return {axis, k[0], k[1], k[2]};
}

/// Lead-in and lead-out of a sweep over its members (sorted by angle); false when either leaves
/// the arm's range.
bool place_sweep(const std::vector<brdf::RigPosed>& poses, const FlyLimits& lim, Sweep* s) {
    const double first = axis_angle(poses[s->members.front()], s->axis);
    const double last = axis_angle(poses[s->members.back()], s->axis);
    const double ramp =
        s->speed * s->speed / (2 * lim.dyn[s->axis].accel) + 0.5 * s->smear_rad + kCruiseMarginRad;
    s->from = first - ramp;
    s->to = last + ramp;
    s->stand = poses[s->members.front()];
    set_axis_angle(&s->stand, s->axis, s->from);
    const AxisRange& r = lim.range[s->axis];
    return s->from >= r.min && s->to <= r.max;
}

/// A sweep of `group` (poses standing alike but for `axis`) not yet taken; false when fewer than
/// two distinct angles remain or the sweep does not fit the arm's range.
bool make_sweep(const std::vector<brdf::RigPosed>& poses,
                const std::vector<std::size_t>& group,
                int axis,
                const std::vector<bool>& taken,
                const FlySpec& spec,
                const FlyLimits& lim,
                Sweep* out) {
    Sweep s;
    s.axis = axis;
    for (std::size_t i : group) {
        if (!taken[i]) {
            s.members.push_back(i);
        }
    }
    std::sort(s.members.begin(), s.members.end(), [&](std::size_t a, std::size_t b) {
        return axis_angle(poses[a], axis) < axis_angle(poses[b], axis);
    });
    // Two configurations at one angle are one frame apart in no time: the second is measured
    // standing.
    std::vector<std::size_t> kept;
    for (std::size_t i : s.members) {
        if (kept.empty() ||
            axis_angle(poses[i], axis) - axis_angle(poses[kept.back()], axis) > kFlySameAxisRad) {
            kept.push_back(i);
        }
    }
    if (kept.size() < 2) {
        return false;
    }
    s.members = std::move(kept);
    double gap = std::numeric_limits<double>::infinity();
    for (std::size_t k = 1; k < s.members.size(); ++k) {
        gap = std::min(
            gap, axis_angle(poses[s.members[k]], axis) - axis_angle(poses[s.members[k - 1]], axis));
    }
    const SweepSpeed v = sweep_speed(gap, axis, spec, lim);
    s.speed = v.speed;
    s.max_exposure_s = v.max_exposure_s;
    s.smear_rad = std::min(spec.max_smear_deg * kDeg, 0.25 * gap);
    if (!place_sweep(poses, lim, &s)) {
        return false;
    }
    *out = std::move(s);
    return true;
}

/// Sweeps of two or more poses, largest group first; the poses they take are marked.
std::vector<FlyUnit> group_sweeps(const std::vector<brdf::RigPosed>& poses,
                                  const FlySpec& spec,
                                  const FlyLimits& lim,
                                  std::vector<bool>* taken) {
    std::map<Key, std::vector<std::size_t>> groups;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        for (int axis :
             {static_cast<int>(AxisRole::kLight), static_cast<int>(AxisRole::kDetector)}) {
            groups[stand_key(poses[i], axis)].push_back(i);
        }
    }
    std::vector<std::pair<std::size_t, const std::pair<const Key, std::vector<std::size_t>>*>>
        by_size;
    for (const auto& g : groups) {
        if (g.second.size() >= 2) {
            by_size.push_back({g.second.size(), &g});
        }
    }
    std::stable_sort(by_size.begin(), by_size.end(), [](const auto& a, const auto& b) {
        return a.first > b.first;
    });
    std::vector<FlyUnit> units;
    for (const auto& [size, g] : by_size) {
        FlyUnit u;
        if (make_sweep(poses, g->second, std::get<0>(g->first), *taken, spec, lim, &u.sweep)) {
            for (std::size_t i : u.sweep.members) {
                (*taken)[i] = true;
            }
            units.push_back(std::move(u));
        }
    }
    return units;
}

/// The sweep run the other way.
Sweep reversed(const Sweep& s) {
    Sweep r = s;
    std::reverse(r.members.begin(), r.members.end());
    std::swap(r.from, r.to);
    set_axis_angle(&r.stand, r.axis, r.from);
    return r;
}

brdf::RigPosed exit_pose(const FlyUnit& u) {
    brdf::RigPosed p = u.sweep.stand;
    if (!u.standing) {
        set_axis_angle(&p, u.sweep.axis, u.sweep.to);
    }
    return p;
}

/// Nearest entry first: each unit after the one before it, a sweep entered at its nearer end.
std::vector<FlyUnit> order_units(std::vector<FlyUnit> units,
                                 const brdf::RigPosed& start,
                                 const FlyLimits& lim) {
    std::vector<FlyUnit> out;
    std::vector<bool> used(units.size(), false);
    brdf::RigPosed at = start;
    for (std::size_t n = 0; n < units.size(); ++n) {
        double best = std::numeric_limits<double>::infinity();
        std::size_t pick = 0;
        bool flip = false;
        for (std::size_t k = 0; k < units.size(); ++k) {
            if (used[k]) {
                continue;
            }
            const double fwd = move_time(at, units[k].sweep.stand, lim.dyn);
            const double back =
                units[k].standing ? fwd : move_time(at, reversed(units[k].sweep).stand, lim.dyn);
            if (std::min(fwd, back) < best) {
                best = std::min(fwd, back);
                pick = k;
                flip = back < fwd;
            }
        }
        used[pick] = true;
        FlyUnit u = units[pick];
        if (flip) {
            u.sweep = reversed(u.sweep);
        }
        at = exit_pose(u);
        out.push_back(std::move(u));
    }
    return out;
}

}  // namespace

std::string fly_spec_problem(const FlySpec& s) {
    if (!(s.max_smear_deg > 0 && s.max_smear_deg <= 10)) {
        return "fly.max_smear_deg = " + std::to_string(s.max_smear_deg) + " outside (0, 10]";
    }
    if (!(s.speed_deg_per_s >= 0 && s.speed_deg_per_s <= 1000)) {
        return "fly.speed_deg_per_s = " + std::to_string(s.speed_deg_per_s) +
               " outside [0, 1000] (0: the arm's own speed)";
    }
    return {};
}

double axis_angle(const brdf::RigPosed& p, int axis) {
    return axis == static_cast<int>(AxisRole::kLight) ? p.light : p.detector;
}

void set_axis_angle(brdf::RigPosed* p, int axis, double rad) {
    (axis == static_cast<int>(AxisRole::kLight) ? p->light : p->detector) = rad;
}

SweepSpeed sweep_speed(double gap_rad, int axis, const FlySpec& spec, const FlyLimits& lim) {
    // A smear of more than a quarter of the gap would leave less than half the time between
    // configurations to the trigger: it is bounded there.
    const double smear = std::min(spec.max_smear_deg * kDeg, 0.25 * gap_rad);
    double v = lim.dyn[axis].speed;
    if (spec.speed_deg_per_s > 0) {
        v = std::min(v, spec.speed_deg_per_s * kDeg);
    }
    if (lim.readout_s > 0) {
        v = std::min(v, (0.5 * gap_rad - smear) / lim.readout_s);
    }
    SweepSpeed out;
    out.max_exposure_s = std::min(smear / v, lim.max_exposure_s);
    if (out.max_exposure_s < lim.min_exposure_s) {
        // The shortest exposure would smear more than allowed: slow down to it.
        v = smear / lim.min_exposure_s;
        out.max_exposure_s = lim.min_exposure_s;
    }
    out.speed = v;
    return out;
}

std::vector<FlyUnit> plan_fly_units(const std::vector<brdf::RigPosed>& poses,
                                    const brdf::RigPosed& start,
                                    const FlySpec& spec,
                                    const FlyLimits& lim) {
    std::vector<bool> taken(poses.size(), false);
    std::vector<FlyUnit> units = group_sweeps(poses, spec, lim, &taken);
    for (std::size_t i = 0; i < poses.size(); ++i) {
        if (!taken[i]) {
            FlyUnit u;
            u.standing = true;
            u.sweep.members = {i};
            u.sweep.stand = poses[i];
            units.push_back(std::move(u));
        }
    }
    return order_units(std::move(units), start, lim);
}

}  // namespace gonio::acquisition
