#pragma once

// Stratified reduction of a large set of samples in the Rusinkiewicz half/difference domain.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gonio/brdf/dataset.h"

namespace gonio::fitting {

/// Chooses about `budget` samples: strata are cells of (sqrt-spaced theta_h, theta_d, phi_d folded
/// to [0, pi)); the budget is spread evenly over the non-empty strata (a stratum smaller than its
/// share keeps all its samples and leaves the rest to the others); inside a stratum the choice is
/// a seeded uniform draw without replacement. Every kept sample's weight is multiplied by
/// n_stratum / kept_stratum, so that for every stratum the weighted sum over the kept samples
/// estimates the sum over all of them (the weighted least-squares objective is an unbiased
/// estimate of the full one). When budget == 0 or budget >= samples.size() the input is returned
/// unchanged.
std::vector<brdf::Sample> stratified_reduce(const std::vector<brdf::Sample>& samples,
                                            std::size_t budget,
                                            std::uint64_t seed);

/// The coordinates of a sample in the strata of stratified_reduce, each in [0, 1]: sqrt(theta_h /
/// (pi/2)), theta_d / (pi/2) and phi_d folded to [0, pi) over pi.
using StratumCoords = std::array<double, 3>;

/// The stratum coordinates of every sample: the costly part of a reduction (the half/difference
/// transform, about 150 ns a sample), computed once for several reductions of the same samples.
std::vector<StratumCoords> stratum_coordinates(const std::vector<brdf::Sample>& samples);

/// stratified_reduce with the samples' coordinates given (coords[i] of samples[i]): the same
/// result, without the transform. With `kept`, the index in `samples` of each returned sample
/// (so that the reduction's own coordinates need no transform either).
std::vector<brdf::Sample> stratified_reduce(const std::vector<brdf::Sample>& samples,
                                            std::size_t budget,
                                            std::uint64_t seed,
                                            const std::vector<StratumCoords>& coords,
                                            std::vector<std::size_t>* kept = nullptr);

}  // namespace gonio::fitting
