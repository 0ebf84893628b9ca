// In-plane polar plot of measured samples and a fitted BRDF.

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

/// A measured point of a slice: signed outgoing angle (radians; + forward) and luminance.
struct SlicePoint {
    double theta_signed;
    double y;
    double sigma;
};

struct Slice {
    double theta_i_deg = 0;
    double phi_i = 0;
    std::vector<SlicePoint> points;
    std::vector<double> curve;  ///< fitted luminance at kCurveAngles
};

std::vector<double> curve_angles() {
    std::vector<double> a;
    for (double t = -89.5; t <= 89.5 + 1e-9; t += 0.25) {
        a.push_back(t * kDeg);
    }
    return a;
}

/// Signed outgoing angle of a sample relative to the plane of incidence, or NaN when wo is out of
/// the plane by more than tol.
double in_plane_angle(const brdf::Sample& s, double tol) {
    if (s.theta_o < tol) {
        // Near the normal the azimuth does not matter.
        return s.theta_o;
    }
    const double dphi = std::abs(brdf::wrap_pi(s.phi_o - s.phi_i));
    if (dphi < tol / std::max(std::sin(s.theta_o), 1e-3)) {
        return -s.theta_o;  // back toward the light
    }
    if (brdf::kPi - dphi < tol / std::max(std::sin(s.theta_o), 1e-3)) {
        return s.theta_o;  // forward, specular side
    }
    return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

Expected<Image> plot_in_plane(const brdf::Dataset& data,
                              const brdf::Brdf* fit,
                              const PlotOptions& options,
                              PolarLayout* layout) {
    const double tol = options.angle_tolerance_deg * kDeg;
    std::vector<double> thetas = options.theta_i_deg;
    if (thetas.empty()) {
        // Slices from the data: the distinct theta_i that have in-plane samples.
        std::vector<std::pair<double, int>> found;  // theta_i (deg), count
        for (const brdf::Sample& s : data.samples) {
            if (std::isnan(in_plane_angle(s, tol))) {
                continue;
            }
            const double t = s.theta_i / kDeg;
            auto it = std::find_if(found.begin(), found.end(), [&](const auto& f) {
                return std::abs(f.first - t) <= options.angle_tolerance_deg;
            });
            if (it == found.end()) {
                found.push_back({t, 1});
            } else {
                ++it->second;
            }
        }
        found.erase(
            std::remove_if(found.begin(), found.end(), [](const auto& f) { return f.second < 3; }),
            found.end());
        std::sort(found.begin(), found.end());
        thetas = plot_detail::pick_evenly(found, 5);
        if (thetas.empty() && fit != nullptr) {
            thetas = {0.0, 20.0, 40.0, 60.0};
        }
    }
    if (thetas.empty()) {
        return make_error(data.source +
                          ": no in-plane slice to plot (no theta_i with 3 or more samples in the "
                          "plane of incidence, and no fit)");
    }

    const std::vector<double> angles = curve_angles();
    std::vector<Slice> slices;
    double vmax = 0;
    double vmax_data = 0;  // the radius follows the measured data, not the model out to 90 degrees
    double vmin_pos = std::numeric_limits<double>::infinity();
    for (double t_deg : thetas) {
        Slice sl;
        sl.theta_i_deg = t_deg;
        std::vector<double> phis;
        for (const brdf::Sample& s : data.samples) {
            if (std::abs(s.theta_i / kDeg - t_deg) > options.angle_tolerance_deg) {
                continue;
            }
            const double a = in_plane_angle(s, tol);
            if (std::isnan(a)) {
                continue;
            }
            const double y = luminance(s.value);
            const double sy = luminance_sigma(s.sigma);
            sl.points.push_back({a, y, sy});
            phis.push_back(s.phi_i);
            vmax = std::max(vmax, y + sy);
            vmax_data = std::max(vmax_data, y + sy);
            if (y > 0) {
                vmin_pos = std::min(vmin_pos, y);
            }
        }
        if (!phis.empty()) {
            std::nth_element(phis.begin(), phis.begin() + phis.size() / 2, phis.end());
            sl.phi_i = phis[phis.size() / 2];
        }
        if (fit != nullptr) {
            const brdf::Vec3d wi = brdf::spherical_to_cartesian(t_deg * kDeg, sl.phi_i);
            for (double a : angles) {
                const double phi_o = a >= 0 ? sl.phi_i + brdf::kPi : sl.phi_i;
                const brdf::Vec3d wo = brdf::spherical_to_cartesian(std::abs(a), phi_o);
                const double y = luminance(fit->eval(wi, wo));
                sl.curve.push_back(y);
                if (std::isfinite(y)) {
                    vmax = std::max(vmax, y);
                    if (y > 0) {
                        vmin_pos = std::min(vmin_pos, y);
                    }
                }
            }
        }
        slices.push_back(std::move(sl));
    }
    if (!(vmax > 0)) {
        return make_error(data.source + ": in-plane slices hold only zero values; nothing to plot");
    }

    // Layout: a half disk, origin at the bottom centre.
    const int W = std::max(400, options.width);
    const int top = 80;
    const int R = (W - 160) / 2;
    // Below the baseline: ring values, two axis captions, then the legend (one row per slice).
    const int H = top + R + 96 + 20 * static_cast<int>(thetas.size()) + 8 + 8;
    const cv::Point origin(W / 2, top + R + 8);
    char sub[200];
    std::snprintf(sub,
                  sizeof sub,
                  "%s scale; markers: measured +-1 sigma; curves: %s",
                  options.log_scale ? "log" : "linear",
                  fit ? "fit" : "(no fit given)");
    cv::Mat img = draw::blank(
        W, H, "In-plane BRDF (luminance Y) - " + plot_detail::short_name(data.source), sub);

    // Radial scale.
    // The fit's curve beyond the largest measured value is clipped at the outer ring.
    plot_detail::RadialScale rs = plot_detail::RadialScale::make(
        vmin_pos, vmax_data > 0 ? vmax_data : vmax, options.log_scale, R);

    // Rings and their labels (along the baseline to the right of the origin).
    for (double v : rs.ticks) {
        const double r = rs.radius(v);
        if (r < 2) {
            continue;
        }
        cv::ellipse(img,
                    origin,
                    {int(std::lround(r)), int(std::lround(r))},
                    0,
                    180,
                    360,
                    draw::kGrid,
                    1,
                    cv::LINE_AA);
        draw::text(img,
                   draw::format_tick(v),
                   {origin.x + int(std::lround(r)), origin.y + 14},
                   0.42,
                   draw::kBlack,
                   draw::Align::kCenter);
    }
    // Angular spokes every 15 degrees, labelled outside the outer ring.
    for (int a = -90; a <= 90; a += 15) {
        const double s = std::sin(a * kDeg);
        const double c = std::cos(a * kDeg);
        const cv::Point end(origin.x + int(std::lround(R * s)), origin.y - int(std::lround(R * c)));
        cv::line(img, origin, end, draw::kGrid, 1, cv::LINE_AA);
        const cv::Point lab(origin.x + int(std::lround((R + 32) * s)),
                            origin.y - int(std::lround((R + 26) * c)));
        draw::text(img, std::to_string(a), lab, 0.45, draw::kBlack, draw::Align::kCenter);
    }
    cv::ellipse(img, origin, {R, R}, 0, 180, 360, draw::kAxis, 1, cv::LINE_AA);
    cv::line(img, {origin.x - R, origin.y}, {origin.x + R, origin.y}, draw::kAxis, 1);
    draw::text(img,
               "radius: BRDF luminance Y [1/sr]" + std::string(options.log_scale ? " (log)" : ""),
               {origin.x, origin.y + 36},
               draw::kTextScale,
               draw::kBlack,
               draw::Align::kCenter);
    draw::text(
        img,
        "angle: theta_o [deg] from the normal; + forward (specular side), - toward the light",
        {origin.x, origin.y + 58},
        draw::kTextScale,
        draw::kBlack,
        draw::Align::kCenter);

    std::vector<draw::LegendEntry> entries;
    PolarLayout out;
    out.origin_x = origin.x;
    out.origin_y = origin.y;
    out.radius_px = R;
    auto to_px = [&](double a, double v) {
        const double r = rs.radius(v);
        return cv::Point2d(origin.x + r * std::sin(a), origin.y - r * std::cos(a));
    };
    for (std::size_t k = 0; k < slices.size(); ++k) {
        const Slice& sl = slices[k];
        const cv::Scalar col = draw::series_color(static_cast<int>(k));
        // Light direction: a small triangle outside the ring at -theta_i.
        {
            const double a = -sl.theta_i_deg * kDeg;
            const cv::Point2d tip = to_px(a, rs.max_value);
            const cv::Point2d dir(std::sin(a), -std::cos(a));
            const cv::Point2d nrm(-dir.y, dir.x);
            std::vector<cv::Point> tri = {cv::Point(tip + dir * 4),
                                          cv::Point(tip + dir * 16 + nrm * 6),
                                          cv::Point(tip + dir * 16 - nrm * 6)};
            cv::fillConvexPoly(img, tri, col, cv::LINE_AA);
        }
        if (!sl.curve.empty()) {
            std::vector<cv::Point2d> pts;
            for (std::size_t j = 0; j < angles.size(); ++j) {
                const double v = sl.curve[j];
                pts.push_back(std::isfinite(v) ? to_px(angles[j], std::min(v, rs.max_value))
                                               : cv::Point2d(std::nan(""), std::nan("")));
            }
            draw::polyline(img, pts, col, 2);
        }
        for (const SlicePoint& p : sl.points) {
            const cv::Point2d lo = to_px(p.theta_signed, std::max(p.y - p.sigma, 0.0));
            const cv::Point2d hi = to_px(p.theta_signed, p.y + p.sigma);
            if (p.sigma > 0) {
                cv::line(img, cv::Point(lo), cv::Point(hi), col, 1, cv::LINE_AA);
            }
            draw::marker(img, cv::Point(to_px(p.theta_signed, p.y)), col, 3);
        }
        char label[96];
        std::snprintf(
            label, sizeof label, "theta_i = %.1f deg (%zu pts)", sl.theta_i_deg, sl.points.size());
        entries.push_back({col, label, !sl.curve.empty(), !sl.points.empty()});
        const cv::Vec3b c(cv::saturate_cast<uchar>(col[0]),
                          cv::saturate_cast<uchar>(col[1]),
                          cv::saturate_cast<uchar>(col[2]));
        out.slice_colors.push_back({c[2], c[1], c[0]});
        out.theta_i_deg.push_back(sl.theta_i_deg);
        out.points_drawn += sl.points.size();
    }
    const cv::Size ls = draw::legend_size(entries);
    draw::legend(img, entries, {origin.x - ls.width / 2, origin.y + 72}, true);
    draw::text(img, "triangles: light direction", {8, 62}, 0.45, draw::kAxis);
    if (layout != nullptr) {
        *layout = out;
    }
    return from_mat(img);
}

}  // namespace gonio::report
