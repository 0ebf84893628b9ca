#pragma once

// Drawing helpers shared by the plots (private to the module): text, axes with ticks, legends,
// colour maps. Everything is drawn with OpenCV primitives and anti-aliased text; sizes are chosen
// so that a plot stays readable at 800 px wide.

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "gonio/report/plot.h"

namespace gonio::report::draw {

inline const cv::Scalar kBlack(0, 0, 0);
inline const cv::Scalar kWhite(255, 255, 255);
inline const cv::Scalar kGrid(215, 215, 215);
inline const cv::Scalar kAxis(60, 60, 60);

constexpr int kFont = 0;  // cv::FONT_HERSHEY_SIMPLEX
constexpr double kTextScale = 0.5;
constexpr double kTitleScale = 0.65;

/// A distinct BGR colour for series i (cycled).
cv::Scalar series_color(int i);

enum class Align { kLeft, kCenter, kRight };

/// Draws text with its baseline-middle at org.y shifted so that the text is vertically centred on
/// org.y; horizontal alignment as requested.
void text(cv::Mat& img,
          const std::string& s,
          cv::Point org,
          double scale = kTextScale,
          cv::Scalar color = kBlack,
          Align align = Align::kLeft,
          int thickness = 1,
          TextRole role = TextRole::kText);

/// Text rotated by 90 degrees counter-clockwise, centred on org (for y-axis labels).
void text_vertical(cv::Mat& img,
                   const std::string& s,
                   cv::Point org,
                   double scale = kTextScale,
                   TextRole role = TextRole::kText);

/// Width in pixels of a text.
int text_width(const std::string& s, double scale = kTextScale, int thickness = 1);

/// "Nice" tick values (1, 2, 5 times a power of ten) covering [lo, hi] with about `target` ticks.
std::vector<double> nice_ticks(double lo, double hi, int target);

/// Formats a tick value compactly (%g with up to 3 significant digits, e.g. "0.05", "1e+03").
std::string format_tick(double v);

/// Cartesian axes: a plot area in pixels and data ranges; y optionally logarithmic (base 10).
struct Axes {
    cv::Rect area;
    double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
    bool log_y = false;

    double px(double x) const;
    /// Pixel row of a data value; values <= 0 on a log axis map below the area.
    double py(double y) const;
    cv::Point pt(double x, double y) const {
        return {static_cast<int>(std::lround(px(x))), static_cast<int>(std::lround(py(y)))};
    }
    bool inside_y(double y) const;

    /// Frame, grid, ticks with labels, axis labels.
    void draw(cv::Mat& img, const std::string& x_label, const std::string& y_label) const;
};

/// Axes of the half/difference plane over `area`: theta_h [deg] along x, theta_d [deg] up, both
/// over [0, 90] (Rusinkiewicz 1998; the residual and coverage maps).
Axes half_diff_axes(cv::Rect area);

/// Draws half_diff_axes: frame, grid, ticks and the plane's axis labels (`brief`: the angles'
/// names alone, for a narrow panel).
void draw_half_diff_axes(cv::Mat& img, const Axes& ax, bool brief = false);

/// A vertical colour bar in `area` for values in [lo, hi]: colour(t), t in [0, 1] from bottom to
/// top; about `ticks` ticks at the right, and `label` (when not empty) rotated beyond the widest
/// tick label.
void colour_bar(cv::Mat& img,
                cv::Rect area,
                double lo,
                double hi,
                const std::function<cv::Scalar(double)>& colour,
                const std::string& label,
                int ticks = 5);

/// A legend entry: a colour, a style (line, marker or both) and a label.
struct LegendEntry {
    cv::Scalar color;
    std::string label;
    bool line = true;
    bool marker = false;
};

/// Draws a framed legend whose top-right corner (or top-left with anchor_left) is at corner. The
/// frame is at most max_width pixels wide (0: the picture's width less its margins), its labels
/// drawn smaller or shortened to fit, and moved inside the picture rather than cut by its edge.
void legend(cv::Mat& img,
            const std::vector<LegendEntry>& entries,
            cv::Point corner,
            bool anchor_left = false,
            int max_width = 0);

/// Size in pixels of the legend box legend() draws.
cv::Size legend_size(const std::vector<LegendEntry>& entries);

/// A filled circle marker with a dark outline.
void marker(cv::Mat& img, cv::Point p, cv::Scalar color, int radius = 4);

/// A polyline, broken where points are invalid (NaN pixel coordinates).
void polyline(cv::Mat& img,
              const std::vector<cv::Point2d>& pts,
              cv::Scalar color,
              int thickness = 2);

/// Diverging colour map for t in [-1, 1]: blue (-1) through white (0) to red (+1); BGR.
cv::Scalar diverging(double t);

/// Sequential colour map for t in [0, 1] (dark blue to yellow); BGR.
cv::Scalar sequential(double t);

/// A white canvas with a title line at the top.
cv::Mat blank(int width, int height, const std::string& title, const std::string& subtitle = {});

}  // namespace gonio::report::draw
