#pragma once

// Rows of direction pairs evaluated together, as `gonio eval` and Python's gonio.eval() do: the
// directions laid out as structure of arrays for Brdf::eval_many (an analytic model on SIMD
// packets). A row that cannot be evaluated keeps its place and its value is NaN, so that output
// row k answers input row k; so is a row whose value is not finite, which evaluate() names.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "gonio/brdf/brdf.h"

namespace gonio::brdf {

class DirectionRows {
  public:
    void reserve(std::size_t n);
    /// A row to evaluate: unit vectors in the local frame.
    void add(const Vec3d& wi, const Vec3d& wo);
    /// A row that cannot be evaluated: held at the normal (a valid direction), its value NaN.
    void add_refused();
    std::size_t size() const { return refused_.size(); }
    /// Forgets every row.
    void clear();

    /// Evaluates every row: out[c][k] is channel c of row k (out[c] holds size() values), NaN in
    /// every channel for a refused row and for a row whose value is not finite. Returns the
    /// latter rows (not the refused ones), in order.
    std::vector<std::size_t> evaluate(const Brdf& brdf, double* const out[3]) const;

  private:
    std::vector<double> dir_[6];
    std::vector<std::uint8_t> refused_;
};

}  // namespace gonio::brdf
