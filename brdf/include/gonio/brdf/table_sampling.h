#pragma once

// Importance sampling of an isotropic BRDF from tables (typically a TabulatedBrdf, for which no
// closed-form sampling exists): for each of n_theta_i incidence slices, a piecewise-constant 2D
// density over the outgoing hemisphere in (theta_o, phi_o - phi_i), proportional to the luminance
// of f(wi, wo) cos(theta_o) integrated over each cell, sampled by a marginal CDF over theta_o rows
// and a conditional CDF over phi cells in the row (the standard construction, e.g. M. Pharr, W.
// Jakob, G. Humphreys, "Physically Based Rendering", 4th ed., 2023, section A.5 "Sampling 2D
// functions").
//
// Within a cell, directions are uniform in solid angle. A fraction `uniform_fraction` of the
// samples is cosine-distributed over the hemisphere ("defensive" mixture), so the pdf is positive
// wherever cos(theta_o) > 0 even where the tabulated cell value was 0:
//   pdf(wo | wi) = (1 - e) P_s(cell(wo)) / Omega(cell(wo)) + e cos(theta_o) / pi   [1/sr]
// with s the slice containing theta_i (nearest slice, no blending), P_s the cell probability and
// Omega the cell's solid angle. pdf() returns exactly the density that sample() draws from.

#include <vector>

#include "gonio/brdf/brdf.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/sampling.h"

namespace gonio::brdf {

struct TableSamplerOptions {
    int n_theta_i = 32;             ///< incidence slices over [0, pi/2)
    int n_theta_o = 64;             ///< rows over theta_o in [0, pi/2)
    int n_phi_o = 128;              ///< cells over phi_o - phi_i in [0, 2 pi)
    double uniform_fraction = 0.1;  ///< e in the file comment, in [0, 1]
};

class TableSampler {
  public:
    /// Builds the slices by evaluating `brdf` at cell centres (n_theta_i n_theta_o n_phi_o calls).
    /// brdf must be isotropic; the options are checked (positive counts, e in [0, 1]).
    TableSampler(const Brdf& brdf, const TableSamplerOptions& options = {});

    /// Draws wo for wi from three uniform numbers in [0, 1): u_mix chooses table or cosine part,
    /// (u1, u2) place the direction. The sample's w is wo; pdf = 0 and w = (0, 0, 1) when wi is at or
    /// below the horizon (nothing to sample).
    DirectionSample sample(const Vec3d& wi, double u_mix, double u1, double u2) const;

    /// Density of sample() at wo, 1/sr; 0 when wi or wo is at or below the horizon.
    double pdf(const Vec3d& wi, const Vec3d& wo) const;

    const TableSamplerOptions& options() const { return options_; }

  private:
    int slice_of(double theta_i) const;
    double table_pdf(int slice, double theta_o, double phi_rel) const;

    TableSamplerOptions options_;
    // Per slice: cell probabilities (row-major theta_o, phi), the row marginal CDF (n_theta_o + 1),
    // the conditional CDFs per row (n_phi_o + 1 each), and whether the slice has any weight.
    std::vector<double> cell_prob_;
    std::vector<double> row_cdf_;
    std::vector<double> col_cdf_;
    std::vector<char> slice_ok_;
};

}  // namespace gonio::brdf
