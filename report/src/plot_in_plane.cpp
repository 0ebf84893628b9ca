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

/// Signed outgoing angle of a sample in the plane of incidence (radians; + forward, - back toward
/// the light), or NaN when wo lies farther than tol from that plane. The distance is the angle
/// between wo and the plane: asin(sin theta_o |sin(phi_o - phi_i)|).
double in_plane_angle(const brdf::Sample& s, double tol) {
    const double dphi = brdf::wrap_pi(s.phi_o - s.phi_i);
    const double off_plane =
        std::asin(std::min(1.0, std::sin(s.theta_o) * std::abs(std::sin(dphi))));
    if (off_plane > tol) {
        return std::numeric_limits<double>::quiet_NaN();
    }
    // cos(dphi) >= 0: on the light's side.
    return std::cos(dphi) >= 0 ? -s.theta_o : s.theta_o;
}

/// The fit's luminance in the plane of incidence at phi_i, theta_i_slice, in-plane angle `a`.
double on_slice(const brdf::Brdf& fit, double phi_i, double theta_i_slice, double a);

/// The factor that moves a sample measured at its own theta_i to a slice at theta_i_slice (same
/// in-plane angle `a`, same phi_i): the fit's luminance there over the fit's luminance at the
/// sample's own geometry. 1 when the sample is on the slice (within 0.01 deg) or when the fit
/// gives no positive finite ratio.
double on_slice(const brdf::Brdf& fit, double phi_i, double theta_i_slice, double a) {
    const brdf::Vec3d wi = brdf::spherical_to_cartesian(theta_i_slice, phi_i);
    const brdf::Vec3d wo =
        brdf::spherical_to_cartesian(std::abs(a), a >= 0 ? phi_i + brdf::kPi : phi_i);
    return luminance(fit.eval(wi, wo));
}

double to_slice(const brdf::Brdf& fit, const brdf::Sample& s, double theta_i_slice, double a) {
    if (std::abs(s.theta_i - theta_i_slice) < 0.01 * kDeg) {
        return 1.0;
    }
    const double own = luminance(fit.eval(s.wi(), s.wo()));
    const double k = on_slice(fit, s.phi_i, theta_i_slice, a) / own;
    return std::isfinite(k) && k > 0 ? k : 1.0;
}

/// Slices from the data: the theta_i of in-plane samples (degrees, sorted) grouped greedily into
/// windows of width 2 tol holding the most samples (at least 3), up to `max_slices`, in order of
/// theta_i; each slice at the median theta_i of its members.
std::vector<double> slices_from_data(std::vector<double> theta_i_deg,
                                     double tol_deg,
                                     std::size_t max_slices) {
    std::sort(theta_i_deg.begin(), theta_i_deg.end());
    std::vector<std::pair<std::size_t, std::size_t>> windows;  // [first, last) in theta_i_deg
    std::vector<bool> taken(theta_i_deg.size(), false);
    while (true) {
        std::size_t best_first = 0, best_count = 0;
        std::size_t j = 0;
        for (std::size_t i = 0; i < theta_i_deg.size(); ++i) {
            if (taken[i]) {
                continue;
            }
            j = std::max(j, i);
            while (j < theta_i_deg.size() && !taken[j] &&
                   theta_i_deg[j] - theta_i_deg[i] <= 2 * tol_deg) {
                ++j;
            }
            if (j - i > best_count) {
                best_count = j - i;
                best_first = i;
            }
            if (j == i) {
                j = i + 1;
            }
        }
        if (best_count < 3) {
            break;
        }
        windows.push_back({best_first, best_first + best_count});
        for (std::size_t k = best_first; k < best_first + best_count; ++k) {
            taken[k] = true;
        }
    }
    // Keep the fullest windows, spread evenly over theta_i.
    std::vector<std::pair<double, int>> found;
    for (const auto& w : windows) {
        found.push_back(
            {theta_i_deg[(w.first + w.second - 1) / 2], static_cast<int>(w.second - w.first)});
    }
    std::sort(found.begin(), found.end());
    return plot_detail::pick_evenly(found, max_slices);
}

/// The theta_i (degrees) of the samples within tol of the plane of incidence.
std::vector<double> in_plane_theta_i(const brdf::Dataset& data, double tol) {
    std::vector<double> theta_i_deg;
    for (const brdf::Sample& s : data.samples) {
        if (!std::isnan(in_plane_angle(s, tol))) {
            theta_i_deg.push_back(s.theta_i / kDeg);
        }
    }
    return theta_i_deg;
}

/// The slice nearest in theta_i (degrees) to ti.
double nearest_slice(const std::vector<double>& thetas, double ti) {
    double nearest = thetas.front();
    for (double t : thetas) {
        if (std::abs(t - ti) < std::abs(nearest - ti)) {
            nearest = t;
        }
    }
    return nearest;
}

/// What the slices hold together: samples moved to their slice's theta_i, the largest
/// |log10(marker / curve)| at a marker's angle, and the range of the values (the radius follows
/// the measured data, not the model out to 90 degrees).
struct SliceStats {
    std::size_t moved = 0;
    double worst_misfit = 0;
    double vmax = 0;
    double vmax_data = 0;
    double vmin_pos = std::numeric_limits<double>::infinity();
    double vmin_data = std::numeric_limits<double>::infinity();
};

/// The measured points of the slice at sl->theta_i_deg: each sample joins the slice nearest in
/// theta_i, when within the tolerance and near the plane of incidence; phi_i is their median.
void add_slice_points(const brdf::Dataset& data,
                      const brdf::Brdf* fit,
                      const std::vector<double>& thetas,
                      const PlotOptions& options,
                      Slice* sl,
                      SliceStats* st) {
    const double tol = options.angle_tolerance_deg * kDeg;
    const double t_deg = sl->theta_i_deg;
    std::vector<double> phis;
    for (const brdf::Sample& s : data.samples) {
        const double ti = s.theta_i / kDeg;
        if (nearest_slice(thetas, ti) != t_deg ||
            std::abs(ti - t_deg) > options.angle_tolerance_deg) {
            continue;
        }
        const double a = in_plane_angle(s, tol);
        if (std::isnan(a)) {
            continue;
        }
        // A sample measured at its own theta_i, off the slice's (an image campaign's pixels
        // spread over the tolerance): moved to the slice by the fit's ratio between the two
        // geometries, so that it is compared with the curve at its own incident angle.
        const double k = fit != nullptr ? to_slice(*fit, s, t_deg * kDeg, a) : 1.0;
        st->moved += k != 1.0;
        const double y = k * luminance(s.value);
        const double sy = k * luminance_sigma(s.sigma);
        if (fit != nullptr && y > 0) {
            const double c = on_slice(*fit, s.phi_i, t_deg * kDeg, a);
            if (c > 0 && std::isfinite(c)) {
                st->worst_misfit = std::max(st->worst_misfit, std::abs(std::log10(y / c)));
            }
        }
        sl->points.push_back({a, y, sy});
        phis.push_back(s.phi_i);
        st->vmax = std::max(st->vmax, y + sy);
        st->vmax_data = std::max(st->vmax_data, y + sy);
        if (y > 0) {
            st->vmin_pos = std::min(st->vmin_pos, y);
            st->vmin_data = std::min(st->vmin_data, y);
        }
    }
    if (!phis.empty()) {
        std::nth_element(phis.begin(), phis.begin() + phis.size() / 2, phis.end());
        sl->phi_i = phis[phis.size() / 2];
    }
}

/// The fit's luminance along the slice's plane of incidence at `angles`.
void add_slice_curve(const brdf::Brdf& fit,
                     const std::vector<double>& angles,
                     Slice* sl,
                     SliceStats* st) {
    const brdf::Vec3d wi = brdf::spherical_to_cartesian(sl->theta_i_deg * kDeg, sl->phi_i);
    for (double a : angles) {
        const double phi_o = a >= 0 ? sl->phi_i + brdf::kPi : sl->phi_i;
        const brdf::Vec3d wo = brdf::spherical_to_cartesian(std::abs(a), phi_o);
        const double y = luminance(fit.eval(wi, wo));
        sl->curve.push_back(y);
        if (std::isfinite(y)) {
            st->vmax = std::max(st->vmax, y);
            if (y > 0) {
                st->vmin_pos = std::min(st->vmin_pos, y);
            }
        }
    }
}

/// Which rings get their value written along the baseline: from the outer ring inward, each
/// whose label keeps 4 px from the label kept outside it (close log rings near the origin would
/// write over each other; the ring itself is drawn either way).
std::vector<bool> ring_labels_with_room(const plot_detail::RadialScale& rs, double scale) {
    std::vector<bool> keep(rs.ticks.size(), false);
    double left_of_kept = std::numeric_limits<double>::infinity();
    for (std::size_t k = rs.ticks.size(); k-- > 0;) {
        const double r = rs.radius(rs.ticks[k]);
        if (r < 2) {
            continue;
        }
        const double half = 0.5 * draw::text_width(draw::format_tick(rs.ticks[k]), scale);
        if (std::lround(r) + half + 4 <= left_of_kept) {
            keep[k] = true;
            left_of_kept = std::lround(r) - half;
        }
    }
    return keep;
}

/// The rings with their values along the baseline to the right of the origin, spokes every 15
/// degrees labelled outside the outer ring, the outer ring and the baseline, and the captions of
/// the radius and the angle below.
void draw_polar_grid(cv::Mat& img,
                     cv::Point origin,
                     int R,
                     const plot_detail::RadialScale& rs,
                     const std::string& radius_caption) {
    constexpr double kRingScale = 0.42;
    const std::vector<bool> labelled = ring_labels_with_room(rs, kRingScale);
    for (std::size_t k = 0; k < rs.ticks.size(); ++k) {
        const double v = rs.ticks[k];
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
        if (!labelled[k]) {
            continue;
        }
        draw::text(img,
                   draw::format_tick(v),
                   {origin.x + int(std::lround(r)), origin.y + 14},
                   kRingScale,
                   draw::kBlack,
                   draw::Align::kCenter,
                   1,
                   TextRole::kRingLabel);
    }
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
               radius_caption,
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
}

/// Where a value v at signed in-plane angle a lies on the polar plot.
struct PolarMap {
    cv::Point origin;
    const plot_detail::RadialScale& rs;
    cv::Point2d operator()(double a, double v) const {
        const double r = rs.radius(v);
        return cv::Point2d(origin.x + r * std::sin(a), origin.y - r * std::cos(a));
    }
};

/// A slice's light direction (a small triangle outside the ring at -theta_i), its curve (clipped
/// at the outer ring) and its markers with radial +-1 sigma bars.
void draw_polar_slice(cv::Mat& img,
                      const PolarMap& to_px,
                      const Slice& sl,
                      const std::vector<double>& angles,
                      const cv::Scalar& col) {
    {
        const double a = -sl.theta_i_deg * kDeg;
        const cv::Point2d tip = to_px(a, to_px.rs.max_value);
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
            pts.push_back(std::isfinite(v) ? to_px(angles[j], std::min(v, to_px.rs.max_value))
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
}

/// Every slice drawn in its series colour with its legend entry; the layout's slice colours,
/// slices and points drawn.
PolarLayout draw_polar_slices(cv::Mat& img,
                              const PolarMap& to_px,
                              const std::vector<Slice>& slices,
                              const std::vector<double>& angles,
                              std::vector<draw::LegendEntry>* entries) {
    PolarLayout out;
    for (std::size_t k = 0; k < slices.size(); ++k) {
        const Slice& sl = slices[k];
        const cv::Scalar col = draw::series_color(static_cast<int>(k));
        draw_polar_slice(img, to_px, sl, angles, col);
        char label[96];
        std::snprintf(
            label, sizeof label, "theta_i = %.1f deg (%zu pts)", sl.theta_i_deg, sl.points.size());
        entries->push_back({col, label, !sl.curve.empty(), !sl.points.empty()});
        const cv::Vec3b c(cv::saturate_cast<uchar>(col[0]),
                          cv::saturate_cast<uchar>(col[1]),
                          cv::saturate_cast<uchar>(col[2]));
        out.slice_colors.push_back({c[2], c[1], c[0]});
        out.theta_i_deg.push_back(sl.theta_i_deg);
        out.points_drawn += sl.points.size();
    }
    return out;
}

}  // namespace

Expected<Image> plot_in_plane(const brdf::Dataset& data,
                              const brdf::Brdf* fit,
                              const PlotOptions& options,
                              PolarLayout* layout) {
    const double tol = options.angle_tolerance_deg * kDeg;
    std::vector<double> thetas = options.theta_i_deg;
    if (thetas.empty()) {
        thetas = slices_from_data(in_plane_theta_i(data, tol), options.angle_tolerance_deg, 5);
        if (thetas.empty() && !data.samples.empty()) {
            // Scattered directions: no slice holds them, so show every sample against theta_h.
            char why[200];
            std::snprintf(why,
                          sizeof why,
                          "no in-plane slice: no 3 samples within %.3g deg of one theta_i and of "
                          "the plane of incidence",
                          options.angle_tolerance_deg);
            return plot_half_angle(data, fit, options, why);
        }
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
    SliceStats st;
    for (double t_deg : thetas) {
        Slice sl;
        sl.theta_i_deg = t_deg;
        add_slice_points(data, fit, thetas, options, &sl, &st);
        if (fit != nullptr) {
            add_slice_curve(*fit, angles, &sl, &st);
        }
        slices.push_back(std::move(sl));
    }
    if (!(st.vmax > 0)) {
        return make_error(data.source + ": in-plane slices hold only zero values; nothing to plot");
    }

    // Layout: a half disk, origin at the bottom centre.
    const int W = std::max(400, options.width);
    const int top = 80;
    const int R = (W - 160) / 2;
    // Below the baseline: ring values, two axis captions, then the legend (one row per slice).
    const int H = top + R + 96 + 20 * static_cast<int>(thetas.size()) + 8 + 8;
    const cv::Point origin(W / 2, top + R + 8);
    // The scale follows the measured values' dynamic range (the fit's alone when there is no data).
    const bool have_data = st.vmax_data > 0 && std::isfinite(st.vmin_data);
    const double range_lo = have_data ? st.vmin_data : st.vmin_pos;
    const double range_hi = have_data ? st.vmax_data : st.vmax;
    const bool log_scale = resolve_scale(options.scale, range_lo, range_hi) == AxisScale::kLog &&
                           std::isfinite(range_lo);
    char sub[240];
    std::snprintf(sub,
                  sizeof sub,
                  "markers: measured +-1 sigma at their own theta_o (slice tolerance %.3g deg%s); "
                  "curves: %s",
                  options.angle_tolerance_deg,
                  st.moved > 0 ? ", moved to the slice's theta_i by the fit" : "",
                  fit ? "fit" : "(no fit given)");
    cv::Mat img = draw::blank(
        W, H, "In-plane BRDF (luminance Y) - " + plot_detail::short_name(data.source), sub);
    // The fit's curve beyond the largest measured value is clipped at the outer ring.
    const plot_detail::RadialScale rs =
        plot_detail::RadialScale::make(range_lo, range_hi, log_scale, R);
    draw_polar_grid(img,
                    origin,
                    R,
                    rs,
                    "radius: BRDF luminance Y [1/sr], " +
                        plot_detail::scale_caption(log_scale, range_lo, range_hi));

    std::vector<draw::LegendEntry> entries;
    PolarLayout out = draw_polar_slices(img, PolarMap{origin, rs}, slices, angles, &entries);
    out.origin_x = origin.x;
    out.origin_y = origin.y;
    out.radius_px = R;
    out.log_scale = log_scale;
    out.ring_values = rs.ticks;
    const cv::Size ls = draw::legend_size(entries);
    draw::legend(img, entries, {origin.x - ls.width / 2, origin.y + 72}, true);
    draw::text(img, "triangles: light direction", {8, 62}, 0.45, draw::kAxis);
    out.moved_to_slice = st.moved;
    out.worst_marker_misfit = st.worst_misfit;
    if (layout != nullptr) {
        *layout = out;
    }
    return from_mat(img);
}

}  // namespace gonio::report
