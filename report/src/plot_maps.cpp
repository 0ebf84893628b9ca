// Residual map over (theta_h, theta_d) and coverage of the angular domain.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "canvas.h"
#include "gonio/report/plot.h"
#include "image_cv.h"
#include "plot_common.h"

namespace gonio::report {

namespace {

constexpr double kDeg = brdf::kPi / 180.0;

}  // namespace

Expected<Image> plot_residual_map(const brdf::Dataset& data,
                                  const brdf::Brdf& fit,
                                  const PlotOptions& options) {
    if (data.samples.empty()) {
        return make_error(data.source + ": empty dataset: no residual to map");
    }
    constexpr int kBins = 18;  // 5-degree bins over [0, 90] degrees
    std::vector<double> sum(kBins * kBins, 0.0);
    std::vector<int> count(kBins * kBins, 0);
    std::size_t skipped = 0;
    double sum_sq = 0;
    std::size_t used = 0;
    for (const brdf::Sample& s : data.samples) {
        const double measured = luminance(s.value);
        const double model = luminance(fit.eval(s.wi(), s.wo()));
        if (!(measured > 0) || !(model > 0) || !std::isfinite(model)) {
            // log residual undefined: counted and skipped.
            ++skipped;
            continue;
        }
        const double r = std::log10(measured / model);
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
        const int ih = std::clamp(static_cast<int>(hd.theta_h / kDeg / 5.0), 0, kBins - 1);
        const int id = std::clamp(static_cast<int>(hd.theta_d / kDeg / 5.0), 0, kBins - 1);
        sum[id * kBins + ih] += r;
        ++count[id * kBins + ih];
        sum_sq += r * r;
        ++used;
    }
    std::vector<double> cell_abs;
    for (int i = 0; i < kBins * kBins; ++i) {
        if (count[i] > 0) {
            cell_abs.push_back(std::abs(sum[i] / count[i]));
        }
    }
    double range = 0.05;
    if (!cell_abs.empty()) {
        std::sort(cell_abs.begin(), cell_abs.end());
        const double p95 = cell_abs[std::min(cell_abs.size() - 1, cell_abs.size() * 95 / 100)];
        for (double r : {0.05, 0.1, 0.2, 0.5, 1.0, 2.0}) {
            range = r;
            if (p95 <= r) {
                break;
            }
        }
    }

    const int W = std::max(400, options.width);
    const int H = W * 3 / 4;
    char sub[240];
    std::snprintf(sub,
                  sizeof sub,
                  "%zu samples; rms over samples of log10(Y_meas / Y_fit) = %.3g (luminance); %zu "
                  "skipped (zero value); grey: no sample",
                  used,
                  used ? std::sqrt(sum_sq / used) : 0.0,
                  skipped);
    cv::Mat img = draw::blank(W,
                              H,
                              "Residuals: log10(measured / fit) luminance per 5-deg bin - " +
                                  plot_detail::short_name(data.source),
                              sub);
    const int side = std::min(W - 90 - 190, H - 60 - 70);
    const draw::Axes ax = draw::half_diff_axes(cv::Rect(90, 60, side, side));
    for (int id = 0; id < kBins; ++id) {
        for (int ih = 0; ih < kBins; ++ih) {
            const int i = id * kBins + ih;
            const cv::Point a = ax.pt(ih * 5.0, (id + 1) * 5.0);
            const cv::Point b = ax.pt((ih + 1) * 5.0, id * 5.0);
            const cv::Scalar c = count[i] > 0 ? draw::diverging(sum[i] / count[i] / range)
                                              : cv::Scalar(200, 200, 200);
            cv::rectangle(img, cv::Rect(a, b), c, cv::FILLED);
        }
    }
    draw::draw_half_diff_axes(img, ax);
    draw::colour_bar(
        img,
        cv::Rect(ax.area.x + ax.area.width + 24, ax.area.y, 22, ax.area.height),
        -range,
        range,
        [](double t) { return draw::diverging(2 * t - 1); },
        "log10(measured / fit); red: data above fit",
        6);
    return from_mat(img);
}

Expected<Image> plot_coverage(const brdf::Dataset& data, const PlotOptions& options) {
    if (data.samples.empty()) {
        return make_error(data.source + ": empty dataset: no coverage to plot");
    }
    const int W = std::max(400, options.width);
    // Left third and a bit: the projected hemisphere; right: (theta_h, theta_d); far right: the
    // colour bar of theta_i.
    const int R = std::max(60, (W * 3) / 16);
    const int top = 64;
    const int H = top + 2 * R + 110;
    char sub[160];
    std::snprintf(
        sub, sizeof sub, "%zu samples; colour: theta_i [deg] (bar at right)", data.samples.size());
    cv::Mat img = draw::blank(
        W, H, "Coverage of the angular domain - " + plot_detail::short_name(data.source), sub);
    auto colour_of = [](double theta_i) { return draw::sequential(theta_i / (brdf::kPi / 2)); };

    // Left: outgoing directions seen from above the sample. The rings' labels sit at 45 degrees
    // off the horizontal, the 60 deg ring's below it: the 60 and 90 deg rings are only
    // R (1 - sin 60 deg) = 0.13 R apart, less than a label's height on a narrow picture.
    const cv::Point c(W / 20 + R, top + R);
    for (int t : {30, 60, 90}) {
        const int r = static_cast<int>(std::lround(R * std::sin(t * kDeg)));
        const int off = static_cast<int>(std::lround(r * 0.707));
        cv::circle(img, c, r, t == 90 ? draw::kAxis : draw::kGrid, 1, cv::LINE_AA);
        draw::text(img,
                   std::to_string(t) + " deg",
                   {c.x + off + 4, t == 60 ? c.y + off + 6 : c.y - off - 6},
                   0.5,
                   draw::kAxis,
                   draw::Align::kLeft,
                   1,
                   TextRole::kRingLabel);
    }
    cv::line(img, {c.x - R, c.y}, {c.x + R, c.y}, draw::kGrid, 1);
    cv::line(img, {c.x, c.y - R}, {c.x, c.y + R}, draw::kGrid, 1);
    for (const brdf::Sample& s : data.samples) {
        const double r = R * std::sin(s.theta_o);
        const cv::Point p(c.x + int(std::lround(r * std::cos(s.phi_o))),
                          c.y - int(std::lround(r * std::sin(s.phi_o))));
        cv::circle(img, p, 3, colour_of(s.theta_i), cv::FILLED, cv::LINE_AA);
    }
    draw::text(img,
               "outgoing directions seen from above",
               {c.x, c.y + R + 22},
               0.45,
               draw::kBlack,
               draw::Align::kCenter);
    draw::text(img,
               "rings: theta_o [deg]; phi_o = 0 to the right",
               {c.x, c.y + R + 42},
               0.45,
               draw::kBlack,
               draw::Align::kCenter);

    // Right: (theta_h, theta_d).
    const int ax_x = c.x + R + 110;
    const draw::Axes ax =
        draw::half_diff_axes(cv::Rect(ax_x, top, std::max(80, W - ax_x - 110), 2 * R));
    draw::draw_half_diff_axes(img, ax, true);
    for (const brdf::Sample& s : data.samples) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
        cv::circle(img,
                   ax.pt(hd.theta_h / kDeg, hd.theta_d / kDeg),
                   3,
                   colour_of(s.theta_i),
                   cv::FILLED,
                   cv::LINE_AA);
    }
    const cv::Rect bar(W - 56, top, 16, 2 * R);
    draw::colour_bar(
        img, bar, 0, 90, [](double t) { return draw::sequential(t); }, "", 6);
    draw::text(
        img, "theta_i [deg]", {bar.x + 8, top - 12}, 0.5, draw::kBlack, draw::Align::kCenter);
    draw::legend(img,
                 {{draw::sequential(0.5), "one measured (wi, wo) pair", false, true}},
                 {ax.area.x, ax.area.y + ax.area.height + 56},
                 true);
    return from_mat(img);
}

}  // namespace gonio::report
