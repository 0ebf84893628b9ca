#pragma once

// Piecewise-bilinear 2D densities on the unit square and their marginal-conditional warps, the
// building block of the adaptive parameterisation of J. Dupuy and W. Jakob, "An Adaptive
// Parameterization for Efficient Material Acquisition and Rendering", SIGGRAPH Asia 2018, section 5
// (the VNDF warp) and section 6 (interpolation of the stored values).
//
// A grid of nx x ny node values over [0, 1]^2 (nodes at x = i / (nx - 1), y = j / (ny - 1), x
// contiguous) defines a density that is bilinear in each patch. Its warp maps uniform variates to
// the density by inversion: first the marginal over rows (y), whose density is linear in y inside a
// patch, then the conditional over x at that y, linear in x inside a patch; each step solves a
// quadratic in closed form. invert() is the exact inverse of sample().
//
// A grid may depend on parameters (the RGL files: the incident elevation theta_i, and the channel):
// one grid per parameter node, and between nodes the stored tables (values and both CDFs) are
// interpolated linearly, as the readers of the format (RGL's reference reader, Mitsuba 3's
// `measured` plugin) do. The tables are kept in single precision, and the CDFs summed in double and
// rounded to single precision, so that gonio's warp is the same function as theirs to rounding.

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::brdf {

/// A point of the unit square, (x, y).
using Point2 = std::array<double, 2>;

/// Position of a value among increasing parameter nodes: the left node and the linear weight of
/// the right one (clamped to [0, 1]; a single node gives index 0, weight 0).
struct ParamWeight {
    std::size_t index = 0;
    double w1 = 0;
};
ParamWeight param_weight(const std::vector<float>& nodes, double value);

/// Node values over [0, 1]^2, one grid per parameter node ("slice"), interpolated bilinearly in
/// (x, y) and linearly between slices.
class BilinearGrid {
  public:
    BilinearGrid() = default;
    /// values: slices * ny * nx, slice-major, x contiguous; nx, ny >= 2 (checked by the caller).
    BilinearGrid(std::size_t nx, std::size_t ny, std::size_t slices, std::vector<float> values);

    /// Value at p in slice s (p clamped to the square).
    double eval(const Point2& p, std::size_t slice) const;
    /// Value at p between slices `slice` and `slice + stride` (weight w1 on the second).
    double eval(const Point2& p, std::size_t slice, std::size_t stride, double w1) const;
    /// The same in single precision with the readers' order of operations (see RglBsdf::eval).
    float eval_f(float x, float y, std::size_t slice, std::size_t stride, float w1) const;

    std::size_t nx() const { return nx_; }
    std::size_t ny() const { return ny_; }
    std::size_t slices() const { return slices_; }
    const std::vector<float>& values() const { return values_; }

  private:
    std::size_t nx_ = 0, ny_ = 0, slices_ = 0;
    std::vector<float> values_;
};

/// A normalised piecewise-bilinear density with its marginal-conditional warp, one per slice of a
/// parameter (linear interpolation of the tables between slices).
class Warp2D {
  public:
    Warp2D() = default;

    /// values: params.size() grids of ny x nx non-negative node values (slice-major, x contiguous).
    /// Refused (message starts with `label`): a size below 2 in x or y, a count that is not
    /// params.size() * nx * ny, a negative or non-finite value, parameters not strictly increasing
    /// or not finite, a slice whose integral is zero.
    static Expected<Warp2D> build(std::size_t nx,
                                  std::size_t ny,
                                  const std::vector<float>& values,
                                  std::vector<float> params,
                                  const std::string& label);

    /// Uniform variates -> a point distributed by the density at `param`.
    Point2 sample(const Point2& xi, double param) const;
    /// The inverse of sample(): the variates that sample() maps to p.
    Point2 invert(const Point2& p, double param) const;
    /// invert() in single precision, in the order of operations of the format's readers (RGL's
    /// reference reader, Mitsuba 3): the rounding of a renderer's evaluation is reproduced, which
    /// matters where the stored values fall steeply to zero at the edge of the square.
    std::array<float, 2> invert_f(float x, float y, float param) const;
    /// The normalised density at p (integral 1 over the unit square).
    double pdf(const Point2& p, double param) const;

    std::size_t nx() const { return nx_; }
    std::size_t ny() const { return ny_; }
    const std::vector<float>& params() const { return params_; }

  private:
    // Linear interpolation of a table between the slices of a parameter weight.
    double lerp(const std::vector<float>& table,
                std::size_t slice_size,
                std::size_t index,
                const ParamWeight& w) const;

    float lerp_f(const std::vector<float>& table,
                 std::size_t slice_size,
                 std::size_t index,
                 std::size_t slice,
                 float w0,
                 float w1) const;

    std::size_t nx_ = 0, ny_ = 0;
    std::vector<float> params_;
    std::vector<float> density_;      // slices * ny * nx, normalised
    std::vector<float> conditional_;  // slices * ny * nx: integral along x up to each node
    std::vector<float> marginal_;     // slices * ny: integral along y up to each row
};

}  // namespace gonio::brdf
