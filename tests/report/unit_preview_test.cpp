// Sphere previews: the highlight lies where the geometry puts it, a Lambertian sphere is brightest
// where its normal faces the light, and the environment integral matches its closed form.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/resample.h"
#include "gonio/report/preview.h"
#include "test_models.h"

namespace gonio::report {
namespace {

/// Pixel (column, row) of the largest luminance.
std::pair<int, int> brightest(const RadianceImage& img) {
    double best = -1;
    std::pair<int, int> at{-1, -1};
    for (int y = 0; y < img.height; ++y) {
        for (int x = 0; x < img.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * img.width + x;
            const double v = luminance(img.pixels[i]);
            if (img.covered[i] && v > best) {
                best = v;
                at = {x, y};
            }
        }
    }
    return at;
}

/// The pixel whose centre sees the sphere normal n (orthographic view along -z, x right, y up).
std::pair<double, double> pixel_of_normal(const brdf::Vec3d& n, int size) {
    const SphereLayout lay = sphere_layout(size);
    return {lay.cx + n.x() * lay.radius - 0.5, lay.cy - n.y() * lay.radius - 0.5};
}

TEST(Preview, SpecularHighlightWhereTheHalfVectorMeetsTheNormal) {
    // Mirror-like lobes peak where the sphere normal equals h = normalize(l + v).
    PreviewOptions o;
    o.size_px = 128;
    const brdf::Vec3d l = o.light_dir.normalized();
    const brdf::Vec3d h = (l + brdf::Vec3d(0, 0, 1)).normalized();
    const auto [ex, ey] = pixel_of_normal(h, o.size_px);
    auto models = testing::every_model_type();
    std::vector<std::pair<std::string, std::unique_ptr<brdf::Brdf>>> brdfs;
    for (auto& [name, m] : models) {
        if (!m.lobes.empty()) {
            brdfs.push_back({name, brdf::make_analytic_brdf(m)});
        }
    }
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{90, 45, 90};
    to.threads = 2;
    brdfs.push_back({"table_of_ggx",
                     std::make_unique<brdf::TabulatedBrdf>(brdf::tabulate(*brdfs[0].second, to))});
    for (const auto& [name, b] : brdfs) {
        SCOPED_TRACE(name);
        const auto [x, y] = brightest(render_directional(*b, o));
        EXPECT_NEAR(x, ex, 2.0);
        EXPECT_NEAR(y, ey, 2.0);
    }
}

TEST(Preview, LambertianSphereBrightestWhereTheNormalFacesTheLight) {
    PreviewOptions o;
    o.size_px = 128;
    o.light_dir = brdf::Vec3d(0.3, -0.2, 0.9);
    const brdf::AnalyticBrdf b(testing::every_model_type().back().second);
    const RadianceImage img = render_directional(b, o);
    const auto [ex, ey] = pixel_of_normal(o.light_dir.normalized(), o.size_px);
    const auto [x, y] = brightest(img);
    // cos(theta_i) is flat at its maximum: allow a few pixels.
    EXPECT_NEAR(x, ex, 3.0);
    EXPECT_NEAR(y, ey, 3.0);
    // Radiance rho / pi * E * cos: with E = pi and cos = 1 at the peak, L = rho.
    const std::size_t i = static_cast<std::size_t>(y) * img.width + x;
    EXPECT_NEAR(img.pixels[i][0], 0.6, 0.01);
    EXPECT_NEAR(img.pixels[i][2], 0.4, 0.01);
}

TEST(Preview, EnvironmentOnLambertMatchesTheClosedForm) {
    // At the sphere centre n = +z. Sky: horizon h + (zenith - h) w_y for w_y >= 0, ground g below.
    // Over the hemisphere w_z > 0: integral of cos = pi (half for w_y > 0, half below) and
    // integral of w_y cos over w_y > 0 = 2/3, so L = rho / pi (h pi/2 + (zenith - h) 2/3 + g pi/2).
    PreviewOptions o;
    o.size_px = 32;
    o.env_samples = 1200;
    const double rho = 0.5;
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd::Constant(rho);
    const brdf::AnalyticBrdf b(m);
    const RadianceImage img = render_environment(b, o);
    const brdf::Rgbd h(0.9, 0.95, 1.0), z(0.25, 0.45, 0.9), g(0.22, 0.18, 0.14);
    const brdf::Rgbd expected =
        rho / brdf::kPi * (h * brdf::kPi / 2 + (z - h) * (2.0 / 3.0) + g * brdf::kPi / 2);
    // Average of the 2 x 2 pixels around the centre (their normals are symmetric about +z).
    brdf::Rgbd sum = brdf::Rgbd::Zero();
    for (int y = 15; y <= 16; ++y) {
        for (int x = 15; x <= 16; ++x) {
            sum += img.pixels[static_cast<std::size_t>(y) * img.width + x];
        }
    }
    const brdf::Rgbd got = sum / 4.0;
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(got[c], expected[c], 0.02 * expected[c]) << "channel " << c;
    }
}

TEST(Preview, EnvironmentSkyAboveGroundBelow) {
    PreviewOptions o;
    o.size_px = 64;
    o.env_samples = 96;
    const brdf::AnalyticBrdf b(testing::every_model_type().back().second);
    const RadianceImage img = render_environment(b, o);
    const auto [tx, ty] = pixel_of_normal(brdf::Vec3d(0, 0.9, std::sqrt(0.19)), o.size_px);
    const auto [bx, by] = pixel_of_normal(brdf::Vec3d(0, -0.9, std::sqrt(0.19)), o.size_px);
    const brdf::Rgbd top =
        img.pixels[static_cast<std::size_t>(std::lround(ty)) * 64 + std::lround(tx)];
    const brdf::Rgbd bottom =
        img.pixels[static_cast<std::size_t>(std::lround(by)) * 64 + std::lround(bx)];
    // Albedo (0.6, 0.5, 0.4): the upward normal sees mostly blue sky, the downward mostly ground.
    EXPECT_GT(luminance(top), 2 * luminance(bottom));
    EXPECT_GT(top[2] / top[0], bottom[2] / bottom[0]);
}

TEST(Preview, SheetHasTwoLabelledRowsForAComparison) {
    PreviewOptions o;
    o.size_px = 48;
    o.env_samples = 12;
    const auto models = testing::every_model_type();
    const brdf::AnalyticBrdf a(models[0].second);
    const brdf::AnalyticBrdf b(models[1].second);
    auto one = preview_sheet(a, "a", nullptr, "", o);
    auto two = preview_sheet(a, "a", &b, "b", o);
    ASSERT_TRUE(one) << one.error().message;
    ASSERT_TRUE(two) << two.error().message;
    EXPECT_EQ(one->width, two->width);
    EXPECT_GT(two->height, one->height + o.size_px);
    o.size_px = 4;
    EXPECT_FALSE(preview_sheet(a, "a", nullptr, "", o));
}

}  // namespace
}  // namespace gonio::report

namespace gonio::report {
namespace {

/// A table of a model with the bins of its lower third of theta_h (the highlight) not measured.
brdf::TabulatedBrdf table_with_a_hole(bool hole) {
    const brdf::AnalyticBrdf truth(testing::every_model_type()[0].second);
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{30, 30, 60};
    to.threads = 2;
    brdf::TabulatedBrdf t = brdf::tabulate(truth, to);
    if (hole) {
        const brdf::TableGrid& g = t.grid();
        for (int ih = 0; ih < g.n_theta_h / 3; ++ih) {
            for (int id = 0; id < g.n_theta_d; ++id) {
                for (int ip = 0; ip < g.n_phi_d; ++ip) {
                    t.set_bin_invalid(g.index(ih, id, ip));
                }
            }
        }
    }
    return t;
}

TEST(Preview, TableHolesAreShownAsHolesNotAsBlackReflectance) {
    PreviewOptions o;
    o.size_px = 64;
    o.env_samples = 24;
    const brdf::TabulatedBrdf holed = table_with_a_hole(true);
    for (const RadianceImage& r : {render_directional(holed, o), render_environment(holed, o)}) {
        ASSERT_EQ(r.hole.size(), r.pixels.size());
        std::size_t holes = 0;
        for (std::size_t i = 0; i < r.pixels.size(); ++i) {
            if (r.hole[i]) {
                EXPECT_TRUE(r.covered[i]);
                ++holes;
            }
        }
        EXPECT_GT(holes, 10u);
        // Tone mapped, every hole has the hole colour and no other pixel has it.
        const Image img = tone_map(r, 1.0, Color{48, 48, 48});
        for (std::size_t i = 0; i < r.pixels.size(); ++i) {
            const Color c{img.rgb[3 * i], img.rgb[3 * i + 1], img.rgb[3 * i + 2]};
            EXPECT_EQ(c == kHoleColor, static_cast<bool>(r.hole[i])) << "pixel " << i;
        }
    }
    // The directional picture: the highlight (theta_h near 0) is where the hole is, at the pixel
    // whose normal is the half vector of the light and the viewer.
    const RadianceImage d = render_directional(holed, o);
    const brdf::Vec3d h = (o.light_dir.normalized() + brdf::Vec3d(0, 0, 1)).normalized();
    const SphereLayout lay = sphere_layout(o.size_px);
    const int px = static_cast<int>(lay.cx + h.x() * lay.radius);
    const int py = static_cast<int>(lay.cy - h.y() * lay.radius);
    EXPECT_TRUE(d.hole[static_cast<std::size_t>(py) * o.size_px + px]);
    // A whole tabulation leaves only the bins whose centre is no reflection unmeasured: a few
    // pixels at the rim, where the camera or the light grazes; a model has no hole.
    const auto count = [](const RadianceImage& r) {
        return static_cast<std::size_t>(std::count(r.hole.begin(), r.hole.end(), true));
    };
    const std::size_t full = count(render_directional(table_with_a_hole(false), o));
    const std::size_t holed_count = count(d);
    std::printf("hole pixels: %zu of the holed table, %zu of the whole one\n", holed_count, full);
    EXPECT_LT(5 * full, holed_count);
    const brdf::AnalyticBrdf model(testing::every_model_type()[0].second);
    EXPECT_TRUE(render_environment(model, o).hole.empty());
    // The sheet says what the colour means.
    auto sheet = preview_sheet(holed, "measured", nullptr, "", o);
    ASSERT_TRUE(sheet);
    std::size_t magenta = 0;
    for (std::size_t i = 0; i + 2 < sheet->rgb.size(); i += 3) {
        magenta += Color{sheet->rgb[i], sheet->rgb[i + 1], sheet->rgb[i + 2]} == kHoleColor;
    }
    EXPECT_GT(magenta, 20u);
}

}  // namespace
}  // namespace gonio::report
