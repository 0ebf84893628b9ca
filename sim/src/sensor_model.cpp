// The simulated sensor (EMVA 1288 release 4.0 linear camera model).

#include "gonio/sim/sensor_model.h"

#include <algorithm>
#include <cmath>

#include "gonio/brdf/check.h"
#include "gonio/devices/pixel_format.h"

namespace gonio::sim {

SensorModel::SensorModel(SensorParams p) : p_(p), rng_(p.seed) {
    GONIO_CHECK(p_.width > 0 && p_.height > 0);
    GONIO_CHECK(p_.e_per_count16 > 0 && p_.full_well_e > 0);
    GONIO_CHECK(p_.responsivity_e_per_s >= 0 && p_.read_noise_e >= 0 &&
                p_.dark_current_e_per_s >= 0);
}

void SensorModel::reseed(std::uint64_t seed) {
    rng_.seed(seed);
}

double SensorModel::e_per_count(const ExposureSettings& s) const {
    const int b = devices::significant_bits(s.format);
    return p_.e_per_count16 * std::ldexp(1.0, 16 - b) / s.gain;
}

double SensorModel::black_level(devices::PixelFormat f) const {
    return p_.black_level16 * std::ldexp(1.0, devices::significant_bits(f) - 16);
}

double SensorModel::saturation_level(devices::PixelFormat f) const {
    return std::ldexp(1.0, devices::significant_bits(f)) - 1;
}

double SensorModel::mean_counts(double radiance, const ExposureSettings& s) const {
    const double t = s.exposure_us * 1e-6;
    const double mu_e = p_.responsivity_e_per_s * radiance * t + p_.dark_current_e_per_s * t;
    return black_level(s.format) + mu_e / e_per_count(s);
}

double SensorModel::variance_counts(double radiance, const ExposureSettings& s) const {
    const double t = s.exposure_us * 1e-6;
    const double mu_e = p_.responsivity_e_per_s * radiance * t + p_.dark_current_e_per_s * t;
    const double k = 1.0 / e_per_count(s);
    return k * k * (mu_e + p_.read_noise_e * p_.read_noise_e) + 1.0 / 12.0;
}

cv::Mat SensorModel::expose(const cv::Mat& radiance, const ExposureSettings& s) {
    GONIO_CHECK(radiance.type() == CV_32F);
    GONIO_CHECK(s.exposure_us > 0 && s.gain > 0);
    const double t = s.exposure_us * 1e-6;
    const double counts_per_e = 1.0 / e_per_count(s);
    const double black = black_level(s.format);
    const double sat = saturation_level(s.format);
    const double dark_e = p_.dark_current_e_per_s * t;
    std::normal_distribution<double> normal(0.0, 1.0);
    // Pixels of the same radiance share one Poisson distribution (its set-up dominates otherwise).
    double poisson_mean = -1;
    std::poisson_distribution<long> poisson(1.0);
    cv::Mat out(radiance.rows, radiance.cols, CV_16U);
    for (int y = 0; y < radiance.rows; ++y) {
        const float* L = radiance.ptr<float>(y);
        auto* dst = out.ptr<std::uint16_t>(y);
        for (int x = 0; x < radiance.cols; ++x) {
            // A non-finite or negative radiance is a renderer bug: treat as black, never NaN.
            const double l = std::isfinite(L[x]) && L[x] > 0 ? L[x] : 0.0;
            const double mu_e = p_.responsivity_e_per_s * l * t + dark_e;
            double e;
            if (mu_e < 30) {
                // Small means: exact Poisson draw (a zero mean gives zero electrons).
                if (mu_e <= 0) {
                    e = 0;
                } else {
                    if (mu_e != poisson_mean) {
                        poisson = std::poisson_distribution<long>(mu_e);
                        poisson_mean = mu_e;
                    }
                    e = static_cast<double>(poisson(rng_));
                }
            } else {
                // Large means: the Poisson distribution's normal limit (relative skew 1/sqrt(mu)).
                e = std::max(0.0, mu_e + std::sqrt(mu_e) * normal(rng_));
            }
            e = std::min(e, p_.full_well_e);
            e += p_.read_noise_e * normal(rng_);
            const double c = std::nearbyint(black + e * counts_per_e);
            dst[x] = static_cast<std::uint16_t>(std::clamp(c, 0.0, sat));
        }
    }
    return out;
}

}  // namespace gonio::sim
