#include "canvas.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "gonio/report/plot.h"

namespace gonio::report::draw {

cv::Scalar series_color(int i) {
    // BGR; chosen to stay distinct from each other and from the grey grid.
    static const cv::Scalar kPalette[] = {
        {180, 119, 31},   // blue
        {14, 127, 255},   // orange
        {44, 160, 44},    // green
        {40, 39, 214},    // red
        {189, 103, 148},  // purple
        {75, 86, 140},    // brown
        {194, 119, 227},  // pink
        {34, 189, 188},   // olive
    };
    const int n = static_cast<int>(sizeof(kPalette) / sizeof(kPalette[0]));
    return kPalette[((i % n) + n) % n];
}

int text_width(const std::string& s, double scale, int thickness) {
    int baseline = 0;
    return cv::getTextSize(s, kFont, scale, thickness, &baseline).width;
}

namespace {

thread_local std::vector<DrawnText>* t_recorded = nullptr;

/// Pixels kept free between a text and the picture's edge.
constexpr int kEdge = 2;
/// The smallest scale a text is shrunk to before it is shortened.
constexpr double kMinScale = 0.38;

struct FittedText {
    std::string text;
    double scale = kTextScale;
    cv::Size size;
    int baseline = 0;
};

/// `s` at `scale`, or smaller, or shortened in its middle, so that it is at most `room` pixels
/// long.
FittedText fit_text(const std::string& s, double scale, int thickness, int room) {
    FittedText f{s, scale, {}, 0};
    f.size = cv::getTextSize(f.text, kFont, f.scale, thickness, &f.baseline);
    while (f.size.width > room && f.scale > kMinScale) {
        f.scale = std::max(kMinScale, f.scale * 0.92);
        f.size = cv::getTextSize(f.text, kFont, f.scale, thickness, &f.baseline);
    }
    // Still too long: keep its start and its end (a file name's extension) around "...".
    for (std::size_t keep = s.size(); f.size.width > room && keep > 2;) {
        keep = keep * 9 / 10;
        const std::size_t head = (keep + 1) / 2;
        const std::size_t tail = keep - head;
        f.text = s.substr(0, head) + "..." + s.substr(s.size() - tail);
        f.size = cv::getTextSize(f.text, kFont, f.scale, thickness, &f.baseline);
    }
    return f;
}

void record(const cv::Mat& img,
            const std::string& drawn,
            const std::string& asked,
            cv::Rect box,
            bool vertical,
            TextRole role) {
    if (t_recorded != nullptr) {
        t_recorded->push_back({drawn,
                               asked,
                               box.x,
                               box.y,
                               box.width,
                               box.height,
                               img.cols,
                               img.rows,
                               vertical,
                               role});
    }
}

}  // namespace

namespace {

/// draw::text with the text at most `room` pixels long.
void text_within(cv::Mat& img,
                 const std::string& s,
                 cv::Point org,
                 double scale,
                 cv::Scalar color,
                 Align align,
                 int thickness,
                 TextRole role,
                 int room) {
    const FittedText f = fit_text(s, scale, thickness, room);
    int x = org.x;
    if (align == Align::kCenter) {
        x -= f.size.width / 2;
    } else if (align == Align::kRight) {
        x -= f.size.width;
    }
    // Inside the picture: moved in from an edge rather than cut by it.
    x = std::clamp(x, kEdge, std::max(kEdge, img.cols - kEdge - f.size.width));
    int y = org.y + f.size.height / 2;
    y = std::clamp(
        y, f.size.height + kEdge, std::max(f.size.height + kEdge, img.rows - kEdge - f.baseline));
    cv::putText(img, f.text, {x, y}, kFont, f.scale, color, thickness, cv::LINE_AA);
    record(img,
           f.text,
           s,
           cv::Rect(x, y - f.size.height, f.size.width, f.size.height + f.baseline),
           false,
           role);
}

}  // namespace

void text(cv::Mat& img,
          const std::string& s,
          cv::Point org,
          double scale,
          cv::Scalar color,
          Align align,
          int thickness,
          TextRole role) {
    text_within(img, s, org, scale, color, align, thickness, role, img.cols - 2 * kEdge);
}

void text_vertical(cv::Mat& img, const std::string& s, cv::Point org, double scale, TextRole role) {
    const FittedText f = fit_text(s, scale, 1, img.rows - 2 * kEdge - 4);
    cv::Mat tmp(f.size.height + f.baseline + 4, f.size.width + 4, CV_8UC3, kWhite);
    cv::putText(tmp, f.text, {2, f.size.height + 2}, kFont, f.scale, kBlack, 1, cv::LINE_AA);
    cv::Mat rot;
    cv::rotate(tmp, rot, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int x = std::clamp(
        org.x - rot.cols / 2, kEdge - 2, std::max(kEdge - 2, img.cols - kEdge + 2 - rot.cols));
    const int y = std::clamp(
        org.y - rot.rows / 2, kEdge - 2, std::max(kEdge - 2, img.rows - kEdge + 2 - rot.rows));
    const cv::Rect dst = cv::Rect(x, y, rot.cols, rot.rows) & cv::Rect(0, 0, img.cols, img.rows);
    if (dst.area() <= 0) {
        return;
    }
    rot(cv::Rect(dst.x - x, dst.y - y, dst.width, dst.height)).copyTo(img(dst));
    // The glyphs' box: the rotated picture without its 2-px white margin.
    record(img, f.text, s, cv::Rect(x + 2, y + 2, rot.cols - 4, rot.rows - 4), true, role);
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
    std::vector<double> ticks;
    if (!(hi > lo) || target < 1) {
        // Degenerate range: a single tick at lo.
        ticks.push_back(lo);
        return ticks;
    }
    const double raw = (hi - lo) / target;
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    double step = mag;
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
        if (m * mag >= raw) {
            step = m * mag;
            break;
        }
    }
    const double first = std::ceil(lo / step - 1e-9) * step;
    for (double v = first; v <= hi + step * 1e-9; v += step) {
        ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
    }
    return ticks;
}

std::string format_tick(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

double Axes::px(double x) const {
    return area.x + (x - x0) / (x1 - x0) * area.width;
}

double Axes::py(double y) const {
    double t = 0;
    if (log_y) {
        if (!(y > 0)) {
            // Zero or negative values have no place on a log axis: below the bottom edge.
            return area.y + area.height + 1e6;
        }
        t = (std::log10(y) - std::log10(y0)) / (std::log10(y1) - std::log10(y0));
    } else {
        t = (y - y0) / (y1 - y0);
    }
    return area.y + area.height - t * area.height;
}

bool Axes::inside_y(double y) const {
    const double p = py(y);
    return p >= area.y - 0.5 && p <= area.y + area.height + 0.5;
}

void Axes::draw(cv::Mat& img, const std::string& x_label, const std::string& y_label) const {
    // Grid and ticks.
    for (double x : nice_ticks(x0, x1, 8)) {
        const int p = static_cast<int>(std::lround(px(x)));
        cv::line(img, {p, area.y}, {p, area.y + area.height}, kGrid, 1);
        cv::line(img, {p, area.y + area.height}, {p, area.y + area.height + 5}, kAxis, 1);
        text(img,
             format_tick(x),
             {p, area.y + area.height + 16},
             kTextScale,
             kBlack,
             Align::kCenter,
             1,
             TextRole::kTickLabel);
    }
    std::vector<double> yt;
    if (log_y) {
        const int d0 = static_cast<int>(std::floor(std::log10(y0) + 1e-9));
        const int d1 = static_cast<int>(std::ceil(std::log10(y1) - 1e-9));
        for (int d = d0; d <= d1; ++d) {
            for (double m : {1.0, 2.0, 5.0}) {
                const double v = m * std::pow(10.0, d);
                if (v >= y0 * (1 - 1e-9) && v <= y1 * (1 + 1e-9) && (m == 1.0 || d1 - d0 <= 3)) {
                    yt.push_back(v);
                }
            }
        }
        if (yt.size() < 2) {
            yt = nice_ticks(y0, y1, 5);
        }
    } else {
        yt = nice_ticks(y0, y1, 6);
    }
    for (double y : yt) {
        const int p = static_cast<int>(std::lround(py(y)));
        if (p < area.y - 1 || p > area.y + area.height + 1) {
            continue;
        }
        cv::line(img, {area.x, p}, {area.x + area.width, p}, kGrid, 1);
        cv::line(img, {area.x - 5, p}, {area.x, p}, kAxis, 1);
        text(img,
             format_tick(y),
             {area.x - 8, p},
             kTextScale,
             kBlack,
             Align::kRight,
             1,
             TextRole::kTickLabel);
    }
    cv::rectangle(img, area, kAxis, 1);
    text(img,
         x_label,
         {area.x + area.width / 2, area.y + area.height + 38},
         kTextScale,
         kBlack,
         Align::kCenter,
         1,
         TextRole::kAxisLabel);
    text_vertical(img,
                  y_label,
                  {std::max(12, area.x - 62), area.y + area.height / 2},
                  kTextScale,
                  TextRole::kAxisLabel);
}

void marker(cv::Mat& img, cv::Point p, cv::Scalar color, int radius) {
    cv::circle(img, p, radius, color, cv::FILLED, cv::LINE_AA);
    cv::circle(img, p, radius, kAxis, 1, cv::LINE_AA);
}

cv::Size legend_size(const std::vector<LegendEntry>& entries) {
    int w = 0;
    for (const LegendEntry& e : entries) {
        w = std::max(w, text_width(e.label));
    }
    return {w + 52, 20 * static_cast<int>(entries.size()) + 8};
}

void legend(cv::Mat& img,
            const std::vector<LegendEntry>& entries,
            cv::Point corner,
            bool anchor_left,
            int max_width) {
    if (entries.empty()) {
        return;
    }
    const int row = 20;
    const cv::Size size = legend_size(entries);
    const int room =
        max_width > 0 ? std::min(max_width, img.cols - 2 * kEdge) : img.cols - 2 * kEdge;
    const int box_w = std::min(size.width, room);
    const int box_h = size.height;
    // Inside the picture: moved in from an edge rather than cut by it.
    const int box_x = std::clamp(anchor_left ? corner.x : corner.x - box_w,
                                 kEdge,
                                 std::max(kEdge, img.cols - kEdge - box_w));
    const cv::Rect box(box_x, corner.y, box_w, box_h);
    cv::rectangle(img, box, kWhite, cv::FILLED);
    cv::rectangle(img, box, kAxis, 1);
    record(img, "", "", box, false, TextRole::kLegendFrame);
    for (std::size_t i = 0; i < entries.size(); ++i) {
        const int y = box.y + 4 + row / 2 + static_cast<int>(i) * row;
        const LegendEntry& e = entries[i];
        if (e.line) {
            cv::line(img, {box.x + 8, y}, {box.x + 36, y}, e.color, 2, cv::LINE_AA);
        }
        if (e.marker) {
            marker(img, {box.x + 22, y}, e.color);
        }
        text_within(img,
                    e.label,
                    {box.x + 44, y},
                    kTextScale,
                    kBlack,
                    Align::kLeft,
                    1,
                    TextRole::kText,
                    box_w - 52);
    }
}

void polyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, cv::Scalar color, int thickness) {
    for (std::size_t i = 1; i < pts.size(); ++i) {
        const cv::Point2d& a = pts[i - 1];
        const cv::Point2d& b = pts[i];
        if (!std::isfinite(a.x) || !std::isfinite(a.y) || !std::isfinite(b.x) ||
            !std::isfinite(b.y)) {
            // A gap in the curve (value not representable, e.g. zero on a log axis).
            continue;
        }
        // Sub-pixel precision: 4 fractional bits.
        const cv::Point pa(static_cast<int>(std::lround(a.x * 16)),
                           static_cast<int>(std::lround(a.y * 16)));
        const cv::Point pb(static_cast<int>(std::lround(b.x * 16)),
                           static_cast<int>(std::lround(b.y * 16)));
        cv::line(img, pa, pb, color, thickness, cv::LINE_AA, 4);
    }
}

cv::Scalar diverging(double t) {
    if (!std::isfinite(t)) {
        // No value: neutral grey.
        return {200, 200, 200};
    }
    t = std::clamp(t, -1.0, 1.0);
    const cv::Vec3d white(247, 247, 247);
    const cv::Vec3d red(38, 24, 178);    // BGR of a dark red
    const cv::Vec3d blue(172, 102, 33);  // BGR of a dark blue
    const cv::Vec3d end = t > 0 ? red : blue;
    const double a = std::abs(t);
    const cv::Vec3d c = white * (1 - a) + end * a;
    return {c[0], c[1], c[2]};
}

cv::Scalar sequential(double t) {
    t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
    // Piecewise-linear through dark blue, teal, green, yellow (BGR).
    static const cv::Vec3d kStops[] = {{84, 1, 68}, {140, 104, 49}, {120, 181, 53}, {37, 231, 253}};
    const double s = t * 3.0;
    const int i = std::min(2, static_cast<int>(s));
    const double f = s - i;
    const cv::Vec3d c = kStops[i] * (1 - f) + kStops[i + 1] * f;
    return {c[0], c[1], c[2]};
}

cv::Mat blank(int width, int height, const std::string& title, const std::string& subtitle) {
    cv::Mat img(height, width, CV_8UC3, kWhite);
    text(img, title, {width / 2, 18}, kTitleScale, kBlack, Align::kCenter, 2);
    if (!subtitle.empty()) {
        text(img, subtitle, {width / 2, 40}, kTextScale, kAxis, Align::kCenter);
    }
    return img;
}

Axes half_diff_axes(cv::Rect area) {
    Axes ax;
    ax.area = area;
    ax.x0 = 0;
    ax.x1 = 90;
    ax.y0 = 0;
    ax.y1 = 90;
    return ax;
}

void draw_half_diff_axes(cv::Mat& img, const Axes& ax, bool brief) {
    ax.draw(img,
            brief ? "theta_h [deg]" : "theta_h [deg] (half vector from the normal)",
            brief ? "theta_d [deg]" : "theta_d [deg] (difference angle)");
}

void colour_bar(cv::Mat& img,
                cv::Rect area,
                double lo,
                double hi,
                const std::function<cv::Scalar(double)>& colour,
                const std::string& label,
                int ticks) {
    for (int y = 0; y < area.height; ++y) {
        const double t = 1.0 - (y + 0.5) / area.height;
        cv::line(img, {area.x, area.y + y}, {area.x + area.width - 1, area.y + y}, colour(t), 1);
    }
    cv::rectangle(img, area, kAxis, 1);
    int widest = 0;
    for (double v : nice_ticks(lo, hi, ticks)) {
        const int y = area.y + area.height -
                      static_cast<int>(std::lround((v - lo) / (hi - lo) * area.height));
        cv::line(img, {area.x + area.width, y}, {area.x + area.width + 4, y}, kAxis, 1);
        const std::string s = format_tick(v);
        text(img,
             s,
             {area.x + area.width + 7, y},
             kTextScale,
             kBlack,
             Align::kLeft,
             1,
             TextRole::kTickLabel);
        widest = std::max(widest, text_width(s));
    }
    if (!label.empty()) {
        text_vertical(
            img, label, {area.x + area.width + 7 + widest + 14, area.y + area.height / 2});
    }
}

}  // namespace gonio::report::draw

namespace gonio::report {

TextRecorder::TextRecorder() {
    draw::t_recorded = &texts_;
}

TextRecorder::~TextRecorder() {
    draw::t_recorded = nullptr;
}

}  // namespace gonio::report
