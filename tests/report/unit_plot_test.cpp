// Plots: drawn for every model type and for a table; the in-plane peak sits at the mirror angle;
// an empty dataset is an error and writes nothing.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/resample.h"
#include "gonio/report/plot.h"
#include "test_models.h"

namespace gonio::report {
namespace {

using gonio::test_units::kDeg;

int color_distance(Color a, Color b) {
    return std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
}

/// Angle from the upward vertical (degrees, positive to the right) of the pixel of colour c that
/// lies farthest from the polar origin, inside the outer ring.
double peak_angle_deg(const Image& img, const PolarLayout& lay, Color c, double* dist = nullptr) {
    double best = -1;
    double angle = std::nan("");
    for (int y = 0; y < img.height; ++y) {
        for (int x = 0; x < img.width; ++x) {
            if (color_distance(img.at(x, y), c) > 12) {
                continue;
            }
            const double dx = x + 0.5 - lay.origin_x;
            const double dy = lay.origin_y - (y + 0.5);
            const double r = std::hypot(dx, dy);
            if (r > lay.radius_px + 1 || dy < 0) {
                // Outside the plot: the light-direction marks and the legend.
                continue;
            }
            if (r > best) {
                best = r;
                angle = std::atan2(dx, dy) / kDeg;
            }
        }
    }
    if (dist != nullptr) {
        *dist = best;
    }
    return angle;
}

/// In-plane samples of a BRDF at theta_i (degrees), every 2 degrees of theta_o on both sides, with
/// 3 % multiplicative noise (seeded) and matching sigma.
brdf::Dataset in_plane_samples(const brdf::Brdf& b, double theta_i_deg, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.03);
    brdf::Dataset d;
    d.source = "synthetic.csv";
    d.has_sigma = true;
    for (int t = -88; t <= 88; t += 2) {
        brdf::Sample s;
        s.theta_i = theta_i_deg * kDeg;
        s.phi_i = 0.3;
        s.theta_o = std::abs(t) * kDeg;
        s.phi_o = t >= 0 ? s.phi_i + brdf::kPi : s.phi_i;
        const brdf::Rgbd f = b.eval(s.wi(), s.wo());
        s.value = f * (1.0 + noise(rng));
        s.sigma = 0.03 * f;
        d.samples.push_back(s);
    }
    return d;
}

TEST(InPlanePlot, FittedCurvePeaksAtTheMirrorAngle) {
    // Narrow lobes (alpha 0.02): the off-specular shift of the peak (Fresnel and the 1 / cos_o
    // factor push it toward grazing, by about alpha^2 radians) stays far below a degree.
    for (auto [name, model] : testing::every_model_type()) {
        if (model.lobes.empty()) {
            continue;
        }
        SCOPED_TRACE(name);
        brdf::Lobe<double>& l = model.lobes[0];
        l.alpha_y *= 0.02 / l.alpha_x;
        l.alpha_x = 0.02;
        l.exponent = 2.0 / (0.02 * 0.02) - 2.0;
        const brdf::AnalyticBrdf fit(model);
        PlotOptions o;
        o.theta_i_deg = {25.0, 50.0};
        PolarLayout lay;
        auto img = plot_in_plane(brdf::Dataset{}, &fit, o, &lay);
        ASSERT_TRUE(img) << img.error().message;
        EXPECT_EQ(img->width, 800);
        ASSERT_EQ(lay.slice_colors.size(), 2u);
        EXPECT_NEAR(peak_angle_deg(*img, lay, lay.slice_colors[0]), 25.0, 1.5);
        EXPECT_NEAR(peak_angle_deg(*img, lay, lay.slice_colors[1]), 50.0, 1.5);
    }
}

TEST(InPlanePlot, MeasuredMarkersPeakAtTheMirrorAngleOnLogScale) {
    const auto models = testing::every_model_type();
    const brdf::AnalyticBrdf truth(models[0].second);
    const unsigned seed = 20261122;
    SCOPED_TRACE("seed " + std::to_string(seed));
    const brdf::Dataset d = in_plane_samples(truth, 40.0, seed);
    PlotOptions o;
    o.scale = AxisScale::kLog;
    PolarLayout lay;
    auto img = plot_in_plane(d, nullptr, o, &lay);
    ASSERT_TRUE(img) << img.error().message;
    ASSERT_EQ(lay.theta_i_deg.size(), 1u);  // the slice is found in the data
    EXPECT_NEAR(lay.theta_i_deg[0], 40.0, 1e-9);
    EXPECT_NEAR(peak_angle_deg(*img, lay, lay.slice_colors[0]), 40.0, 2.5);
}

TEST(InPlanePlot, LambertianCurveIsAHalfCircleOfConstantRadius) {
    // f = rho / pi everywhere: every curve pixel lies at the same distance from the origin.
    const brdf::AnalyticBrdf fit(testing::every_model_type().back().second);
    PlotOptions o;
    o.theta_i_deg = {30.0};
    PolarLayout lay;
    auto img = plot_in_plane(brdf::Dataset{}, &fit, o, &lay);
    ASSERT_TRUE(img) << img.error().message;
    double rmin = 1e9, rmax = 0;
    for (int y = 0; y < img->height; ++y) {
        for (int x = 0; x < img->width; ++x) {
            if (color_distance(img->at(x, y), lay.slice_colors[0]) > 12) {
                continue;
            }
            const double dx = x + 0.5 - lay.origin_x;
            const double dy = lay.origin_y - (y + 0.5);
            const double r = std::hypot(dx, dy);
            if (r > lay.radius_px + 1 || dy < 2) {
                continue;
            }
            rmin = std::min(rmin, r);
            rmax = std::max(rmax, r);
        }
    }
    ASSERT_GT(rmax, 0);
    // A 2 px anti-aliased line drawn on the pixel grid: within +-2.5 px of one radius.
    EXPECT_LT(rmax - rmin, 5.0);
    EXPECT_GT(rmin, 0.5 * lay.radius_px);
}

TEST(Plots, EveryModelTypeAndATableGivesEveryPlot) {
    auto models = testing::every_model_type();
    std::vector<std::pair<std::string, std::unique_ptr<brdf::Brdf>>> brdfs;
    for (auto& [name, m] : models) {
        brdfs.push_back({name, brdf::make_analytic_brdf(m)});
    }
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{45, 45, 90};
    to.threads = 1;
    brdfs.push_back(
        {"table", std::make_unique<brdf::TabulatedBrdf>(brdf::tabulate(*brdfs[0].second, to))});
    for (const auto& [name, b] : brdfs) {
        SCOPED_TRACE(name);
        brdf::Dataset d = in_plane_samples(*b, 30.0, 7);
        // Azimuthal samples at theta_i = theta_o = 45 degrees.
        for (int a = 0; a <= 180; a += 15) {
            brdf::Sample s;
            s.theta_i = 45 * kDeg;
            s.theta_o = 45 * kDeg;
            s.phi_o = a * kDeg;
            s.value = b->eval(s.wi(), s.wo());
            d.samples.push_back(s);
        }
        for (bool log : {false, true}) {
            PlotOptions o;
            o.scale = log ? AxisScale::kLog : AxisScale::kLinear;
            auto ip = plot_in_plane(d, b.get(), o);
            ASSERT_TRUE(ip) << ip.error().message;
            auto dp = plot_delta_phi(d, b.get(), o);
            ASSERT_TRUE(dp) << dp.error().message;
            auto rm = plot_residual_map(d, *b, o);
            ASSERT_TRUE(rm) << rm.error().message;
            auto cov = plot_coverage(d, o);
            ASSERT_TRUE(cov) << cov.error().message;
            for (const Image* im : {&*ip, &*dp, &*rm, &*cov}) {
                EXPECT_EQ(im->width, 800);
                EXPECT_GT(im->height, 300);
            }
        }
        if (name != "table" && name != "lambert") {
            PolarLayout lay;
            PlotOptions o;
            o.theta_i_deg = {30.0};
            auto ip = plot_in_plane(d, b.get(), o, &lay);
            ASSERT_TRUE(ip);
            EXPECT_NEAR(peak_angle_deg(*ip, lay, lay.slice_colors[0]), 30.0, 2.5);
        }
    }
}

TEST(Plots, TablePeakAtTheMirrorAngle) {
    const brdf::AnalyticBrdf model(testing::every_model_type()[0].second);
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{90, 45, 90};
    to.threads = 2;
    const brdf::TabulatedBrdf table = brdf::tabulate(model, to);
    PlotOptions o;
    o.theta_i_deg = {35.0};
    PolarLayout lay;
    auto img = plot_in_plane(brdf::Dataset{}, &table, o, &lay);
    ASSERT_TRUE(img) << img.error().message;
    EXPECT_NEAR(peak_angle_deg(*img, lay, lay.slice_colors[0]), 35.0, 2.0);
}

TEST(Plots, EmptyDatasetIsAClearErrorAndWritesNothing) {
    const auto dir = std::filesystem::path(GONIO_BINARY_DIR) / "tests" / "report_empty_plots";
    std::filesystem::remove_all(dir);
    brdf::Dataset empty;
    empty.source = "campaign/dataset.csv";
    const brdf::AnalyticBrdf fit(testing::every_model_type()[0].second);
    auto r = write_plots(empty, &fit, PlotOptions{}, dir.string());
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("campaign/dataset.csv"), std::string::npos);
    EXPECT_NE(r.error().message.find("empty dataset"), std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(dir));
    EXPECT_FALSE(plot_residual_map(empty, fit, PlotOptions{}));
    EXPECT_FALSE(plot_coverage(empty, PlotOptions{}));
    EXPECT_FALSE(plot_in_plane(empty, nullptr, PlotOptions{}));
}

TEST(Plots, WritePlotsWritesTheThreePictures) {
    const auto dir = std::filesystem::path(GONIO_BINARY_DIR) / "tests" / "report_write_plots";
    std::filesystem::remove_all(dir);
    const brdf::AnalyticBrdf fit(testing::every_model_type()[1].second);
    const brdf::Dataset d = in_plane_samples(fit, 45.0, 11);
    auto r = write_plots(d, &fit, PlotOptions{}, dir.string());
    ASSERT_TRUE(r) << r.error().message;
    // No azimuthal slice in these data, but the fit draws its own delta_phi curves.
    ASSERT_EQ(r->written.size(), 3u);
    for (const char* f : {"in_plane.png", "delta_phi.png", "residuals.png"}) {
        auto img = read_png((dir / f).string());
        ASSERT_TRUE(img) << f;
        EXPECT_EQ(img->width, 800);
    }
}

TEST(ResidualMap, ExactFitIsWhiteAndBiasedFitIsRed) {
    // Data equal to the fit: every filled cell has residual 0 (the white centre of the scale);
    // data twice the fit: log10(2) > 0, red cells (r > b).
    const brdf::AnalyticBrdf fit(testing::every_model_type()[0].second);
    brdf::Dataset d = in_plane_samples(fit, 30.0, 3);
    for (brdf::Sample& s : d.samples) {
        s.value = fit.eval(s.wi(), s.wo());
    }
    auto same = plot_residual_map(d, fit, PlotOptions{});
    ASSERT_TRUE(same);
    for (brdf::Sample& s : d.samples) {
        s.value *= 2.0;
    }
    auto twice = plot_residual_map(d, fit, PlotOptions{});
    ASSERT_TRUE(twice);
    int white = 0, red = 0;
    for (int y = 60; y < same->height - 80; ++y) {
        for (int x = 92; x < 500; ++x) {
            const Color a = same->at(x, y);
            const Color b = twice->at(x, y);
            if (a != b) {
                // A cell filled in both: exact fit near white, doubled data red.
                white += a.r > 235 && a.g > 235 && a.b > 235;
                red += b.r > b.b + 60;
            }
        }
    }
    EXPECT_GT(white, 100);
    EXPECT_GT(red, 100);
}

}  // namespace
}  // namespace gonio::report

namespace gonio::report {
namespace {

/// Pixels that are strongly coloured (not grey, not white) in the rectangle [x0, x1) x [y0, y1).
std::size_t coloured_pixels(const Image& img, int x0, int y0, int x1, int y1) {
    std::size_t n = 0;
    for (int y = std::max(0, y0); y < std::min(img.height, y1); ++y) {
        for (int x = std::max(0, x0); x < std::min(img.width, x1); ++x) {
            const Color c = img.at(x, y);
            const int hi = std::max({c.r, c.g, c.b});
            const int lo = std::min({c.r, c.g, c.b});
            n += hi - lo > 60 ? 1 : 0;
        }
    }
    return n;
}

/// Samples at uniformly random directions (seeded), none on a slice of the plane of incidence.
brdf::Dataset scattered_samples(const brdf::Brdf& b, unsigned seed, std::size_t n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    brdf::Dataset d;
    d.source = "scattered.csv";
    for (std::size_t k = 0; k < n; ++k) {
        brdf::Sample s;
        s.theta_i = std::acos(1 - 0.95 * u(rng));
        s.phi_i = 2 * brdf::kPi * u(rng);
        s.theta_o = std::acos(1 - 0.95 * u(rng));
        // Away from the plane of incidence by 10 to 170 degrees of azimuth.
        s.phi_o = s.phi_i + (10 + 160 * u(rng)) * kDeg;
        s.value = b.eval(s.wi(), s.wo());
        d.samples.push_back(s);
    }
    return d;
}

TEST(ScatteredPlot, SamplesOffEverySliceAreDrawnAgainstTheHalfAngle) {
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    for (unsigned seed : {1u, 2u, 3u}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const brdf::Dataset d = scattered_samples(truth, seed, 200);
        PlotOptions o;
        auto img = plot_in_plane(d, nullptr, o);
        ASSERT_TRUE(img) << img.error().message;
        // Markers coloured by theta_d fill the plot area; an empty plot has none.
        const std::size_t marked =
            coloured_pixels(*img, 90, 70, img->width - 130, img->height - 64);
        EXPECT_GT(marked, 200u * 4) << "scattered samples not drawn";
        // The same data with nothing: the title alone would say nothing; here an empty dataset
        // with no fit is an error, never a blank picture.
        EXPECT_FALSE(plot_in_plane(brdf::Dataset{}, nullptr, o));
    }
}

TEST(ScatteredPlot, SamplesNearASliceAreDrawnAtTheirOwnAngle) {
    // theta_i within 2 degrees of 30, wo within 2 degrees of the plane: one slice at the median
    // theta_i, each marker at its own theta_o; the brightest marker sits at the mirror angle.
    const brdf::AnalyticBrdf truth(testing::every_model_type()[1].second);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> jitter(-2.0, 2.0);
    brdf::Dataset d;
    d.source = "jittered.csv";
    for (int t = -86; t <= 86; t += 3) {
        brdf::Sample s;
        s.theta_i = (30 + jitter(rng)) * kDeg;
        s.phi_i = 0.4;
        s.theta_o = std::abs(t) * kDeg;
        const double off = jitter(rng) * kDeg / std::max(std::sin(s.theta_o), 0.1);
        s.phi_o = (t >= 0 ? s.phi_i + brdf::kPi : s.phi_i) + off;
        s.value = truth.eval(s.wi(), s.wo());
        d.samples.push_back(s);
    }
    PlotOptions o;
    PolarLayout lay;
    auto img = plot_in_plane(d, nullptr, o, &lay);
    ASSERT_TRUE(img) << img.error().message;
    ASSERT_EQ(lay.theta_i_deg.size(), 1u);
    EXPECT_NEAR(lay.theta_i_deg[0], 30.0, 2.0);
    EXPECT_NEAR(peak_angle_deg(*img, lay, lay.slice_colors[0]), 30.0, 4.0);
}

TEST(DynamicRange, FourDecadesGetALogRadiusAndEverySampleIsVisible) {
    // A synthetic slice whose values fall from 10 to 1e-3 1/sr (four decades) across theta_o.
    brdf::Dataset d;
    d.source = "decades.csv";
    for (int t = -80; t <= 80; t += 4) {
        brdf::Sample s;
        s.theta_i = 40 * kDeg;
        s.theta_o = std::abs(t) * kDeg;
        s.phi_o = t >= 0 ? brdf::kPi : 0;
        const double v = 10.0 * std::pow(10.0, -4.0 * (80 - t) / 160.0);
        s.value = brdf::Rgbd::Constant(v);
        d.samples.push_back(s);
    }
    PlotOptions o;  // automatic scale
    PolarLayout lay;
    auto img = plot_in_plane(d, nullptr, o, &lay);
    ASSERT_TRUE(img) << img.error().message;
    EXPECT_TRUE(lay.log_scale);
    ASSERT_FALSE(lay.ring_values.empty());
    EXPECT_LE(lay.ring_values.front(), 1e-2 * 1.0001);
    EXPECT_GE(lay.ring_values.back(), 10.0 * 0.9999);
    // The faintest sample (on the light's side, theta_o = -80) lies well away from the origin.
    double dist = 0;
    const double a = peak_angle_deg(*img, lay, lay.slice_colors[0], &dist);
    EXPECT_NEAR(a, 80.0, 3.0);  // brightest at +80
    // Marker pixels near -80 degrees at more than a tenth of the radius.
    std::size_t far_left = 0;
    for (int y = 0; y < img->height; ++y) {
        for (int x = 0; x < img->width; ++x) {
            if (color_distance(img->at(x, y), lay.slice_colors[0]) > 12) {
                continue;
            }
            const double dx = x + 0.5 - lay.origin_x;
            const double dy = lay.origin_y - (y + 0.5);
            const double r = std::hypot(dx, dy);
            const double ang = std::atan2(dx, dy) / kDeg;
            if (r <= lay.radius_px && dy >= 0 && ang < -70 && r > 0.1 * lay.radius_px) {
                ++far_left;
            }
        }
    }
    EXPECT_GT(far_left, 5u) << "the faint samples sit in the origin";
    // The same data on a forced linear scale: the faint side collapses onto the origin.
    o.scale = AxisScale::kLinear;
    PolarLayout lin;
    ASSERT_TRUE(plot_in_plane(d, nullptr, o, &lin));
    EXPECT_FALSE(lin.log_scale);
    // Less than a decade: automatic means linear.
    for (brdf::Sample& s : d.samples) {
        s.value = brdf::Rgbd::Constant(1.0 + 0.5 * std::cos(s.theta_o));
    }
    PolarLayout one;
    ASSERT_TRUE(plot_in_plane(d, nullptr, PlotOptions{}, &one));
    EXPECT_FALSE(one.log_scale);
}

TEST(DynamicRange, ResolveScaleSwitchesAboveOneDecade) {
    EXPECT_EQ(resolve_scale(AxisScale::kAuto, 1.0, 9.9), AxisScale::kLinear);
    EXPECT_EQ(resolve_scale(AxisScale::kAuto, 1.0, 10.5), AxisScale::kLog);
    EXPECT_EQ(resolve_scale(AxisScale::kLinear, 1e-4, 10), AxisScale::kLinear);
    EXPECT_EQ(resolve_scale(AxisScale::kLog, 1, 2), AxisScale::kLog);
}

TEST(ResidualMap, CellOfASampleSitsWhereTheHalfDiffAxesPutIt) {
    // One in-plane sample at theta_i = 42 deg, theta_o = 20 deg on the other side: theta_h = 11
    // deg, theta_d = 31 deg, the 5-degree cell [10, 15) x [30, 35). The map's axes are the
    // half/difference plane, 0..90 deg both ways, on a square of side min(W - 280, H - 130) px
    // from (90, 60): at 800 x 600 px, 470 px.
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd::Constant(0.2);
    const brdf::AnalyticBrdf fit(m);
    brdf::Dataset d;
    d.source = "one.csv";
    brdf::Sample s;
    s.theta_i = 42 * kDeg;
    s.phi_i = 0;
    s.theta_o = 20 * kDeg;
    s.phi_o = brdf::kPi;
    s.value = 2.0 * fit.eval(s.wi(), s.wo());  // data above the fit: a red cell
    d.samples.push_back(s);
    PlotOptions o;
    o.width = 800;
    auto img = plot_residual_map(d, fit, o);
    ASSERT_TRUE(img) << img.error().message;
    const double side = 470;
    int x_lo = img->width, x_hi = -1, y_lo = img->height, y_hi = -1;
    for (int y = 60; y < 60 + 470; ++y) {
        for (int x = 90; x < 90 + 470; ++x) {
            const Color c = img->at(x, y);
            if (c.r > c.b + 60) {
                x_lo = std::min(x_lo, x);
                x_hi = std::max(x_hi, x);
                y_lo = std::min(y_lo, y);
                y_hi = std::max(y_hi, y);
            }
        }
    }
    ASSERT_GE(x_hi, 0) << "no red cell inside the axes";
    // Grid lines may cover a cell's edge pixel.
    EXPECT_NEAR(x_lo, 90 + 10 / 90.0 * side, 2);
    EXPECT_NEAR(x_hi, 90 + 15 / 90.0 * side, 2);
    EXPECT_NEAR(y_lo, 60 + side - 35 / 90.0 * side, 2);
    EXPECT_NEAR(y_hi, 60 + side - 30 / 90.0 * side, 2);
}

TEST(CoverageCells, EachCellDrawnInTheColourOfItsFraction) {
    // A 2 x 2 (theta_h x theta_d) grid, theta_h-major: (0,0) full, (0,1) half, (1,0) empty,
    // (1,1) without a valid bin. theta_h cell edges are at (i/2)^2 90 deg: 0, 22.5, 90.
    CoverageCells c;
    c.n_theta_h = 2;
    c.n_theta_d = 2;
    c.n_phi_d = 4;
    c.fraction = {1.0, 0.5, 0.0, -1.0};
    c.measured_bins = 6;
    c.total_bins = 12;
    c.total_is_valid_bins = true;
    PlotOptions o;
    o.width = 640;
    auto img = plot_coverage_cells(c, {}, o, "cells");
    ASSERT_TRUE(img) << img.error().message;
    EXPECT_EQ(img->width, 640);
    // The axes: 400 px square from (90, 70), 0..90 deg on both axes, theta_d up.
    auto at = [&](double theta_h_deg, double theta_d_deg) {
        const int x = 90 + static_cast<int>(std::lround(theta_h_deg / 90 * 400));
        const int y = 70 + 400 - static_cast<int>(std::lround(theta_d_deg / 90 * 400));
        return img->at(x, y);
    };
    const Color empty = at(56, 22);    // cell (1, 0)
    const Color invalid = at(56, 67);  // cell (1, 1)
    EXPECT_EQ(empty, (Color{225, 225, 225}));
    EXPECT_EQ(invalid, (Color{150, 150, 150}));
    // Measured cells are coloured, the full one differently from the half one.
    const Color full = at(11, 22);
    const Color half = at(11, 67);
    EXPECT_NE(full, empty);
    EXPECT_NE(half, empty);
    EXPECT_NE(full, half);
    EXPECT_NE(full, invalid);
    // Cells that do not match the grid: an error, no picture.
    c.fraction.pop_back();
    auto bad = plot_coverage_cells(c, {}, o, "cells");
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("3 cells"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace gonio::report

namespace gonio::report {
namespace {

TEST(InPlanePlot, SamplesSpreadInThetaIAreComparedAtTheirOwnIncidentAngle) {
    // Samples as an image campaign gives them: every theta_i within +-2.4 deg of 30 deg, in the
    // plane of incidence, exactly the model's values. Each marker sits on the fit's curve once
    // moved to the slice by the fit; drawn at the slice's theta_i unmoved, markers near the
    // highlight sit far off it.
    const auto models = testing::every_model_type();
    const brdf::AnalyticBrdf truth(models[0].second);
    brdf::Dataset d;
    d.source = "image-campaign.csv";
    d.has_sigma = true;
    int k = 0;
    for (int t = -86; t <= 86; t += 2, ++k) {
        brdf::Sample s;
        s.theta_i = (30.0 + 2.4 * std::sin(1.7 * k)) * kDeg;
        s.phi_i = 0.0;
        s.theta_o = std::abs(t) * kDeg;
        s.phi_o = t >= 0 ? brdf::kPi : 0.0;
        s.value = truth.eval(s.wi(), s.wo());
        s.sigma = 0.01 * s.value;
        d.samples.push_back(s);
    }
    PlotOptions o;
    o.theta_i_deg = {30.0};
    PolarLayout lay;
    ASSERT_TRUE(plot_in_plane(d, &truth, o, &lay));
    EXPECT_GT(lay.moved_to_slice, 40u);
    EXPECT_LT(lay.worst_marker_misfit, 1e-9);
    // The misfit the unmoved markers would have: the model's own change over 2.4 deg of theta_i
    // at the highlight, well above the plot's resolution.
    double unmoved = 0;
    for (const brdf::Sample& s : d.samples) {
        const double a = s.phi_o == 0.0 ? -s.theta_o : s.theta_o;
        const brdf::Vec3d wi = brdf::spherical_to_cartesian(30.0 * kDeg, 0.0);
        const brdf::Vec3d wo = brdf::spherical_to_cartesian(std::abs(a), a >= 0 ? brdf::kPi : 0.0);
        unmoved = std::max(
            unmoved, std::abs(std::log10(luminance(s.value) / luminance(truth.eval(wi, wo)))));
    }
    EXPECT_GT(unmoved, 0.05);
}

}  // namespace
}  // namespace gonio::report
