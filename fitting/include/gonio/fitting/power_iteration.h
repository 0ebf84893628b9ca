#pragma once

// A data-driven microfacet distribution fitted to measurements: the tabulated NDF of
// brdf/tabulated_ndf.h extracted from the backscattering samples by power iteration, the remaining
// factors (Lambert diffuse, per-channel scale, Fresnel) by least squares.
//
// J. Dupuy, E. Heitz, J.-C. Iehl, P. Poulin, V. Ostromoukhov, "Extracting Microfacet-based BRDF
// Parameters from Arbitrary Materials with Power Iterations", Computer Graphics Forum 34(4), 2015.
// In backscattering (wi = wo = k, h = k) a microfacet lobe is
//   f(k, k) = F(1) D(k) G(k, k) / (4 cos^2 theta_k),
// and G depends on D through the projected area sigma(k) = int D(m) <k, m>+ dm; the paper writes
// G(k, k) = G1(k) = cos theta_k / sigma(k), so that D(k) is proportional to f(k, k) cos theta_k
// sigma(k): D is the eigenvector of the largest eigenvalue of that linear operator, found by power
// iteration D <- normalise(f(k, k) cos theta_k sigma[D](k)). gonio's lobes use the
// height-correlated Smith G = 1 / (1 + Lambda(wi) + Lambda(wo)) with Lambda = sigma / cos - 1
// (E. Heitz, JCGT 3(2), 2014), so the same iteration is written with the model's own G:
//   D <- normalise(y / G[D]),   y = (f - rho / pi) 4 cos_i cos_o / (scale F),
// on the samples whose theta_d (the angle between wi and h) is below a threshold (by default
// every sample; PowerIterationOptions), each sample splatted onto the two grid nodes around its
// theta_h (hat weights in u). At exact backscattering with G1 this is the paper's iteration; off
// it, y / G is the model's own inversion, exact for data made by such a model, with F divided out
// per sample. Nodes no sample reaches take
// the values of their nearest reached neighbours (linear between two, constant beyond the last).
// The rounds alternate: the table from the data with the current diffuse, scale and Fresnel
// removed, then those factors by the Ceres fit (fit.h) with the table held; the first round starts
// from a diffuse floor (a low percentile of the samples far from the specular peak).

#include <cstddef>

#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/tabulated_ndf.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"

namespace gonio::fitting {

struct PowerIterationOptions {
    std::size_t nodes = 32;  ///< Nodes of the table (u = sqrt(theta_h / (pi/2)) uniform).
    /// The samples of the iteration: theta_d (the angle between wi and h) below this, doubled (up
    /// to 90 degrees) until at least min_samples are selected. 90 (the default) takes every
    /// sample: on the three real RGL files the whole data give a log RMSE of 0.077 on satin
    /// against 0.113 from the samples within 40 degrees of backscattering (the paper's selection
    /// is theta_d near 0), and equal or lower on the others (docs/benchmarks/models.md).
    double theta_d_max_deg = 90.0;
    std::size_t min_samples = 400;
    int iterations = 200;  ///< Most power iterations per round (stops at a change below 1e-7).
    int rounds = 3;        ///< Alternations of the table and the least-squares factors (>= 1).
};

/// What one extraction did.
struct NdfExtraction {
    brdf::TabulatedNdf table;
    std::size_t samples = 0;      ///< Backscattering samples used.
    double theta_d_max_deg = 0;   ///< The threshold that selected them.
    std::size_t empty_nodes = 0;  ///< Nodes no sample reached (filled from their neighbours).
    int iterations = 0;
    double change = 0;  ///< Relative change (max norm) of the last iteration.
};

/// The table from the samples, with the factors of `factors` removed: its diffuse (when present)
/// and, of its first lobe (which must be tabulated; its table, when set, is the first iterate),
/// the scale, Fresnel term and shadowing. Errors: no lobe or not tabulated, too few
/// backscattering samples, nothing reflected above the diffuse.
Expected<NdfExtraction> extract_ndf(const std::vector<brdf::Sample>& samples,
                                    const brdf::ModelD& factors,
                                    const PowerIterationOptions& options = {});

/// True when `spec` has a tabulated lobe whose table is still to be extracted from the data.
bool needs_power_iteration(const FitSpec& spec);

/// The fit of a spec with one tabulated lobe (its table null): rounds of extract_ndf and fit()
/// with the table held (the last round with the spec's options: polish, covariance, metrics on all
/// samples). The result's model holds the table; its first stage is "power iteration".
Expected<FitResult> fit_power_iteration(const brdf::Dataset& data,
                                        const FitSpec& spec,
                                        const PowerIterationOptions& options = {});

/// fit_power_iteration when the spec needs it, else fit().
Expected<FitResult> fit_any(const brdf::Dataset& data, const FitSpec& spec);

/// Nodes of the tabulated lobes of a model (the parameters the table stands for, counted by the
/// model choice's criterion).
int table_nodes(const brdf::ModelD& model);

}  // namespace gonio::fitting
