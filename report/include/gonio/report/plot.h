#pragma once

// Plots of measured BRDF samples and of a fitted (or tabulated) BRDF: in-plane polar slices,
// delta_phi slices, residual maps over (theta_h, theta_d) and the coverage of the angular domain.
// Every plot carries a title, axes with tick labels and units, and a legend; the default size is
// readable at 800 px wide. Plotted quantity: luminance Y (Rec. 709 weights) of the RGB BRDF, 1/sr.

#include <string>
#include <vector>

#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/table.h"
#include "gonio/report/image.h"

namespace gonio::report {

/// How the BRDF axis (the radius of a polar plot, the y axis of the others) is scaled.
enum class AxisScale {
    kAuto,    ///< logarithmic when the measured values span more than a decade, else linear
    kLinear,  ///< linear from 0
    kLog,     ///< logarithmic (base 10), whole decades
};

/// Name of a scale as the command line spells it: "auto", "linear", "log".
const char* axis_scale_name(AxisScale s);

/// The scale used for values spanning [vmin_pos, vmax] (vmin_pos: smallest positive value):
/// kAuto resolves to kLog when vmax / vmin_pos > 10, else kLinear; the others stay.
AxisScale resolve_scale(AxisScale requested, double vmin_pos, double vmax);

struct PlotOptions {
    int width = 800;                     ///< picture width, px (>= 400)
    AxisScale scale = AxisScale::kAuto;  ///< BRDF axis scale
    /// In-plane slices: incidence angles to show, degrees. Empty: chosen from the data (up to 5
    /// distinct theta_i with in-plane samples), or 0, 20, 40, 60 when only a fit is given.
    std::vector<double> theta_i_deg;
    /// How far a sample may lie from a slice, degrees: from the slice's theta_i, and (in-plane
    /// plot) its outgoing direction from the plane of incidence. Each sample is drawn at its own
    /// theta_o in the nearest slice within this tolerance (stated on the plot).
    double angle_tolerance_deg = 2.5;
};

/// What a recorded box on a picture is.
enum class TextRole {
    kText,        ///< a text with no role below (titles, captions, legend labels, ...)
    kAxisLabel,   ///< an axis's name (below the x axis, rotated left of the y axis)
    kTickLabel,   ///< the value at a tick of an axis
    kRingLabel,   ///< the value of a ring of a polar plot
    kLegendFrame  ///< a legend's framed box (filled: it hides what lies under it); no text
};

/// A text drawn on a picture: what, where (its box in pixels, glyphs included) and the size of the
/// picture it was drawn on. A text that would not fit is drawn smaller, then shortened in its
/// middle ("..."), and moved inside: it is never cut at the picture's edge. A legend's frame is
/// recorded too (role kLegendFrame, empty text), so that tests can check what it covers.
struct DrawnText {
    std::string text;   ///< as drawn (shortened when it had to be)
    std::string asked;  ///< as the plot asked for it
    int x = 0, y = 0, width = 0, height = 0;
    int image_width = 0, image_height = 0;
    bool vertical = false;  ///< rotated by 90 degrees (a y-axis or colour-bar label)
    TextRole role = TextRole::kText;
};

/// While alive, records every text the pictures drawn on this thread put down (tests check that
/// each lies inside its picture). One recorder per thread at a time.
class TextRecorder {
  public:
    TextRecorder();
    ~TextRecorder();
    TextRecorder(const TextRecorder&) = delete;
    TextRecorder& operator=(const TextRecorder&) = delete;
    const std::vector<DrawnText>& texts() const { return texts_; }
    void clear() { texts_.clear(); }

  private:
    std::vector<DrawnText> texts_;
};

/// Geometry of an in-plane polar plot, for callers that place marks on it: the polar origin (the
/// point on the sample surface) in pixels and the radius, in pixels, of the largest ring.
/// Outgoing direction theta_o is drawn at angle theta_o from the upward vertical, positive
/// (forward, specular side: delta_phi = pi) to the right, negative (back toward the light:
/// delta_phi = 0) to the left; distance from the origin grows with the BRDF value.
struct PolarLayout {
    double origin_x = 0, origin_y = 0;
    double radius_px = 0;
    /// Colour of the fitted curve and markers of each slice, in slice order.
    std::vector<Color> slice_colors;
    std::vector<double> theta_i_deg;  ///< the slices drawn
    std::size_t points_drawn = 0;     ///< measured samples drawn in all slices together
    bool log_scale = false;           ///< the radius scale used (after AxisScale::kAuto)
    /// BRDF values of the rings, 1/sr, inner first; each is labelled along the baseline unless
    /// its label would overlap the one of the ring outside it (close log rings near the origin).
    std::vector<double> ring_values;
    /// Measured samples off their slice's theta_i moved onto it by the fit (see plot_in_plane).
    std::size_t moved_to_slice = 0;
    /// With a fit: the largest |log10(marker / curve)| at a marker's in-plane angle.
    double worst_marker_misfit = 0;
};

/// In-plane polar plot: measured samples (markers with radial error bars of +-1 sigma) and the fit
/// (curves) at several theta_i. `fit` may be null (data only); the dataset may be empty when a fit
/// is given (curves only). Slices are chosen from the data: clusters of at least 3 samples whose
/// theta_i agree within 2 angle_tolerance_deg and whose wo lies within angle_tolerance_deg of the
/// plane of incidence (scattered directions included). When the dataset has samples but no slice
/// holds 3 of them, the picture is plot_half_angle() instead (its title says so). Error when there
/// is nothing to draw. With a fit, a sample whose own theta_i is off its slice's (an image
/// campaign's pixels spread over the tolerance) is moved onto the slice by the fit's ratio between
/// the slice's geometry and its own, so that each marker is compared with the fit at its own
/// incident angle (the subtitle says so).
Expected<Image> plot_in_plane(const brdf::Dataset& data,
                              const brdf::Brdf* fit,
                              const PlotOptions& options,
                              PolarLayout* layout = nullptr);

/// Scattered samples: BRDF luminance against theta_h (Rusinkiewicz half angle), each sample a
/// marker coloured by theta_d (colour bar), the fit evaluated at each sample's own directions as a
/// hollow ring. Used when no in-plane slice holds the samples. Error on an empty dataset.
Expected<Image> plot_half_angle(const brdf::Dataset& data,
                                const brdf::Brdf* fit,
                                const PlotOptions& options,
                                const std::string& why = {});

/// BRDF against delta_phi = phi_o - phi_i (degrees, 0 = back toward the light, 180 = forward) at
/// fixed (theta_i, theta_o) pairs found in the data (or theta_i = theta_o = 20, 40, 60 degrees for
/// a fit alone). Error when there is nothing to draw.
Expected<Image> plot_delta_phi(const brdf::Dataset& data,
                               const brdf::Brdf* fit,
                               const PlotOptions& options);

/// Residual map: log10(measured / fitted) luminance averaged in 5-degree bins of (theta_h,
/// theta_d) (Rusinkiewicz half/difference angles), on a diverging colour scale with a colour bar.
/// The subtitle states the rms over samples of log10(Y_measured / Y_fit) (luminance, unweighted),
/// which is not the fit report's log RMSE (per channel, natural log of 1 + f cos theta_i).
/// Samples whose measured or fitted luminance is not positive are counted and skipped. Error when
/// the dataset has no sample.
Expected<Image> plot_residual_map(const brdf::Dataset& data,
                                  const brdf::Brdf& fit,
                                  const PlotOptions& options);

/// Coverage of the angular domain: left, every measured (wi, wo) pair's outgoing direction wo
/// projected on the unit disk (x = sin theta cos phi, y = sin theta sin phi), coloured by theta_i;
/// right, the samples in (theta_h, theta_d). Error when the dataset has no sample.
Expected<Image> plot_coverage(const brdf::Dataset& data, const PlotOptions& options);

/// Coverage of a half/difference table (an image-mode campaign): per (theta_h, theta_d) cell the
/// fraction of its phi_d bins that hold a measured value, axes in degrees (theta_h on its square-
/// root bin scale's centres drawn at their angles), a colour bar, and the holes outlined.
struct TableHole {
    double theta_h_min_deg = 0, theta_h_max_deg = 0;
    double theta_d_min_deg = 0, theta_d_max_deg = 0;
    std::string reason;
};
Expected<Image> plot_table_coverage(const brdf::TabulatedBrdf& table,
                                    const std::vector<TableHole>& holes,
                                    const PlotOptions& options,
                                    const std::string& title);

/// The coverage of a half/difference table as counts per (theta_h, theta_d) cell, for a table
/// still being filled (the live page of an image campaign).
struct CoverageCells {
    int n_theta_h = 0, n_theta_d = 0, n_phi_d = 0;
    /// Per cell, theta_h-major (index ih * n_theta_d + id): the fraction of its phi_d bins that
    /// hold a measured value, or -1 when the cell has no valid bin.
    std::vector<double> fraction;
    std::size_t measured_bins = 0;     ///< Bins holding a measured value.
    std::size_t total_bins = 0;        ///< Bins the percentage is of.
    bool total_is_valid_bins = false;  ///< total_bins counts the valid bins only.
};

/// plot_table_coverage() drawn from cells: the same axes, colour bar, legend and hole outlines;
/// cells without a valid bin in mid grey. Error when the cells do not match the grid.
Expected<Image> plot_coverage_cells(const CoverageCells& cells,
                                    const std::vector<TableHole>& holes,
                                    const PlotOptions& options,
                                    const std::string& title);

/// The dataset without its drift-reference rows (flag kFlagReference): those re-measure one
/// configuration to follow the lamp, they are not BRDF samples of the plan.
brdf::Dataset without_reference_rows(const brdf::Dataset& data);

/// A picture that was written, with its path and a caption.
struct WrittenPlot {
    std::string path;
    std::string caption;
};

/// What write_plots() produced: the pictures written and, for each plot that had nothing to show,
/// the reason it was left out.
struct PlotSet {
    std::vector<WrittenPlot> written;
    std::vector<std::string> skipped;
    /// Plots written that show less than they seem to (in-plane slices without one measured
    /// point: the samples are scattered off the plane of incidence, only the fit is drawn).
    std::vector<std::string> warnings;
};

/// Writes in_plane.png, delta_phi.png and, with a fit, residuals.png into out_dir (created if
/// missing). Error on an empty dataset (nothing is written), when no plot has anything
/// to show, or when a file cannot be written. `data.source` names the data in titles.
Expected<PlotSet> write_plots(const brdf::Dataset& data,
                              const brdf::Brdf* fit,
                              const PlotOptions& options,
                              const std::string& out_dir);

}  // namespace gonio::report
