// Every text a picture draws lies inside the picture: every plot kind, the sphere preview and the
// table coverage, drawn at the narrowest and the default width with long file names and labels,
// record each text's box (TextRecorder); none may reach past an edge. A text too long for its
// picture is drawn smaller or shortened in its middle, keeping its start and its end. A legend
// covers no axis or tick label, and no two ring labels of a polar plot overlap.

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/resample.h"
#include "gonio/report/plot.h"
#include "gonio/report/preview.h"
#include "test_models.h"

namespace gonio::report {
namespace {

using gonio::test_units::kDeg;

/// A file name far longer than any picture is wide.
const std::string kLongName =
    "campaigns/2026-12-06_0915_satin_rosaline_rgb_measured_on_the_second_rig_after_the_lamp_"
    "change_with_the_white_reference_remounted_and_the_detector_refocused_dataset_final.csv";

/// A dataset of the model over a grid of incidence and outgoing directions (in and out of the
/// plane), 2 % multiplicative noise with a seed.
brdf::Dataset grid_samples(const brdf::Brdf& b, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.02);
    brdf::Dataset d;
    d.source = kLongName;
    d.has_sigma = true;
    for (double ti : {10.0, 30.0, 50.0, 70.0}) {
        for (int to = 0; to <= 86; to += 4) {
            for (double dphi : {0.0, 45.0, 90.0, 135.0, 180.0}) {
                brdf::Sample s;
                s.theta_i = ti * kDeg;
                s.theta_o = to * kDeg;
                s.phi_o = dphi * kDeg;
                const brdf::Rgbd f = b.eval(s.wi(), s.wo());
                s.value = f * (1.0 + noise(rng));
                s.sigma = 0.02 * f;
                d.samples.push_back(s);
            }
        }
    }
    return d;
}

/// Fails for each recorded text whose box is not inside its picture; returns how many there were.
std::size_t expect_inside(const TextRecorder& rec, const std::string& what) {
    for (const DrawnText& t : rec.texts()) {
        const bool inside = t.x >= 0 && t.y >= 0 && t.x + t.width <= t.image_width &&
                            t.y + t.height <= t.image_height;
        EXPECT_TRUE(inside) << what << ": \"" << t.text << "\" at (" << t.x << ", " << t.y << ") "
                            << t.width << " x " << t.height << " on a " << t.image_width << " x "
                            << t.image_height << " picture";
    }
    return rec.texts().size();
}

TEST(PlotText, EveryTextOfEveryPictureLiesInsideItAtAnyNameLength) {
    const brdf::AnalyticBrdf fit(testing::every_model_type()[0].second);
    const brdf::Dataset data = grid_samples(fit, 20261206);
    brdf::TabulateOptions to;
    to.grid = brdf::TableGrid{30, 30, 60};
    to.threads = 2;
    const brdf::TabulatedBrdf table = brdf::tabulate(fit, to);
    CoverageCells cells;
    cells.n_theta_h = 30;
    cells.n_theta_d = 30;
    cells.n_phi_d = 60;
    for (int i = 0; i < 30 * 30; ++i) {
        cells.fraction.push_back(i % 7 == 0 ? -1.0 : (i % 10) / 10.0);
    }
    cells.measured_bins = 12345;
    cells.total_bins = 54000;
    const std::vector<TableHole> holes = {{10, 20, 30, 40, "shadowed by the sample holder"}};
    for (int width : {400, 800}) {
        SCOPED_TRACE("width " + std::to_string(width));
        PlotOptions o;
        o.width = width;
        TextRecorder rec;
        const auto check = [&](const char* what, const Expected<Image>& img) {
            ASSERT_TRUE(img) << what << ": " << img.error().message;
            for (const DrawnText& t : rec.texts()) {
                EXPECT_EQ(t.image_width, img->width) << what << ": " << t.text;
            }
            EXPECT_GT(expect_inside(rec, what), 3u) << what << ": too few texts recorded";
            rec.clear();
        };
        check("in-plane", plot_in_plane(data, &fit, o));
        check("half angle", plot_half_angle(data, &fit, o, "why: " + kLongName));
        check("delta phi", plot_delta_phi(data, &fit, o));
        check("residuals", plot_residual_map(data, fit, o));
        check("coverage", plot_coverage(data, o));
        check("table coverage", plot_table_coverage(table, holes, o, kLongName));
        check("coverage cells", plot_coverage_cells(cells, holes, o, kLongName));
        PreviewOptions po;
        po.size_px = 96;
        po.env_samples = 12;
        check("preview",
              preview_sheet(fit, "measured: " + kLongName, &fit, "fit: " + kLongName, po));
    }
}

TEST(PlotText, ALongTitleKeepsItsStartAndItsEnd) {
    const brdf::AnalyticBrdf fit(testing::every_model_type()[0].second);
    const brdf::Dataset data = grid_samples(fit, 7);
    PlotOptions o;
    o.width = 400;
    TextRecorder rec;
    ASSERT_TRUE(plot_in_plane(data, &fit, o));
    const DrawnText* title = nullptr;
    for (const DrawnText& t : rec.texts()) {
        if (t.asked.rfind("In-plane BRDF", 0) == 0) {
            title = &t;
        }
    }
    ASSERT_NE(title, nullptr);
    // Shortened in the middle: the plot's kind at the start, the file's extension at the end.
    EXPECT_NE(title->text, title->asked);
    EXPECT_EQ(title->text.rfind("In-plane BRDF", 0), 0u) << title->text;
    EXPECT_NE(title->text.find("..."), std::string::npos) << title->text;
    EXPECT_EQ(title->text.substr(title->text.size() - 4), ".csv") << title->text;
    EXPECT_LE(title->x + title->width, 400);
}

bool boxes_overlap(const DrawnText& a, const DrawnText& b) {
    return a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height &&
           b.y < a.y + a.height;
}

std::string box_of(const DrawnText& t) {
    return "\"" + t.text + "\" at (" + std::to_string(t.x) + ", " + std::to_string(t.y) + ") " +
           std::to_string(t.width) + " x " + std::to_string(t.height);
}

/// The pictures that draw a legend or rings, at the narrowest and the default width and every
/// BRDF axis scale; `check(what, texts)` sees each picture's recorded boxes.
template <class Check>
void for_each_labelled_picture(const Check& check) {
    const brdf::AnalyticBrdf fit(testing::every_model_type()[0].second);
    const brdf::Dataset data = grid_samples(fit, 20261207);
    CoverageCells cells;
    cells.n_theta_h = 30;
    cells.n_theta_d = 30;
    cells.n_phi_d = 60;
    for (int i = 0; i < 30 * 30; ++i) {
        cells.fraction.push_back(i % 7 == 0 ? -1.0 : (i % 10) / 10.0);
    }
    const std::vector<TableHole> holes = {{10, 20, 30, 40, "shadowed by the sample holder"}};
    for (int width : {400, 800}) {
        for (AxisScale scale : {AxisScale::kAuto, AxisScale::kLinear, AxisScale::kLog}) {
            PlotOptions o;
            o.width = width;
            o.scale = scale;
            const std::string at =
                " (width " + std::to_string(width) + ", " + axis_scale_name(scale) + ")";
            TextRecorder rec;
            const auto run = [&](const std::string& what, const Expected<Image>& img) {
                ASSERT_TRUE(img) << what << ": " << img.error().message;
                check(what + at, rec.texts());
                rec.clear();
            };
            run("in-plane", plot_in_plane(data, &fit, o));
            run("in-plane, fit only", plot_in_plane(brdf::Dataset{}, &fit, o));
            run("delta phi", plot_delta_phi(data, &fit, o));
            run("coverage", plot_coverage(data, o));
            run("coverage cells", plot_coverage_cells(cells, holes, o, "a table"));
        }
    }
}

TEST(PlotText, NoLegendCoversAnAxisOrTickLabel) {
    std::size_t frames = 0;
    for_each_labelled_picture([&](const std::string& what, const std::vector<DrawnText>& texts) {
        for (const DrawnText& legend : texts) {
            if (legend.role != TextRole::kLegendFrame) {
                continue;
            }
            ++frames;
            for (const DrawnText& t : texts) {
                if (t.role != TextRole::kAxisLabel && t.role != TextRole::kTickLabel) {
                    continue;
                }
                EXPECT_FALSE(boxes_overlap(legend, t))
                    << what << ": the legend's frame " << box_of(legend) << " covers " << box_of(t);
            }
        }
    });
    // Every picture above has a legend.
    EXPECT_EQ(frames, 2u * 3u * 5u);
}

TEST(PlotText, NoTwoRingLabelsOfAPolarPlotOverlap) {
    std::size_t pictures_with_rings = 0;
    for_each_labelled_picture([&](const std::string& what, const std::vector<DrawnText>& texts) {
        std::vector<const DrawnText*> rings;
        for (const DrawnText& t : texts) {
            if (t.role == TextRole::kRingLabel) {
                rings.push_back(&t);
            }
        }
        pictures_with_rings += rings.size() >= 2;
        for (std::size_t a = 0; a < rings.size(); ++a) {
            for (std::size_t b = a + 1; b < rings.size(); ++b) {
                EXPECT_FALSE(boxes_overlap(*rings[a], *rings[b]))
                    << what << ": ring labels " << box_of(*rings[a]) << " and " << box_of(*rings[b])
                    << " overlap";
            }
        }
    });
    // The in-plane plots (with and without data) and the coverage plot label their rings.
    EXPECT_EQ(pictures_with_rings, 2u * 3u * 3u);
}

}  // namespace
}  // namespace gonio::report
