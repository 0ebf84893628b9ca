#pragma once

// Stratified reduction of a large set of samples in the Rusinkiewicz half/difference domain.

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

}  // namespace gonio::fitting
