#pragma once

// The simulated sensor: radiance -> electrons -> counts, with photon shot noise, dark current, read
// noise, a black level, full-well and bit-depth saturation (EMVA 1288 linear camera model, release
// 4.0, sec. 2: mean signal mu_y = mu_y.dark + K * (eta * mu_p); variance
// sigma_y^2 = K^2 (sigma_d^2 + mu_e) + sigma_q^2).
//
// Chain for one pixel (docs/camera.md):
//   mu_e  = R * L * t + D * t                    electrons (R responsivity, D dark current)
//   e     ~ Poisson(mu_e), clipped at the full well, plus Normal(0, read_noise_e)
//   counts = round(black + e * gain / K_b), clipped to [0, 2^b - 1]
// with K_b = e_per_count16 * 2^(16 - b) electrons per count at unity gain for b significant bits.

#include <cstdint>
#include <opencv2/core.hpp>
#include <random>

#include "gonio/devices/camera.h"

namespace gonio::sim {

struct SensorParams {
    int width = 1280;
    int height = 1024;
    /// Electrons per second per unit radiance (W m^-2 sr^-1): pixel etendue x optics transmission
    /// x quantum efficiency / photon energy, lumped.
    double responsivity_e_per_s = 5.0e6;
    double full_well_e = 30000;
    /// Electrons per Mono16 count at unity gain.
    double e_per_count16 = 0.5;
    double read_noise_e = 6;
    double dark_current_e_per_s = 25;
    /// Black level in Mono16 counts (scaled by 2^(b-16) for b bits).
    double black_level16 = 1024;
    /// Non-linearity of the response: a signal x above black, in units of the full scale
    /// (saturation - black), reads x (1 + nonlinearity (x - 1/2)) (0: linear). Applied to the
    /// counts after the noise, before the clip.
    double nonlinearity = 0;
    std::uint64_t seed = 1;
};

struct ExposureSettings {
    double exposure_us = 10000;
    double gain = 1;  ///< linear
    devices::PixelFormat format = devices::PixelFormat::kMono16;
};

class SensorModel {
  public:
    explicit SensorModel(SensorParams p);

    const SensorParams& params() const { return p_; }
    /// Electrons per count for the settings (K_b / gain).
    double e_per_count(const ExposureSettings& s) const;
    double black_level(devices::PixelFormat f) const;
    double saturation_level(devices::PixelFormat f) const;
    /// Expected counts (unclipped, noise-free) for a pixel seeing radiance L.
    double mean_counts(double radiance, const ExposureSettings& s) const;
    /// Variance of the counts (shot + dark + read + quantisation) for a pixel seeing radiance L.
    double variance_counts(double radiance, const ExposureSettings& s) const;
    /// One noisy exposure of a radiance image (CV_32F); returns CV_16U counts (at most 2^b - 1).
    cv::Mat expose(const cv::Mat& radiance, const ExposureSettings& s);
    /// Restarts the noise sequence.
    void reseed(std::uint64_t seed);

  private:
    void apply_nonlinearity(double black, double sat, cv::Mat* counts) const;

    SensorParams p_;
    std::mt19937_64 rng_;
};

}  // namespace gonio::sim
