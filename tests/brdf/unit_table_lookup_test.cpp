// Tabulated BRDFs: lookups against an analytic model at bin centres (exact up to the stored
// precision) and between centres (interpolation error reported), the rules for invalid bins, phi_d
// periodicity, statistics, reciprocity.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {
namespace {

ModelD ggx_model(double alpha) {
    ModelD m;
    m.has_diffuse = true;
    m.diffuse = Rgbd(0.3, 0.2, 0.1);
    Lobe<double> l;
    l.distribution = Distribution::kGgx;
    l.alpha_x = alpha;
    l.alpha_y = alpha;
    l.shadowing = Shadowing::kSmithCorrelated;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd(0.9, 0.6, 0.3);
    m.lobes.push_back(l);
    return m;
}

// Uniform random direction above the horizon with theta < theta_max.
Vec3d random_direction(std::mt19937_64& rng, double theta_max) {
    std::uniform_real_distribution<double> u(0, 1);
    const double cos_t = 1 - u(rng) * (1 - std::cos(theta_max));
    return spherical_to_cartesian(std::acos(cos_t), 2 * kPi * u(rng));
}

TEST(TableLookup, NearestAtBinCentresMatchesModel) {
    const AnalyticBrdf model(ggx_model(0.3));
    TabulateOptions opts;
    opts.grid = TableGrid{30, 30, 60};
    opts.threads = 2;
    TabulatedBrdf table = tabulate(model, opts);
    const TableGrid& g = table.grid();
    double worst_nearest = 0;
    double worst_trilinear = 0;
    std::size_t checked = 0;
    for (int ih = 0; ih < g.n_theta_h; ++ih) {
        for (int id = 0; id < g.n_theta_d; ++id) {
            for (int ip = 0; ip < g.n_phi_d; ++ip) {
                const auto [wi, wo] = g.centre_directions(ih, id, ip);
                if (wi.z() <= 0 || wo.z() <= 0) {
                    ASSERT_FALSE(table.bin_valid(g.index(ih, id, ip)));
                    continue;
                }
                const Rgbd expect = eval_model(model.model(), wi, wo);
                table.set_interpolation(Interpolation::kNearest);
                const TableLookup n = table.lookup(wi, wo);
                table.set_interpolation(Interpolation::kTrilinear);
                const TableLookup t = table.lookup(wi, wo);
                ASSERT_TRUE(n.valid && t.valid);
                worst_nearest =
                    std::max(worst_nearest, ((n.value - expect).abs() / expect).maxCoeff());
                worst_trilinear =
                    std::max(worst_trilinear, ((t.value - expect).abs() / expect).maxCoeff());
                ++checked;
            }
        }
    }
    std::printf("centres %zu: worst relative error nearest %.3g, trilinear %.3g\n",
                checked,
                worst_nearest,
                worst_trilinear);
    // value / scale * scale: within 2 ulps.
    EXPECT_LT(worst_nearest, 5e-16);
    // Trilinear weights at a centre are 1 up to rounding of the index coordinates.
    EXPECT_LT(worst_trilinear, 1e-9);
}

// Between centres: relative error of both lookups against the model at random directions (theta up
// to 80 degrees, so that every query has valid neighbours), on the MERL grid and a coarser one.
TEST(TableLookup, InterpolationErrorBetweenCentres) {
    const AnalyticBrdf model(ggx_model(0.3));
    const unsigned seed = 7;
    for (const TableGrid grid : {TableGrid{45, 45, 90}, TableGrid::merl()}) {
        TabulateOptions opts;
        opts.grid = grid;
        opts.threads = 2;
        TabulatedBrdf table = tabulate(model, opts);
        std::mt19937_64 rng(seed);
        std::vector<double> err_n;
        std::vector<double> err_t;
        for (int k = 0; k < 20000; ++k) {
            const Vec3d wi = random_direction(rng, 80 * kPi / 180);
            const Vec3d wo = random_direction(rng, 80 * kPi / 180);
            const Rgbd expect = eval_model(model.model(), wi, wo);
            table.set_interpolation(Interpolation::kNearest);
            const TableLookup n = table.lookup(wi, wo);
            table.set_interpolation(Interpolation::kTrilinear);
            const TableLookup t = table.lookup(wi, wo);
            ASSERT_TRUE(t.valid) << "seed " << seed << " k " << k;
            if (n.valid) {
                err_n.push_back(((n.value - expect).abs() / expect).maxCoeff());
            }
            err_t.push_back(((t.value - expect).abs() / expect).maxCoeff());
        }
        auto pct = [](std::vector<double> v, double q) {
            std::sort(v.begin(), v.end());
            return v[static_cast<std::size_t>(q * (v.size() - 1))];
        };
        const double n50 = pct(err_n, 0.5), n95 = pct(err_n, 0.95);
        const double t50 = pct(err_t, 0.5), t95 = pct(err_t, 0.95);
        std::printf(
            "grid %dx%dx%d GGX alpha 0.3: relative error median/95%%: nearest %.3g/%.3g, "
            "trilinear %.3g/%.3g (%zu nearest queries valid of 20000)\n",
            grid.n_theta_h,
            grid.n_theta_d,
            grid.n_phi_d,
            n50,
            n95,
            t50,
            t95,
            err_n.size());
        // Trilinear must beat nearest, and on the MERL grid stay within 0.2 % (median) and 1 %
        // (95th percentile) for a smooth lobe.
        EXPECT_LT(t50, n50) << "seed " << seed;
        EXPECT_LT(t95, n95) << "seed " << seed;
        if (grid.n_theta_h == 90) {
            EXPECT_LT(t50, 0.002) << "seed " << seed;
            EXPECT_LT(t95, 0.01) << "seed " << seed;
        }
    }
}

// A 4 x 4 x 4 table whose values are linear in the index coordinates, f = 1 + u_h + 2 u_d + 3 u_p:
// trilinear interpolation reproduces it exactly between centres.
TabulatedBrdf linear_table() {
    const TableGrid g{4, 4, 4};
    TabulatedBrdf t = TabulatedBrdf::empty(g, {1.0, 1.0, 1.0}, "linear");
    for (int ih = 0; ih < 4; ++ih) {
        for (int id = 0; id < 4; ++id) {
            for (int ip = 0; ip < 4; ++ip) {
                const double v = 1 + ih + 2 * id + 3 * ip;
                t.set_bin(g.index(ih, id, ip), Rgbd(v, 2 * v, 3 * v));
            }
        }
    }
    return t;
}

// Angles with index coordinates (u_h, u_d, u_p) = (a, b, c): inverse of
// TableGrid::continuous_index.
std::array<double, 3> angles_at(const TableGrid& g, double a, double b, double c) {
    const double sh = (a + 0.5) / g.n_theta_h;
    return {sh * sh * kPi / 2, (b + 0.5) / g.n_theta_d * kPi / 2, (c + 0.5) / g.n_phi_d * kPi};
}

TEST(TableLookup, TrilinearReproducesLinearData) {
    const TabulatedBrdf t = linear_table();
    const std::array<double, 3> x = angles_at(t.grid(), 1.25, 0.5, 2.75);
    const TableLookup l = t.lookup_trilinear(x[0], x[1], x[2]);
    ASSERT_TRUE(l.valid);
    const double expect = 1 + 1.25 + 2 * 0.5 + 3 * 2.75;
    EXPECT_NEAR(l.value[0], expect, 1e-12);
    EXPECT_NEAR(l.value[2], 3 * expect, 1e-12);
    // Beyond the last theta centre the value is held constant (u_h = 3.4 acts as 3).
    const std::array<double, 3> y = angles_at(t.grid(), 3.4, 0.0, 1.0);
    EXPECT_NEAR(t.lookup_trilinear(y[0], y[1], y[2]).value[0], 1 + 3 + 0 + 3, 1e-12);
    // Nearest picks the containing bin, which spans [i - 1/2, i + 1/2) in index coordinates:
    // (1.25, 0.4, 2.75) is in bin (1, 0, 3).
    const std::array<double, 3> z = angles_at(t.grid(), 1.25, 0.4, 2.75);
    const TableLookup n = t.lookup_nearest(z[0], z[1], z[2]);
    EXPECT_DOUBLE_EQ(n.value[0], 1 + 1 + 0 + 3 * 3);
}

TEST(TableLookup, PhiDifferenceIsPeriodicInTrilinear) {
    const TabulatedBrdf t = linear_table();
    // u_p = -0.25: a quarter of the way from the last centre (3, at phi_d = pi - pi/8) to the first
    // (0, at pi/8) across phi_d = 0 = pi: 0.25 * f(ip = 3) + 0.75 * f(ip = 0).
    const std::array<double, 3> x = angles_at(t.grid(), 1.0, 2.0, -0.25);
    const TableLookup l = t.lookup_trilinear(x[0], x[1], x[2]);
    const double f3 = 1 + 1 + 4 + 9;
    const double f0 = 1 + 1 + 4 + 0;
    EXPECT_NEAR(l.value[0], 0.25 * f3 + 0.75 * f0, 1e-12);
    // The same point written as a negative phi_d (shift by pi) gives the same value.
    const TableLookup m = t.lookup_trilinear(x[0], x[1], x[2] - kPi);
    EXPECT_NEAR(m.value[0], l.value[0], 1e-12);
}

TEST(TableLookup, InvalidBinsGiveZeroWithFlagOrAreSkipped) {
    TabulatedBrdf t = linear_table();
    const TableGrid g = t.grid();
    // Invalidate corner (1, 0, 2) of the cell around (1.25, 0.5, 2.75).
    t.set_bin_invalid(g.index(1, 0, 2));
    const std::array<double, 3> x = angles_at(g, 1.25, 0.5, 2.75);
    // Weights: t = (0.25, 0.5, 0.75); the invalid corner (lo, lo, lo) had 0.75 * 0.5 * 0.25.
    double sum = 0;
    double wsum = 0;
    for (int c = 0; c < 8; ++c) {
        const int ih = (c & 1) ? 2 : 1, id = (c & 2) ? 1 : 0, ip = (c & 4) ? 3 : 2;
        const double w = ((c & 1) ? 0.25 : 0.75) * ((c & 2) ? 0.5 : 0.5) * ((c & 4) ? 0.75 : 0.25);
        if (c == 0) {
            continue;
        }
        sum += w * (1 + ih + 2 * id + 3 * ip);
        wsum += w;
    }
    const TableLookup l = t.lookup_trilinear(x[0], x[1], x[2]);
    ASSERT_TRUE(l.valid);
    EXPECT_NEAR(l.value[0], sum / wsum, 1e-12);
    // Nearest lookup inside the invalid bin: zero, flagged.
    const std::array<double, 3> y = angles_at(g, 1.0, 0.0, 2.0);
    const TableLookup n = t.lookup_nearest(y[0], y[1], y[2]);
    EXPECT_FALSE(n.valid);
    EXPECT_EQ(n.value.abs().maxCoeff(), 0.0);
    // All corners invalid: zero, flagged, never NaN.
    TabulatedBrdf e = TabulatedBrdf::empty(g, {1, 1, 1}, "empty");
    const TableLookup z = e.lookup_trilinear(x[0], x[1], x[2]);
    EXPECT_FALSE(z.valid);
    EXPECT_TRUE(z.value.isFinite().all());
    EXPECT_EQ(z.value.abs().maxCoeff(), 0.0);
}

TEST(TableLookup, BelowHorizonIsZero) {
    const TabulatedBrdf t = linear_table();
    const Vec3d up = spherical_to_cartesian(0.3, 0.0);
    const Vec3d down(0.1, 0.0, -0.99);
    EXPECT_FALSE(t.lookup(up, down).valid);
    EXPECT_EQ(t.eval(down, up).abs().maxCoeff(), 0.0);
    EXPECT_EQ(t.eval(up, Vec3d(1, 0, 0)).abs().maxCoeff(), 0.0);
}

TEST(TableLookup, StatisticsOverValidBins) {
    const TableGrid g{1, 1, 4};
    // Stored values per channel block; bin 2 negative (not measured). Scale (2, 1, 0.5).
    TabulatedBrdf t(g, {2.0, 1.0, 0.5}, {1, 2, -1, 4, /*g*/ 1, 1, -1, 1, /*b*/ 8, 0, -1, 2}, "s");
    const TableStatistics s = t.compute_statistics();
    EXPECT_EQ(s.bins, 4u);
    EXPECT_EQ(s.valid_bins, 3u);
    EXPECT_DOUBLE_EQ(s.min[0], 2.0);
    EXPECT_DOUBLE_EQ(s.max[0], 8.0);
    EXPECT_DOUBLE_EQ(s.mean[0], (2.0 + 4.0 + 8.0) / 3);
    EXPECT_DOUBLE_EQ(s.mean[1], 1.0);
    EXPECT_DOUBLE_EQ(s.min[2], 0.0);
    EXPECT_DOUBLE_EQ(s.max[2], 4.0);
    EXPECT_NE(t.statistics().find("valid bins: 3 of 4"), std::string::npos) << t.statistics();
}

// lookup(wi, wo) computes the half/difference angles its own way (no trigonometric rotation): it
// must agree with to_half_diff() of coords.h.
TEST(TableLookup, DirectionLookupAgreesWithHalfDiffCoordinates) {
    const TableGrid g{40, 40, 80};
    TabulatedBrdf t = TabulatedBrdf::empty(g, {1, 1, 1}, "index");
    for (std::size_t flat = 0; flat < g.size(); ++flat) {
        t.set_bin(flat, Rgbd::Constant(static_cast<double>(flat)));
    }
    t.set_interpolation(Interpolation::kTrilinear);
    const unsigned seed = 5;
    std::mt19937_64 rng(seed);
    for (int k = 0; k < 5000; ++k) {
        const Vec3d wi = random_direction(rng, 1.55);
        const Vec3d wo = k % 10 == 0 ? reflect_z(wi) : random_direction(rng, 1.55);
        const HalfDiff<double> hd = to_half_diff(wi, wo);
        const TableLookup a = t.lookup(wi, wo);
        const TableLookup b = t.lookup_half_diff(hd.theta_h, hd.theta_d, hd.phi_d);
        ASSERT_TRUE(a.valid && b.valid);
        ASSERT_NEAR(a.value[0], b.value[0], 1e-6) << "seed " << seed << " k " << k;
    }
}

TEST(TableLookup, ReciprocalUnderTrilinear) {
    const AnalyticBrdf model(ggx_model(0.2));
    TabulateOptions opts;
    opts.grid = TableGrid{30, 30, 60};
    TabulatedBrdf table = tabulate(model, opts);
    table.set_interpolation(Interpolation::kTrilinear);
    const unsigned seed = 11;
    std::mt19937_64 rng(seed);
    for (int k = 0; k < 2000; ++k) {
        const Vec3d wi = random_direction(rng, 1.5);
        const Vec3d wo = random_direction(rng, 1.5);
        const Rgbd a = table.eval(wi, wo);
        const Rgbd b = table.eval(wo, wi);
        ASSERT_LT(((a - b).abs() / (a.abs() + 1e-300)).maxCoeff(), 1e-9) << "seed " << seed;
    }
}

}  // namespace
}  // namespace gonio::brdf
