#include "gonio/acquisition/shared/kinematics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "gonio/base/check.h"

namespace gonio::acquisition {

using brdf::kPi;
using brdf::RigPosed;
using brdf::Vec3d;

namespace {

double deg(double rad) {
    return rad * 180.0 / kPi;
}

std::string fmt_deg(double rad) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", deg(rad));
    return buf;
}

double& axis_ref(RigPosed& p, int k) {
    switch (k) {
        case 0:
            return p.light;
        case 1:
            return p.detector;
        case 2:
            return p.tilt;
        default:
            return p.spin;
    }
}

double axis_val(const RigPosed& p, int k) {
    return axis_ref(const_cast<RigPosed&>(p), k);
}

/// Shifts angle a by multiples of 2 pi into [r.min, r.max], choosing the representative nearest to
/// `near`. Returns false when no representative lies in the range.
bool place_in_range(double a, const AxisRange& r, double near, double* out) {
    const double two_pi = 2 * kPi;
    // Representative closest to `near`, then the neighbours on both sides.
    const double base = a + two_pi * std::round((near - a) / two_pi);
    bool found = false;
    double best = 0;
    for (int k = -2; k <= 2; ++k) {
        const double c = base + k * two_pi;
        if (c < r.min - 1e-12 || c > r.max + 1e-12) {
            continue;
        }
        if (!found || std::abs(c - near) < std::abs(best - near)) {
            best = c;
            found = true;
        }
    }
    if (found) {
        *out = std::clamp(best, r.min, r.max);
    }
    return found;
}

}  // namespace

const char* to_string(AxisRole r) {
    switch (r) {
        case AxisRole::kLight:
            return "light";
        case AxisRole::kDetector:
            return "detector";
        case AxisRole::kTilt:
            return "tilt";
        case AxisRole::kSpin:
            return "spin";
    }
    return "?";
}

double trapezoid_time(double d, double speed, double accel) {
    GONIO_CHECK_MSG(speed > 0 && accel > 0, "speed " << speed << " accel " << accel);
    if (d <= 0) {
        // No motion: no time.
        return 0;
    }
    if (d >= speed * speed / accel) {
        // Accelerate to the cruise speed, cruise, decelerate.
        return d / speed + speed / accel;
    }
    // Triangular profile: the cruise speed is never reached.
    return 2 * std::sqrt(d / accel);
}

double move_time(const RigPosed& a,
                 const RigPosed& b,
                 const std::array<AxisDynamics, kNumAxes>& dyn) {
    double t = 0;
    double settle = 0;
    for (int k = 0; k < kNumAxes; ++k) {
        const double d = std::abs(axis_val(b, k) - axis_val(a, k));
        if (d < 1e-12) {
            continue;
        }
        t = std::max(t, trapezoid_time(d, dyn[k].speed, dyn[k].accel));
        settle = std::max(settle, dyn[k].settle_s);
    }
    return t + settle;
}

Expected<Solution> solve(const Target& tg,
                         const RigLimits& lim,
                         const std::array<AxisDynamics, kNumAxes>& dyn,
                         const RigPosed& current) {
    const double theta_i = std::acos(std::clamp(tg.wi.z(), -1.0, 1.0));
    const double theta_o = std::acos(std::clamp(tg.wo.z(), -1.0, 1.0));
    if (!(theta_i <= lim.max_theta) || !(theta_o <= lim.max_theta)) {
        // Includes NaN directions: the comparison fails.
        return make_error("theta_i " + fmt_deg(theta_i) + " deg / theta_o " + fmt_deg(theta_o) +
                          " deg beyond the largest measured polar angle " + fmt_deg(lim.max_theta) +
                          " deg");
    }
    const double sep = brdf::angle_between(tg.wi, tg.wo);
    if (sep < lim.blind_angle) {
        return make_error("blind zone: arms " + fmt_deg(sep) + " deg apart < " +
                          fmt_deg(lim.blind_angle) + " deg (detector would shadow the light)");
    }
    bool found = false;
    RigPosed best_pose;
    double best_cost = 0;
    bool best_swapped = false;
    // The rule the last rejected candidate broke, worded only when no candidate is left.
    int why_axis = -1;
    double why_value = 0;
    for (int swap = 0; swap < (tg.reciprocal ? 2 : 1); ++swap) {
        const Vec3d& wi = swap ? tg.wo : tg.wi;
        const Vec3d& wo = swap ? tg.wi : tg.wo;
        for (const RigPosed& raw : brdf::rig_inverse(wi, wo)) {
            RigPosed p = raw;
            if (tg.isotropic) {
                // Only the canonical triple matters: rotating the pair about the normal is free, so
                // the spin stays where it is.
                p.spin = current.spin;
            }
            bool ok = true;
            for (int k = 0; k < kNumAxes && ok; ++k) {
                double placed = 0;
                if (!place_in_range(axis_val(p, k), lim.range[k], axis_val(current, k), &placed)) {
                    ok = false;
                    why_axis = k;
                    why_value = axis_val(p, k);
                } else {
                    axis_ref(p, k) = placed;
                }
            }
            if (!ok) {
                continue;
            }
            const double cost = move_time(current, p, dyn);
            if (!found || cost < best_cost) {
                best_pose = p;
                best_cost = cost;
                best_swapped = swap == 1;
                found = true;
            }
        }
    }
    if (!found) {
        // Every target has candidates (rig_inverse gives two), so a rejected one is on record.
        GONIO_CHECK(why_axis >= 0);
        const char* names[kNumAxes] = {"light", "detector", "tilt", "spin"};
        const auto& r = lim.range[why_axis];
        return make_error(std::string(names[why_axis]) + " " + fmt_deg(why_value) +
                          " deg outside [" + fmt_deg(r.min) + ", " + fmt_deg(r.max) + "] deg");
    }
    const auto [fi, fo] = brdf::rig_forward(best_pose);
    return Solution{best_pose, fi, fo, best_swapped, best_cost};
}

}  // namespace gonio::acquisition
