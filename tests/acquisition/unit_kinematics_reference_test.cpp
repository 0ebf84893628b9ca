// solve() against a direct reference of its rule, written out candidate by candidate: both inverse
// solutions, the light/detector swap, each axis shifted by multiples of 2 pi to the representative
// in range nearest the current pose, the smallest move time winning (the first on ties), the last
// rejected candidate's rule as the error. On a grid of targets, limits and current poses the
// solutions agree within 1e-12 and the errors word the same rule.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "common/test_units.h"
#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::RigPosed;
using brdf::Vec3d;
using gonio::test_units::kDeg;

double& axis(RigPosed& p, int k) {
    return k == 0 ? p.light : k == 1 ? p.detector : k == 2 ? p.tilt : p.spin;
}

std::string deg1(double rad) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", rad * 180.0 / kPi);
    return buf;
}

struct RefResult {
    bool ok = false;
    RigPosed pose;
    bool swapped = false;
    double cost = 0;
    std::string error;
};

RefResult reference_solve(const Target& tg,
                          const RigLimits& lim,
                          const std::array<AxisDynamics, kNumAxes>& dyn,
                          RigPosed current) {
    RefResult r;
    const double ti = std::acos(std::clamp(tg.wi.z(), -1.0, 1.0));
    const double to = std::acos(std::clamp(tg.wo.z(), -1.0, 1.0));
    if (!(ti <= lim.max_theta) || !(to <= lim.max_theta)) {
        r.error = "theta";
        return r;
    }
    if (brdf::angle_between(tg.wi, tg.wo) < lim.blind_angle) {
        r.error = "blind zone";
        return r;
    }
    const char* names[kNumAxes] = {"light", "detector", "tilt", "spin"};
    for (int swap = 0; swap < (tg.reciprocal ? 2 : 1); ++swap) {
        for (RigPosed p : brdf::rig_inverse(swap ? tg.wo : tg.wi, swap ? tg.wi : tg.wo)) {
            if (tg.isotropic) {
                p.spin = current.spin;
            }
            bool ok = true;
            for (int k = 0; k < kNumAxes && ok; ++k) {
                const double a = axis(p, k);
                const double near = axis(current, k);
                const double base = a + 2 * kPi * std::round((near - a) / (2 * kPi));
                bool found = false;
                double best = 0;
                for (int m = -2; m <= 2; ++m) {
                    const double c = base + m * 2 * kPi;
                    if (c >= lim.range[k].min - 1e-12 && c <= lim.range[k].max + 1e-12 &&
                        (!found || std::abs(c - near) < std::abs(best - near))) {
                        best = c;
                        found = true;
                    }
                }
                if (!found) {
                    ok = false;
                    r.error = std::string(names[k]) + " " + deg1(a) + " deg outside [" +
                              deg1(lim.range[k].min) + ", " + deg1(lim.range[k].max) + "] deg";
                } else {
                    axis(p, k) = std::clamp(best, lim.range[k].min, lim.range[k].max);
                }
            }
            if (!ok) {
                continue;
            }
            const double cost = move_time(current, p, dyn);
            if (!r.ok || cost < r.cost) {
                r.ok = true;
                r.pose = p;
                r.swapped = swap == 1;
                r.cost = cost;
            }
        }
    }
    return r;
}

TEST(KinematicsReference, SolveMatchesTheCandidateRuleOnAGridOfTargets) {
    std::array<AxisDynamics, kNumAxes> dyn;
    dyn[0] = AxisDynamics{30 * kDeg, 60 * kDeg, 0.005};
    dyn[1] = dyn[0];
    dyn[2] = AxisDynamics{20 * kDeg, 40 * kDeg, 0.005};
    dyn[3] = dyn[0];
    RigLimits wide;  // the standard layout's limits
    wide.range = {AxisRange{-170 * kDeg, 170 * kDeg},
                  AxisRange{-170 * kDeg, 170 * kDeg},
                  AxisRange{-80 * kDeg, 80 * kDeg},
                  AxisRange{-kPi, kPi}};
    RigLimits narrow;  // a cramped rig: many candidates and some targets rejected by the limits
    narrow.range = {AxisRange{-100 * kDeg, 100 * kDeg},
                    AxisRange{-120 * kDeg, 150 * kDeg},
                    AxisRange{-45 * kDeg, 30 * kDeg},
                    AxisRange{-90 * kDeg, 200 * kDeg}};
    const RigPosed currents[] = {
        RigPosed{}, RigPosed{1.2, -0.4, 0.3, 2.5}, RigPosed{-2.8, 2.9, -0.7, -1.0}};
    int solved = 0, rejected = 0, compared = 0;
    for (const RigLimits* lim : {&wide, &narrow}) {
        for (double ti = 0; ti <= 88; ti += 11) {
            for (double to = 0; to <= 88; to += 11) {
                for (double pi_deg = -180; pi_deg < 180; pi_deg += 45) {
                    for (double po_deg = -170; po_deg < 180; po_deg += 40) {
                        const Vec3d wi = brdf::spherical_to_cartesian(ti * kDeg, pi_deg * kDeg);
                        const Vec3d wo = brdf::spherical_to_cartesian(to * kDeg, po_deg * kDeg);
                        for (int flags = 0; flags < 4; ++flags) {
                            const Target tg{wi, wo, (flags & 1) != 0, (flags & 2) != 0};
                            for (const RigPosed& cur : currents) {
                                const RefResult ref = reference_solve(tg, *lim, dyn, cur);
                                const auto s = solve(tg, *lim, dyn, cur);
                                ++compared;
                                ASSERT_EQ(static_cast<bool>(s), ref.ok)
                                    << ti << " " << to << " " << pi_deg << " " << po_deg;
                                if (!s) {
                                    ++rejected;
                                    EXPECT_NE(s.error().message.find(ref.error), std::string::npos)
                                        << s.error().message << " / " << ref.error;
                                    continue;
                                }
                                ++solved;
                                EXPECT_NEAR(s->pose.light, ref.pose.light, 1e-12);
                                EXPECT_NEAR(s->pose.detector, ref.pose.detector, 1e-12);
                                EXPECT_NEAR(s->pose.tilt, ref.pose.tilt, 1e-12);
                                EXPECT_NEAR(s->pose.spin, ref.pose.spin, 1e-12);
                                EXPECT_EQ(s->swapped, ref.swapped);
                                EXPECT_NEAR(s->cost_s, ref.cost, 1e-12);
                                const auto [fi, fo] = brdf::rig_forward(ref.pose);
                                EXPECT_NEAR((s->wi - fi).norm(), 0, 1e-12);
                                EXPECT_NEAR((s->wo - fo).norm(), 0, 1e-12);
                            }
                        }
                    }
                }
            }
        }
    }
    EXPECT_EQ(compared, 2 * 9 * 9 * 8 * 9 * 4 * 3);
    // Both outcomes are exercised, the limits included.
    EXPECT_GT(solved, compared / 4);
    EXPECT_GT(rejected, 100);
}

}  // namespace
}  // namespace gonio::acquisition
