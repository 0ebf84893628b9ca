// BRDF against the azimuth difference delta_phi at fixed (theta_i, theta_o).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "canvas.h"
#include "gonio/report/plot.h"
#include "image_cv.h"
#include "plot_common.h"

namespace gonio::report {

namespace {

constexpr double kDeg = brdf::kPi / 180.0;

struct AzPoint {
    double dphi_deg;
    double y;
    double sigma;
};

struct AzSlice {
    double theta_i_deg = 0, theta_o_deg = 0, phi_i = 0;
    std::vector<AzPoint> points;
    std::vector<double> curve;
};

/// Slices from the data: samples grouped by (theta_i, theta_o) rounded to the tolerance grid; the
/// (up to 4) groups measured at the most azimuths (at least 3, theta_o not 0), in key order, each
/// at its members' mean angles and median phi_i.
std::vector<AzSlice> slices_from_data(const brdf::Dataset& data, const PlotOptions& options) {
    const double q = std::max(options.angle_tolerance_deg, 0.1);
    std::map<std::pair<long, long>, std::vector<const brdf::Sample*>> groups;
    for (const brdf::Sample& s : data.samples) {
        groups[{std::lround(s.theta_i / kDeg / q), std::lround(s.theta_o / kDeg / q)}].push_back(
            &s);
    }
    struct Candidate {
        std::pair<long, long> key;
        std::size_t azimuths;
    };
    std::vector<Candidate> cands;
    for (const auto& [key, members] : groups) {
        std::set<long> az;
        for (const brdf::Sample* s : members) {
            az.insert(std::lround(std::abs(brdf::wrap_pi(s->phi_o - s->phi_i)) / kDeg));
        }
        if (az.size() >= 3 && key.second != 0) {
            cands.push_back({key, az.size()});
        }
    }
    std::stable_sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
        return a.azimuths > b.azimuths;
    });
    if (cands.size() > 4) {
        cands.resize(4);
    }
    std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
        return a.key < b.key;
    });
    std::vector<AzSlice> slices;
    for (const Candidate& c : cands) {
        AzSlice sl;
        const auto& members = groups[c.key];
        double ti = 0, to = 0;
        std::vector<double> phis;
        for (const brdf::Sample* s : members) {
            ti += s->theta_i;
            to += s->theta_o;
            phis.push_back(s->phi_i);
            sl.points.push_back({std::abs(brdf::wrap_pi(s->phi_o - s->phi_i)) / kDeg,
                                 luminance(s->value),
                                 luminance_sigma(s->sigma)});
        }
        sl.theta_i_deg = ti / members.size() / kDeg;
        sl.theta_o_deg = to / members.size() / kDeg;
        std::nth_element(phis.begin(), phis.begin() + phis.size() / 2, phis.end());
        sl.phi_i = phis[phis.size() / 2];
        slices.push_back(std::move(sl));
    }
    return slices;
}

/// The values the axis must hold: of everything drawn, and of the measured values alone.
struct AzRange {
    double vmax = 0;
    double vmin_pos = std::numeric_limits<double>::infinity();
    double data_max = 0;
    double data_min_pos = std::numeric_limits<double>::infinity();
};

/// The fit's curve of each slice over `grid` (delta_phi, degrees), and the range of the values.
AzRange add_curves(std::vector<AzSlice>& slices,
                   const brdf::Brdf* fit,
                   const std::vector<double>& grid) {
    AzRange r;
    for (const AzSlice& sl : slices) {
        for (const AzPoint& p : sl.points) {
            r.data_max = std::max(r.data_max, p.y);
            if (p.y > 0) {
                r.data_min_pos = std::min(r.data_min_pos, p.y);
            }
        }
    }
    auto track = [&](double v) {
        if (std::isfinite(v)) {
            r.vmax = std::max(r.vmax, v);
            if (v > 0) {
                r.vmin_pos = std::min(r.vmin_pos, v);
            }
        }
    };
    for (AzSlice& sl : slices) {
        for (const AzPoint& p : sl.points) {
            track(p.y + p.sigma);
            track(p.y);
        }
        if (fit != nullptr) {
            const brdf::Vec3d wi = brdf::spherical_to_cartesian(sl.theta_i_deg * kDeg, sl.phi_i);
            for (double d : grid) {
                const brdf::Vec3d wo =
                    brdf::spherical_to_cartesian(sl.theta_o_deg * kDeg, sl.phi_i + d * kDeg);
                sl.curve.push_back(luminance(fit->eval(wi, wo)));
                track(sl.curve.back());
            }
        }
    }
    return r;
}

/// delta_phi over [0, 180] along x; the BRDF up, from 0 (linear) or whole decades (log).
draw::Axes delta_phi_axes(int W, int H, bool log_scale, const AzRange& r) {
    draw::Axes ax;
    ax.area = cv::Rect(90, 60, W - 90 - 30, H - 60 - 60);
    ax.x0 = 0;
    ax.x1 = 180;
    ax.log_y = log_scale;
    if (ax.log_y) {
        ax.y0 = plot_detail::log_floor(r.vmin_pos, r.vmax);
        ax.y1 = std::pow(10.0, std::ceil(std::log10(r.vmax) - 1e-9));
    } else {
        ax.y0 = 0;
        const std::vector<double> t = draw::nice_ticks(0, r.vmax, 6);
        ax.y1 = t.back() >= r.vmax ? t.back() : t.back() + (t.size() > 1 ? t[1] - t[0] : r.vmax);
    }
    return ax;
}

/// A slice's curve and markers (with +-1 sigma bars); its legend entry.
draw::LegendEntry draw_slice(cv::Mat& img,
                             const draw::Axes& ax,
                             const AzSlice& sl,
                             const std::vector<double>& grid,
                             const cv::Scalar& col) {
    if (!sl.curve.empty()) {
        std::vector<cv::Point2d> pts;
        for (std::size_t j = 0; j < grid.size(); ++j) {
            const double v = sl.curve[j];
            if (std::isfinite(v) && ax.inside_y(v)) {
                pts.emplace_back(ax.px(grid[j]), ax.py(v));
            } else {
                pts.emplace_back(std::nan(""), std::nan(""));
            }
        }
        draw::polyline(img, pts, col, 2);
    }
    for (const AzPoint& p : sl.points) {
        if (!ax.inside_y(p.y)) {
            continue;
        }
        if (p.sigma > 0) {
            const double lo = std::max(p.y - p.sigma, ax.log_y ? ax.y0 : 0.0);
            cv::line(img,
                     ax.pt(p.dphi_deg, lo),
                     ax.pt(p.dphi_deg, std::min(p.y + p.sigma, ax.y1)),
                     col,
                     1,
                     cv::LINE_AA);
        }
        draw::marker(img, ax.pt(p.dphi_deg, p.y), col, 3);
    }
    char label[96];
    std::snprintf(label,
                  sizeof label,
                  "theta_i = %.1f, theta_o = %.1f deg (%zu pts)",
                  sl.theta_i_deg,
                  sl.theta_o_deg,
                  sl.points.size());
    return {col, label, !sl.curve.empty(), !sl.points.empty()};
}

}  // namespace

Expected<Image> plot_delta_phi(const brdf::Dataset& data,
                               const brdf::Brdf* fit,
                               const PlotOptions& options) {
    std::vector<AzSlice> slices = slices_from_data(data, options);
    if (slices.empty() && fit != nullptr) {
        for (double t : {20.0, 40.0, 60.0}) {
            AzSlice sl;
            sl.theta_i_deg = t;
            sl.theta_o_deg = t;
            slices.push_back(sl);
        }
    }
    if (slices.empty()) {
        return make_error(
            data.source +
            ": no delta_phi slice to plot (no (theta_i, theta_o) pair measured at 3 or "
            "more azimuths, and no fit)");
    }
    std::vector<double> grid;
    for (double d = 0; d <= 180.0 + 1e-9; d += 0.5) {
        grid.push_back(d);
    }
    const AzRange r = add_curves(slices, fit, grid);
    if (!(r.vmax > 0)) {
        return make_error(data.source +
                          ": delta_phi slices hold only zero values; nothing to plot");
    }
    const bool have_data = r.data_max > 0 && std::isfinite(r.data_min_pos);
    const double range_lo = have_data ? r.data_min_pos : r.vmin_pos;
    const double range_hi = have_data ? r.data_max : r.vmax;
    const bool log_scale = resolve_scale(options.scale, range_lo, range_hi) == AxisScale::kLog &&
                           std::isfinite(r.vmin_pos);
    const int W = std::max(400, options.width);
    const int H = W * 3 / 5 + 40;
    cv::Mat img = draw::blank(
        W,
        H,
        "BRDF against azimuth (luminance Y) - " + plot_detail::short_name(data.source),
        "markers: measured +-1 sigma; curves: " + std::string(fit ? "fit" : "(no fit given)"));
    const draw::Axes ax = delta_phi_axes(W, H, log_scale, r);
    ax.draw(img,
            "delta_phi = phi_o - phi_i [deg] (0: back toward the light, 180: forward)",
            std::string("BRDF luminance Y [1/sr]") + (log_scale ? ", log10" : ""));
    std::vector<draw::LegendEntry> entries;
    for (std::size_t k = 0; k < slices.size(); ++k) {
        entries.push_back(
            draw_slice(img, ax, slices[k], grid, draw::series_color(static_cast<int>(k))));
    }
    // Top left, inside the plot area: the forward (specular) peak sits at the right end.
    draw::legend(img, entries, {ax.area.x + 4, ax.area.y + 4}, true, ax.area.width - 8);
    return from_mat(img);
}

}  // namespace gonio::report
