// Scattered samples against the half angle, and the coverage map of a half/difference table.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "canvas.h"
#include "gonio/report/plot.h"
#include "image_cv.h"
#include "plot_common.h"

namespace gonio::report {

namespace {

constexpr double kDeg = brdf::kPi / 180.0;

}  // namespace

Expected<Image> plot_half_angle(const brdf::Dataset& data,
                                const brdf::Brdf* fit,
                                const PlotOptions& options,
                                const std::string& why) {
    if (data.samples.empty()) {
        return make_error(data.source + ": empty dataset: nothing to plot against theta_h");
    }
    struct Point {
        double theta_h_deg, theta_d_deg, y, fit_y;
    };
    std::vector<Point> pts;
    double vmax = 0;
    double vmin_pos = std::numeric_limits<double>::infinity();
    std::size_t zero = 0;
    for (const brdf::Sample& s : data.samples) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
        const double y = luminance(s.value);
        const double fy = fit != nullptr ? luminance(fit->eval(s.wi(), s.wo()))
                                         : std::numeric_limits<double>::quiet_NaN();
        pts.push_back({hd.theta_h / kDeg, hd.theta_d / kDeg, y, fy});
        if (y > 0 && std::isfinite(y)) {
            vmax = std::max(vmax, y);
            vmin_pos = std::min(vmin_pos, y);
        } else {
            ++zero;
        }
    }
    if (!(vmax > 0)) {
        return make_error(data.source + ": every sample is zero; nothing to plot against theta_h");
    }
    const bool log_scale = resolve_scale(options.scale, vmin_pos, vmax) == AxisScale::kLog;
    const int W = std::max(400, options.width);
    const int H = W * 3 / 5 + 60;
    char sub[320];
    std::snprintf(sub,
                  sizeof sub,
                  "%zu samples at their own directions%s; colour: theta_d [deg]; rings: %s%s",
                  pts.size() - zero,
                  zero ? " (zero values not shown)" : "",
                  fit ? "fit at the same directions" : "(no fit given)",
                  why.empty() ? "" : ("; " + why).c_str());
    cv::Mat img = draw::blank(
        W,
        H,
        "BRDF against the half angle (luminance Y) - " + plot_detail::short_name(data.source),
        sub);
    draw::Axes ax;
    ax.area = cv::Rect(90, 70, W - 90 - 130, H - 70 - 64);
    ax.x0 = 0;
    ax.x1 = 90;
    ax.log_y = log_scale;
    if (log_scale) {
        ax.y0 = plot_detail::log_floor(vmin_pos, vmax);
        ax.y1 = std::pow(10.0, std::ceil(std::log10(vmax) - 1e-9));
    } else {
        ax.y0 = 0;
        const std::vector<double> t = draw::nice_ticks(0, vmax, 6);
        ax.y1 = t.back() >= vmax ? t.back() : t.back() + (t.size() > 1 ? t[1] - t[0] : vmax);
    }
    ax.draw(img,
            "theta_h [deg] (half vector from the normal)",
            std::string("BRDF luminance Y [1/sr]") + (log_scale ? ", log10" : ""));
    for (const Point& p : pts) {
        if (fit != nullptr && std::isfinite(p.fit_y) && ax.inside_y(p.fit_y)) {
            cv::circle(img, ax.pt(p.theta_h_deg, p.fit_y), 4, draw::kAxis, 1, cv::LINE_AA);
        }
    }
    for (const Point& p : pts) {
        if (!(p.y > 0) || !ax.inside_y(p.y)) {
            continue;
        }
        draw::marker(img, ax.pt(p.theta_h_deg, p.y), draw::sequential(p.theta_d_deg / 90.0), 3);
    }
    draw::colour_bar(
        img,
        cv::Rect(ax.area.x + ax.area.width + 16, ax.area.y, 16, ax.area.height),
        0,
        90,
        [](double t) { return draw::sequential(t); },
        "theta_d [deg]");
    return from_mat(img);
}

Expected<Image> plot_coverage_cells(const CoverageCells& cells,
                                    const std::vector<TableHole>& holes,
                                    const PlotOptions& options,
                                    const std::string& title) {
    const std::size_t n_cells = static_cast<std::size_t>(std::max(cells.n_theta_h, 0)) *
                                static_cast<std::size_t>(std::max(cells.n_theta_d, 0));
    if (n_cells == 0 || cells.fraction.size() != n_cells) {
        return make_error(title + ": coverage of " + std::to_string(cells.fraction.size()) +
                          " cells for a " + std::to_string(cells.n_theta_h) + " x " +
                          std::to_string(cells.n_theta_d) +
                          " (theta_h x theta_d) grid: no coverage to plot");
    }
    const int W = std::max(400, options.width);
    const int side = std::min(W - 90 - 150, 560);
    // Below the axes: their labels, then the legend (one row per entry), all inside the picture.
    const bool has_invalid =
        std::any_of(cells.fraction.begin(), cells.fraction.end(), [](double f) { return f < 0; });
    const int legend_rows = 1 + (has_invalid ? 1 : 0) + (holes.empty() ? 0 : 1);
    const int H = 70 + side + 56 + std::max(60, 20 * legend_rows + 8 + 12);
    char sub[240];
    std::snprintf(sub,
                  sizeof sub,
                  "%zu of %zu %sbins measured (%.1f %%), grid %dx%dx%d; %zu hole%s outlined",
                  cells.measured_bins,
                  cells.total_bins,
                  cells.total_is_valid_bins ? "valid " : "",
                  cells.total_bins > 0 ? 100.0 * static_cast<double>(cells.measured_bins) /
                                             static_cast<double>(cells.total_bins)
                                       : 0.0,
                  cells.n_theta_h,
                  cells.n_theta_d,
                  cells.n_phi_d,
                  holes.size(),
                  holes.size() == 1 ? "" : "s");
    cv::Mat img = draw::blank(W, H, "Coverage of the table - " + title, sub);
    const draw::Axes ax = draw::half_diff_axes(cv::Rect(90, 70, side, side));
    const cv::Scalar empty_colour(225, 225, 225);
    const cv::Scalar invalid_colour(150, 150, 150);
    bool any_invalid = false;
    auto colour = [&](double t) {
        // Cells without a valid bin mid grey, empty cells light grey, then the sequential map.
        if (t < 0) {
            any_invalid = true;
            return invalid_colour;
        }
        return t <= 0 ? empty_colour : draw::sequential(std::min(t, 1.0));
    };
    // theta_h bins are uniform in sqrt(theta_h / (pi/2)): cell edges at ((i / n)^2) 90 deg.
    for (int ih = 0; ih < cells.n_theta_h; ++ih) {
        const double h0 = std::pow(static_cast<double>(ih) / cells.n_theta_h, 2) * 90;
        const double h1 = std::pow(static_cast<double>(ih + 1) / cells.n_theta_h, 2) * 90;
        for (int id = 0; id < cells.n_theta_d; ++id) {
            const double d0 = 90.0 * id / cells.n_theta_d;
            const double d1 = 90.0 * (id + 1) / cells.n_theta_d;
            const cv::Point a = ax.pt(h0, d1);
            const cv::Point b = ax.pt(h1, d0);
            cv::rectangle(
                img,
                cv::Rect(a, b),
                colour(cells.fraction[static_cast<std::size_t>(ih) * cells.n_theta_d + id]),
                cv::FILLED);
        }
    }
    const cv::Scalar hole_colour(40, 39, 214);  // red (BGR)
    for (const TableHole& h : holes) {
        const cv::Point a = ax.pt(h.theta_h_min_deg, h.theta_d_max_deg);
        const cv::Point b = ax.pt(h.theta_h_max_deg, h.theta_d_min_deg);
        cv::rectangle(img, cv::Rect(a, b), hole_colour, 1, cv::LINE_AA);
    }
    draw::draw_half_diff_axes(img, ax);
    draw::colour_bar(
        img,
        cv::Rect(ax.area.x + ax.area.width + 20, ax.area.y, 18, ax.area.height),
        0,
        1,
        [](double t) { return draw::sequential(t); },
        "fraction of phi_d bins measured");
    std::vector<draw::LegendEntry> entries = {{empty_colour, "no bin measured", false, true}};
    if (any_invalid) {
        entries.push_back(
            {invalid_colour, "no valid bin (beyond the table's domain)", false, true});
    }
    if (!holes.empty()) {
        entries.push_back({hole_colour, "hole: empty valid bins (dataset.json)", true, false});
    }
    draw::legend(img, entries, {ax.area.x, ax.area.y + ax.area.height + 56}, true);
    return from_mat(img);
}

Expected<Image> plot_table_coverage(const brdf::TabulatedBrdf& table,
                                    const std::vector<TableHole>& holes,
                                    const PlotOptions& options,
                                    const std::string& title) {
    const brdf::TableGrid& g = table.grid();
    if (g.size() == 0) {
        return make_error(title + ": empty table grid: no coverage to plot");
    }
    // Fraction of measured phi_d bins per (theta_h, theta_d) cell.
    CoverageCells cells;
    cells.n_theta_h = g.n_theta_h;
    cells.n_theta_d = g.n_theta_d;
    cells.n_phi_d = g.n_phi_d;
    cells.fraction.assign(static_cast<std::size_t>(g.n_theta_h) * g.n_theta_d, 0.0);
    for (int ih = 0; ih < g.n_theta_h; ++ih) {
        for (int id = 0; id < g.n_theta_d; ++id) {
            int n = 0;
            for (int ip = 0; ip < g.n_phi_d; ++ip) {
                n += table.bin_valid(g.index(ih, id, ip)) ? 1 : 0;
            }
            cells.measured_bins += static_cast<std::size_t>(n);
            cells.fraction[static_cast<std::size_t>(ih) * g.n_theta_d + id] =
                static_cast<double>(n) / g.n_phi_d;
        }
    }
    cells.total_bins = g.size();
    return plot_coverage_cells(cells, holes, options, title);
}

}  // namespace gonio::report
