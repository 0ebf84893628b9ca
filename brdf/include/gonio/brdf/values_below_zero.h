#pragma once

// Measured values below zero. A dark value measured with noise lands a little below zero as often
// as above it (a camera's dark frame or a photodiode's offset subtracted): such a value is a
// measurement, kept and fitted as it is (docs/fitting-guide.md, "Values below zero"). A value far
// below zero is no reflectance and is refused, naming its row.

#include <string>
#include <vector>

#include "gonio/brdf/dataset.h"

namespace gonio::brdf {

/// A value down to this many of its noise sigmas below zero is within its noise.
inline constexpr double kBelowZeroSigmas = 5;
/// The relative noise a dataset without sigma columns implies: this fraction of its largest value
/// (a dynamic range of 80 dB, what a 12-bit sensor reaches with a few exposures merged).
inline constexpr double kImpliedRelativeNoise = 1e-4;
/// No value below -0.1 1/sr is within noise, whatever its sigma: log(1 + d cos_i), the default
/// residual, needs d cos_i > -1, and no reflectance measurement is that uncertain near zero.
inline constexpr double kBelowZeroLimit = 0.1;

/// The noise of one value of a dataset without sigma columns (1/sr): kImpliedRelativeNoise times
/// the largest finite value of the samples (0 when none is above zero).
double implied_noise(const std::vector<Sample>& samples);

/// How far below zero each channel of `s` may lie and be kept (1/sr, >= 0):
/// min(kBelowZeroLimit, kBelowZeroSigmas x sigma), sigma the sample's own when it is above zero,
/// else `implied_noise`.
Rgbd below_zero_allowance(const Sample& s, double implied_noise);

/// validate_sample() with values in [-allowance, 0) accepted (allowance per channel, 1/sr). A
/// value below it is refused: "b = -0.5 below zero beyond its noise (down to -5e-05 allowed: 5 x
/// sigma 1e-05)".
std::string validate_sample(const Sample& s, const Rgbd& allowance);

/// The reason a value `v` of channel `channel` (0-2) lies below its allowance, or "" when it does
/// not. `sigma_given`: the allowance came from the sample's sigma (else from the implied noise).
std::string below_zero_reason(int channel, double v, double allowance, bool sigma_given);

}  // namespace gonio::brdf
