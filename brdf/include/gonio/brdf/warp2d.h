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
// A grid may depend on parameters (the RGL files: the incident elevation theta_i, for anisotropic
// files also the incident azimuth phi_i, and the channel): one grid per parameter node, and between
// nodes the stored tables (values and both CDFs) are interpolated linearly in each parameter, as
// the readers of the format (RGL's reference reader, Mitsuba 3's `measured` plugin) do. With two
// parameters the slices are outer-major (phi_i, then theta_i, as the files store them), and the
// single-precision lookups interpolate along the outer parameter first, then the inner one. The
// tables are kept in single precision, and the CDFs summed in double and rounded to single
// precision, so that gonio's warp is the same function as theirs to rounding.

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

/// Where a value falls between the slices of one or two parameters: the first slice, the slice
/// steps to the next node of each parameter (0 when it has one node) and the weights of the next
/// nodes. Slices are outer-major: slice = outer_index * inner_count + inner_index.
struct SliceWeights {
    std::size_t base = 0;
    std::size_t inner_step = 0, outer_step = 0;
    double inner_w1 = 0, outer_w1 = 0;
};
SliceWeights slice_weights(const std::vector<float>& outer_nodes,
                           const std::vector<float>& inner_nodes,
                           double outer,
                           double inner);
/// The same in single precision with the format readers' rounding.
struct SliceWeightsF {
    std::size_t base = 0;
    std::size_t inner_step = 0, outer_step = 0;
    float inner_w0 = 1, inner_w1 = 0, outer_w0 = 1, outer_w1 = 0;
};
SliceWeightsF slice_weights_f(const std::vector<float>& outer_nodes,
                              const std::vector<float>& inner_nodes,
                              float outer,
                              float inner);

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
    /// Value at p between the slices of `w`, each slice index multiplied by `scale` and offset by
    /// `offset` (a channel among `scale` channels per parameter node).
    double eval(const Point2& p,
                const SliceWeights& w,
                std::size_t scale,
                std::size_t offset) const;
    /// The same in single precision with the readers' order of operations (see RglBsdf::eval);
    /// SliceWeightsF{} with scale 1 and offset 0 is the first slice alone.
    float eval_f(
        float x, float y, const SliceWeightsF& w, std::size_t scale, std::size_t offset) const;

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
    /// Two parameters: outer_params.size() x params.size() grids, outer-major (the same rules
    /// for both parameters' nodes).
    static Expected<Warp2D> build(std::size_t nx,
                                  std::size_t ny,
                                  const std::vector<float>& values,
                                  std::vector<float> outer_params,
                                  std::vector<float> params,
                                  const std::string& label);

    /// Uniform variates -> a point distributed by the density at `param`.
    Point2 sample(const Point2& xi, double param) const { return sample(xi, 0.0, param); }
    Point2 sample(const Point2& xi, double outer, double param) const;
    /// The inverse of sample(): the variates that sample() maps to p.
    Point2 invert(const Point2& p, double param) const { return invert(p, 0.0, param); }
    Point2 invert(const Point2& p, double outer, double param) const;
    /// invert() in single precision, in the order of operations of the format's readers (RGL's
    /// reference reader, Mitsuba 3): the rounding of a renderer's evaluation is reproduced, which
    /// matters where the stored values fall steeply to zero at the edge of the square.
    std::array<float, 2> invert_f(float x, float y, float param) const {
        return invert_f(x, y, 0.0f, param);
    }
    std::array<float, 2> invert_f(float x, float y, float outer, float param) const;
    /// The normalised density at p (integral 1 over the unit square).
    double pdf(const Point2& p, double param) const { return pdf(p, 0.0, param); }
    double pdf(const Point2& p, double outer, double param) const;

    std::size_t nx() const { return nx_; }
    std::size_t ny() const { return ny_; }
    const std::vector<float>& params() const { return params_; }
    const std::vector<float>& outer_params() const { return outer_params_; }

  private:
    // Linear interpolation of a table between the slices of the parameter weights.
    double lerp(const std::vector<float>& table,
                std::size_t slice_size,
                std::size_t index,
                const SliceWeights& w) const;

    float lerp_f(const std::vector<float>& table,
                 std::size_t slice_size,
                 std::size_t index,
                 const SliceWeightsF& w) const;

    std::size_t nx_ = 0, ny_ = 0;
    std::vector<float> outer_params_;  // one node (0) when the warp has one parameter
    std::vector<float> params_;
    std::vector<float> density_;      // slices * ny * nx, normalised
    std::vector<float> conditional_;  // slices * ny * nx: integral along x up to each node
    std::vector<float> marginal_;     // slices * ny: integral along y up to each row
};

}  // namespace gonio::brdf
