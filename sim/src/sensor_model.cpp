// The simulated sensor (EMVA 1288 release 4.0 linear camera model).

#include "gonio/sim/sensor_model.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

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

namespace {

// SplitMix64 (Steele, Lea and Flood 2014): decorrelates the per-stripe generator seeds.
std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// Rows per stripe: the unit of parallel work and of generator seeding, so a frame's noise depends
// on the seed only, not on how many threads rendered it.
constexpr int kStripeRows = 32;
// Below this mean the electron count is drawn from the Poisson distribution itself; above it from
// its normal limit (relative skew 1/sqrt(mu) < 0.18).
constexpr double kPoissonLimit = 30;

// Inverse-CDF sampler of Poisson(mu) for one mean (Devroye 1986, "Non-Uniform Random Variate
// Generation", sec. X.3.2, sequential search): the CDF is tabulated once per distinct mean.
class PoissonTable {
  public:
    void set(double mu) {
        mu_ = mu;
        cdf_.clear();
        double p = std::exp(-mu);
        double c = p;
        for (int k = 0; k < 200; ++k) {
            cdf_.push_back(c);
            if (c >= 1.0 - 1e-15) {
                break;
            }
            p *= mu / (k + 1);
            c += p;
        }
    }
    double mean() const { return mu_; }
    int draw(double u) const {
        int k = 0;
        const int n = static_cast<int>(cdf_.size());
        while (k < n - 1 && u > cdf_[static_cast<std::size_t>(k)]) {
            ++k;
        }
        return k;
    }

  private:
    double mu_ = -1;
    std::vector<double> cdf_;
};

}  // namespace

cv::Mat SensorModel::expose(const cv::Mat& radiance, const ExposureSettings& s) {
    GONIO_CHECK(radiance.type() == CV_32F);
    GONIO_CHECK(s.exposure_us > 0 && s.gain > 0);
    const double t = s.exposure_us * 1e-6;
    const double counts_per_e = 1.0 / e_per_count(s);
    const double black = black_level(s.format);
    const double sat = saturation_level(s.format);
    const double dark_e = p_.dark_current_e_per_s * t;
    const double read_e = p_.read_noise_e;
    const double read2 = read_e * read_e;
    const double full_well = p_.full_well_e;
    const double responsivity_t = p_.responsivity_e_per_s * t;
    // One draw from the frame generator seeds every stripe of this frame.
    const std::uint64_t frame_seed = rng_();
    cv::Mat out(radiance.rows, radiance.cols, CV_16U);
    const int stripes = (radiance.rows + kStripeRows - 1) / kStripeRows;
    cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
        cv::Mat z(1, radiance.cols, CV_32F);
        PoissonTable poisson;
        for (int stripe = range.start; stripe < range.end; ++stripe) {
            cv::RNG rng(splitmix64(frame_seed ^ splitmix64(static_cast<std::uint64_t>(stripe))));
            const int y_end = std::min(radiance.rows, (stripe + 1) * kStripeRows);
            for (int y = stripe * kStripeRows; y < y_end; ++y) {
                rng.fill(z, cv::RNG::NORMAL, 0.0, 1.0);
                const float* L = radiance.ptr<float>(y);
                const float* zn = z.ptr<float>(0);
                auto* dst = out.ptr<std::uint16_t>(y);
                // Pixels of one radiance share their mean and standard deviation: a run of equal
                // radiance (the patch, the background) reuses them.
                float last_l = -1.0f;
                double mu_e = 0, sigma = 0;
                int path = 0;  // 0 Poisson, 1 one normal, 2 clipped shot noise then read noise
                for (int x = 0; x < radiance.cols; ++x) {
                    // A non-finite or negative radiance is a renderer bug: treat as black, never
                    // NaN.
                    const float l = std::isfinite(L[x]) && L[x] > 0 ? L[x] : 0.0f;
                    if (l != last_l) {
                        last_l = l;
                        mu_e = responsivity_t * l + dark_e;
                        if (mu_e < kPoissonLimit) {
                            path = 0;
                            if (mu_e > 0 && mu_e != poisson.mean()) {
                                poisson.set(mu_e);
                            }
                        } else if (mu_e + 6 * std::sqrt(mu_e) < full_well) {
                            path = 1;
                            sigma = std::sqrt(mu_e + read2);
                        } else {
                            path = 2;
                            sigma = std::sqrt(mu_e);
                        }
                    }
                    double e;
                    if (path == 0) {
                        // Small means: an exact Poisson draw by inverse CDF (zero mean: zero).
                        e = mu_e > 0 ? poisson.draw(rng.uniform(0.0, 1.0)) : 0.0;
                        e = std::min(e, full_well) + read_e * zn[x];
                    } else if (path == 1) {
                        // Normal limit of the shot noise far from the full well: shot and read
                        // noise add in variance, one draw of N(mu_e, mu_e + read^2).
                        e = mu_e + sigma * zn[x];
                    } else {
                        // Near the full well the shot noise clips before the read noise adds; the
                        // read noise is a second normal draw (Box-Muller from two uniforms).
                        e = std::min(std::max(0.0, mu_e + sigma * zn[x]), full_well);
                        const double u1 = std::max(rng.uniform(0.0, 1.0), 1e-300);
                        e += read_e * std::sqrt(-2.0 * std::log(u1)) *
                             std::cos(6.283185307179586 * rng.uniform(0.0, 1.0));
                    }
                    // Round half up after clamping (a truncating conversion of a value >= 0).
                    const double c = std::clamp(black + e * counts_per_e, 0.0, sat);
                    dst[x] = static_cast<std::uint16_t>(c + 0.5);
                }
            }
        }
    });
    return out;
}

}  // namespace gonio::sim
