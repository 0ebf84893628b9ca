// The simulated sensor (EMVA 1288 release 4.0 linear camera model).

#include "gonio/sim/sensor_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "gonio/base/check.h"
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

__extension__ typedef unsigned __int128 Uint128;

// SplitMix64 (Steele, Lea and Flood 2014, "Fast splittable pseudorandom number generators"):
// the output function, used to decorrelate seeds ...
std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// ... and the generator itself: a Weyl sequence through that output function (period 2^64; passes
// BigCrush). One instance per stripe of rows.
class SplitMix64 {
  public:
    explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }

  private:
    std::uint64_t state_;
};

// Rows per stripe: the unit of parallel work and of generator seeding, so a frame's noise depends
// on the seed only, not on how many threads rendered it.
constexpr int kStripeRows = 32;
// Below this mean the electron count is drawn from the Poisson distribution itself; above it from
// its normal limit (relative skew 1/sqrt(mu) < 0.18).
constexpr double kPoissonLimit = 30;
// A run of at least this many pixels of one radiance draws its counts from the tabulated count
// distribution; shorter runs (a sphere's shading) draw electrons pixel by pixel.
constexpr int kMinTableRun = 64;
// At most this many distinct radiances per stripe use tables (bounds the table building of an
// image of many medium-length runs).
constexpr std::size_t kMaxTablesPerStripe = 8;
// Tables cover each normal component to +-kTailSigmas standard deviations (tail mass 1.5e-23).
constexpr double kTailSigmas = 10;

// What turns electrons into counts, for one frame.
struct Chain {
    double responsivity_t = 0;  ///< electrons per unit radiance in the exposure
    double dark_e = 0;          ///< dark electrons in the exposure
    double read_e = 0;          ///< read noise, electrons rms
    double full_well = 0;       ///< electrons
    double counts_per_e = 0;
    double black = 0;  ///< counts
    double sat = 0;    ///< highest code, counts
};

/// Converted, clamped and rounded half up: the counts of e electrons.
std::uint16_t to_counts(const Chain& ch, double e) {
    const double c = std::clamp(ch.black + e * ch.counts_per_e, 0.0, ch.sat);
    return static_cast<std::uint16_t>(c + 0.5);
}

// Standard normal CDF, accurate in both tails.
double normal_cdf(double z) {
    return 0.5 * std::erfc(-z * 0.7071067811865476);
}

// Distribution of the counts of a pixel whose electron count is a mixture of atoms e_j (weights
// w_j) plus one normal N(0, sd_e^2): P(c) = sum_j w_j P(round_clamp(black + (e_j + N) k) = c),
// with round_clamp the converter of to_counts (codes 0 and sat collect the clipped tails).
// Returns the probabilities of codes first, first + 1, ...
std::vector<double> count_pmf(const Chain& ch,
                              const std::vector<std::pair<double, double>>& atoms,
                              double sd_e,
                              int* first) {
    const double s = sd_e * ch.counts_per_e;  // counts
    double lo_m = std::numeric_limits<double>::infinity(), hi_m = -lo_m;
    for (const auto& [e, w] : atoms) {
        const double m = ch.black + e * ch.counts_per_e;
        lo_m = std::min(lo_m, m);
        hi_m = std::max(hi_m, m);
    }
    const int sat = static_cast<int>(ch.sat);
    const int lo = std::clamp(static_cast<int>(std::floor(lo_m - kTailSigmas * s)) - 1, 0, sat);
    const int hi = std::clamp(static_cast<int>(std::ceil(hi_m + kTailSigmas * s)) + 1, 0, sat);
    std::vector<double> pmf(static_cast<std::size_t>(hi - lo + 1), 0.0);
    for (const auto& [e, w] : atoms) {
        if (w <= 0) {
            continue;
        }
        const double m = ch.black + e * ch.counts_per_e;
        if (s <= 0) {
            pmf[static_cast<std::size_t>(to_counts(ch, e) - lo)] += w;
            continue;
        }
        // Codes within kTailSigmas of m; the lowest and highest code of the table take the
        // whole tail beyond them (they are 0 and sat when the tail reaches the clamp; a mean
        // far above sat puts all its weight on sat).
        const int c0 = std::clamp(static_cast<int>(std::floor(m - kTailSigmas * s)), lo, hi);
        const int c1 = std::clamp(static_cast<int>(std::ceil(m + kTailSigmas * s)), lo, hi);
        double below = c0 == lo ? 0.0 : normal_cdf((c0 - 0.5 - m) / s);
        for (int c = c0; c <= c1; ++c) {
            const double upper = c == hi ? 1.0 : normal_cdf((c + 0.5 - m) / s);
            pmf[static_cast<std::size_t>(c - lo)] += w * (upper - below);
            below = upper;
        }
    }
    double total = 0;
    for (double p : pmf) {
        total += p;
    }
    GONIO_CHECK_MSG(
        total > 0.5 && std::isfinite(total),
        "count distribution sums to " << total << " (codes " << lo << ".." << hi << ")");
    for (double& p : pmf) {
        p /= total;
    }
    *first = lo;
    return pmf;
}

// Draws codes from a discrete distribution in constant time: Walker's alias method (Walker 1977,
// "An efficient method for generating discrete random variables with general distributions", ACM
// TOMS 3(3)) with Vose's numerically stable construction (Vose 1991, IEEE TSE 17(9)). One 64-bit
// uniform word r per draw: r * n / 2^64 picks the cell (its integer part) and the top 48 bits of
// its fractional part make the cell's threshold test, so each code's probability is exact to
// about 2^-48. A cell is one 64-bit word (48-bit threshold, 16-bit alias code): 3000 cells stay
// in the first-level cache.
class CountSampler {
  public:
    CountSampler(const std::vector<double>& pmf, int first) : first_(first) {
        const std::size_t n = pmf.size();
        GONIO_CHECK(n > 0 && first >= 0 && first + n <= 65536);
        std::vector<std::uint64_t> threshold(n, kAlways);
        std::vector<std::uint16_t> alias(n);
        std::vector<double> q(n);
        std::vector<std::size_t> small, large;
        for (std::size_t i = 0; i < n; ++i) {
            q[i] = pmf[i] * static_cast<double>(n);
            (q[i] < 1.0 ? small : large).push_back(i);
            alias[i] = code(i);
        }
        while (!small.empty() && !large.empty()) {
            const std::size_t l = small.back(), g = large.back();
            small.pop_back();
            large.pop_back();
            threshold[l] = q[l] <= 0.0 ? 0 : static_cast<std::uint64_t>(std::ldexp(q[l], 48));
            alias[l] = code(g);
            q[g] = (q[g] + q[l]) - 1.0;
            (q[g] < 1.0 ? small : large).push_back(g);
        }
        // What remains has q = 1 up to rounding: its alias is its own code.
        cells_.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            cells_[i] = std::min(threshold[i], kAlways) << 16 | alias[i];
        }
    }
    std::uint16_t draw(std::uint64_t r) const {
        const Uint128 m = static_cast<Uint128>(r) * cells_.size();
        const std::size_t i = static_cast<std::size_t>(m >> 64);
        const std::uint64_t cell = cells_[i];
        // Own code or alias, selected without a branch (the outcome is random: a branch would
        // be mispredicted often).
        const std::uint64_t own =
            static_cast<std::uint64_t>((static_cast<std::uint64_t>(m) >> 16) < (cell >> 16));
        const std::uint64_t mask = 0 - own;
        const std::uint64_t code = static_cast<std::uint64_t>(first_) + i;
        return static_cast<std::uint16_t>((code & mask) | (cell & ~mask));
    }

  private:
    static constexpr std::uint64_t kAlways = (std::uint64_t{1} << 48) - 1;
    std::uint16_t code(std::size_t i) const {
        return static_cast<std::uint16_t>(first_ + static_cast<int>(i));
    }
    int first_;
    std::vector<std::uint64_t> cells_;  ///< threshold (P(own code | cell) * 2^48) << 16 | alias
};

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

// How the electrons of a pixel with mean mu_e are drawn; the tabulated and the pixel-by-pixel
// draws follow the same law.
enum class ShotLaw {
    kPoisson,       ///< mu_e < kPoissonLimit: Poisson itself, clipped at the full well, + read
    kNormal,        ///< far below the full well: one normal of variance mu_e + read^2
    kFullWell,      ///< far above it: the full well, + read noise
    kClippedNormal  ///< near it: normal shot noise clipped at the full well, + read noise
};

ShotLaw shot_law(const Chain& ch, double mu_e) {
    if (mu_e < kPoissonLimit) {
        return ShotLaw::kPoisson;
    }
    const double sd = std::sqrt(mu_e);
    if (mu_e + 6 * sd < ch.full_well) {
        return ShotLaw::kNormal;
    }
    if (mu_e - kTailSigmas * sd >= ch.full_well) {
        return ShotLaw::kFullWell;
    }
    return ShotLaw::kClippedNormal;
}

// The count distribution of a pixel of mean mu_e as a sampler, or null for the clipped-normal law
// (a normal clipped inside its body convolved with a normal: drawn pixel by pixel).
std::shared_ptr<const CountSampler> make_sampler(const Chain& ch, double mu_e) {
    std::vector<std::pair<double, double>> atoms;
    double sd_e = ch.read_e;
    switch (shot_law(ch, mu_e)) {
        case ShotLaw::kPoisson: {
            // Poisson probabilities by recurrence, until the remaining tail is below 1e-17.
            double p = std::exp(-mu_e), cum = 0;
            for (int k = 0; k < 400; ++k) {
                atoms.emplace_back(std::min(static_cast<double>(k), ch.full_well), p);
                cum += p;
                if (k > mu_e && 1.0 - cum < 1e-17) {
                    break;
                }
                p *= mu_e / (k + 1);
            }
            break;
        }
        case ShotLaw::kNormal:
            atoms.emplace_back(mu_e, 1.0);
            sd_e = std::sqrt(mu_e + ch.read_e * ch.read_e);
            break;
        case ShotLaw::kFullWell:
            atoms.emplace_back(ch.full_well, 1.0);
            break;
        case ShotLaw::kClippedNormal:
            return nullptr;
    }
    int first = 0;
    const std::vector<double> pmf = count_pmf(ch, atoms, sd_e, &first);
    return std::make_shared<const CountSampler>(pmf, first);
}

// Samplers of one frame, shared by the stripes (built once per distinct radiance).
class SamplerCache {
  public:
    explicit SamplerCache(const Chain& ch) : ch_(ch) {}
    std::shared_ptr<const CountSampler> get(float radiance) {
        std::lock_guard<std::mutex> lock(mutex_);
        for (const auto& [l, s] : samplers_) {
            if (l == radiance) {
                return s;
            }
        }
        auto s = make_sampler(ch_, ch_.responsivity_t * radiance + ch_.dark_e);
        samplers_.emplace_back(radiance, s);
        return s;
    }

  private:
    Chain ch_;
    std::mutex mutex_;
    std::vector<std::pair<float, std::shared_ptr<const CountSampler>>> samplers_;
};

// One pixel's counts drawn electron by electron (the path of short runs).
class PixelDraw {
  public:
    PixelDraw(const Chain& ch, std::uint64_t seed) : ch_(ch), rng_(seed) {}
    void set(double mu_e) {
        mu_e_ = mu_e;
        law_ = shot_law(ch_, mu_e);
        if (law_ == ShotLaw::kPoisson && mu_e > 0 && mu_e != poisson_.mean()) {
            poisson_.set(mu_e);
        }
        sigma_ =
            law_ == ShotLaw::kNormal ? std::sqrt(mu_e + ch_.read_e * ch_.read_e) : std::sqrt(mu_e);
    }
    std::uint16_t draw() {
        double e = 0;
        switch (law_) {
            case ShotLaw::kPoisson:
                // Small means: an exact Poisson draw by inverse CDF (zero mean: zero).
                e = mu_e_ > 0 ? poisson_.draw(rng_.uniform(0.0, 1.0)) : 0.0;
                e = std::min(e, ch_.full_well) + ch_.read_e * rng_.gaussian(1.0);
                break;
            case ShotLaw::kNormal:
                // Normal limit of the shot noise far from the full well: shot and read noise add
                // in variance, one draw of N(mu_e, mu_e + read^2).
                e = mu_e_ + sigma_ * rng_.gaussian(1.0);
                break;
            case ShotLaw::kFullWell:
            case ShotLaw::kClippedNormal:
                // Near or above the full well the shot noise clips before the read noise adds.
                e = std::min(std::max(0.0, mu_e_ + sigma_ * rng_.gaussian(1.0)), ch_.full_well);
                e += ch_.read_e * rng_.gaussian(1.0);
                break;
        }
        return to_counts(ch_, e);
    }

  private:
    Chain ch_;
    cv::RNG rng_;
    PoissonTable poisson_;
    double mu_e_ = 0, sigma_ = 0;
    ShotLaw law_ = ShotLaw::kPoisson;
};

// A non-finite or negative radiance is a renderer bug: treated as black, never NaN.
float clean(float l) {
    return l > 0 && l <= std::numeric_limits<float>::max() ? l : 0.0f;
}

}  // namespace

cv::Mat SensorModel::expose(const cv::Mat& radiance, const ExposureSettings& s) {
    GONIO_CHECK(radiance.type() == CV_32F);
    GONIO_CHECK(s.exposure_us > 0 && s.gain > 0);
    const double t = s.exposure_us * 1e-6;
    Chain ch;
    ch.responsivity_t = p_.responsivity_e_per_s * t;
    ch.dark_e = p_.dark_current_e_per_s * t;
    ch.read_e = p_.read_noise_e;
    ch.full_well = p_.full_well_e;
    ch.counts_per_e = 1.0 / e_per_count(s);
    ch.black = black_level(s.format);
    ch.sat = saturation_level(s.format);
    // One draw from the frame generator seeds every stripe of this frame.
    const std::uint64_t frame_seed = rng_();
    cv::Mat out(radiance.rows, radiance.cols, CV_16U);
    const int stripes = (radiance.rows + kStripeRows - 1) / kStripeRows;
    SamplerCache cache(ch);
    cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
        for (int stripe = range.start; stripe < range.end; ++stripe) {
            const std::uint64_t seed =
                splitmix64(frame_seed ^ splitmix64(static_cast<std::uint64_t>(stripe)));
            SplitMix64 words(seed);
            PixelDraw pixel(ch, splitmix64(seed));
            // Radiances whose runs this stripe draws from tables (at most kMaxTablesPerStripe,
            // in order of appearance: the choice depends on the image only).
            std::vector<std::pair<float, std::shared_ptr<const CountSampler>>> tables;
            float pixel_l = -1.0f;
            const int y_end = std::min(radiance.rows, (stripe + 1) * kStripeRows);
            for (int y = stripe * kStripeRows; y < y_end; ++y) {
                const float* L = radiance.ptr<float>(y);
                auto* dst = out.ptr<std::uint16_t>(y);
                int x = 0;
                while (x < radiance.cols) {
                    // The run of pixels of one radiance starting at x (the patch, the background):
                    // equal values, compared as bit patterns.
                    std::uint32_t bits = 0;
                    std::memcpy(&bits, L + x, sizeof bits);
                    int end = x + 1;
                    for (std::uint32_t b = 0; end < radiance.cols; ++end) {
                        std::memcpy(&b, L + end, sizeof b);
                        if (b != bits) {
                            break;
                        }
                    }
                    const float l = clean(L[x]);
                    const CountSampler* table = nullptr;
                    if (end - x >= kMinTableRun) {
                        auto it = std::find_if(tables.begin(), tables.end(), [l](const auto& e) {
                            return e.first == l;
                        });
                        if (it == tables.end() && tables.size() < kMaxTablesPerStripe) {
                            tables.emplace_back(l, cache.get(l));
                            it = tables.end() - 1;
                        }
                        if (it != tables.end()) {
                            table = it->second.get();
                        }
                    }
                    if (table != nullptr) {
                        for (; x < end; ++x) {
                            dst[x] = table->draw(words.next());
                        }
                        continue;
                    }
                    if (l != pixel_l) {
                        pixel_l = l;
                        pixel.set(ch.responsivity_t * l + ch.dark_e);
                    }
                    for (; x < end; ++x) {
                        dst[x] = pixel.draw();
                    }
                }
            }
        }
    });
    if (p_.nonlinearity != 0) {
        apply_nonlinearity(ch.black, ch.sat, &out);
    }
    return out;
}

void SensorModel::apply_nonlinearity(double black, double sat, cv::Mat* counts) const {
    // x (1 + beta (x - 1/2)) on the signal above black in units of the full scale; the result
    // rounds to a count and clips like the linear chain.
    const double full = sat - black;
    for (int y = 0; y < counts->rows; ++y) {
        auto* row = counts->ptr<std::uint16_t>(y);
        for (int x = 0; x < counts->cols; ++x) {
            const double v = row[x] - black;
            if (v <= 0 || row[x] >= sat) {
                continue;  // black or clipped: nothing to bend
            }
            const double frac = v / full;
            const double bent = black + v * (1 + p_.nonlinearity * (frac - 0.5));
            row[x] = static_cast<std::uint16_t>(std::clamp(std::round(bent), 0.0, sat));
        }
    }
}

}  // namespace gonio::sim
