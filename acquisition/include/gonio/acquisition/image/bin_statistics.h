#pragma once

// The per-bin statistics both image tables keep (image_binning.h: BinnedTable over the
// half/difference table, image_aniso.h: AnisoTable over the 4-D table): the count, the Welford
// mean and sum of squared deviations per channel, the running mean of the noise-model variance,
// and the estimates made of them. Each table adds what it keeps of the samples' directions.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include "gonio/base/check.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition::detail {

class BinStatistics {
  public:
    explicit BinStatistics(std::size_t bins)
        : count_(bins, 0), mean_(3 * bins, 0.0), m2_(3 * bins, 0.0), model_var_(3 * bins, 0.0f) {}

    std::size_t size() const { return count_.size(); }
    std::uint32_t count(std::size_t bin) const { return count_[bin]; }
    std::uint64_t total() const { return total_; }

    /// One sample (B. P. Welford, Technometrics 4(3), 1962); returns 1 / the new count.
    double add(std::size_t bin, const brdf::Rgbd& value, const brdf::Rgbd& model_variance) {
        const std::uint32_t n = ++count_[bin];
        const double inv_n = 1.0 / n;
        for (int c = 0; c < 3; ++c) {
            // Welford: delta against the old mean, then against the new one.
            double& mean = mean_[3 * bin + c];
            const double delta = value[c] - mean;
            mean += delta * inv_n;
            m2_[3 * bin + c] += delta * (value[c] - mean);
            float& mv = model_var_[3 * bin + c];
            mv += static_cast<float>((model_variance[c] - mv) * inv_n);
        }
        ++total_;
        return inv_n;
    }

    /// A group of `nb` samples summarised by their mean, M2 and mean model variance (T. F. Chan,
    /// G. H. Golub, R. J. LeVeque, 1979: with delta = mean_b - mean_a, M2 = M2_a + M2_b + delta^2
    /// n_a n_b / n). Returns the bin's former count; the caller merges its own means with
    /// merge_means() before or after (they do not depend on these statistics).
    double merge(std::size_t bin,
                 std::uint32_t nb,
                 const std::array<float, 3>& mean_b,
                 const std::array<float, 3>& m2_b,
                 const std::array<float, 3>& model_var_b) {
        const double na = count_[bin];
        const double n = na + nb;
        for (int c = 0; c < 3; ++c) {
            double& mean = mean_[3 * bin + c];
            const double delta = mean_b[c] - mean;
            mean += delta * nb / n;
            m2_[3 * bin + c] += m2_b[c] + delta * delta * na * nb / n;
            float& mv = model_var_[3 * bin + c];
            mv = static_cast<float>((na * mv + nb * model_var_b[c]) / n);
        }
        count_[bin] += nb;
        total_ += nb;
        return na;
    }

    brdf::Rgbd mean(std::size_t bin) const {
        return {mean_[3 * bin], mean_[3 * bin + 1], mean_[3 * bin + 2]};
    }
    /// Unbiased sample variance (zero with fewer than two samples: one sample has no spread).
    brdf::Rgbd sample_variance(std::size_t bin) const {
        const std::uint32_t n = count_[bin];
        if (n < 2) {
            return brdf::Rgbd::Zero();
        }
        return brdf::Rgbd(m2_[3 * bin], m2_[3 * bin + 1], m2_[3 * bin + 2]) / (n - 1.0);
    }
    /// Mean noise-model variance of one sample, clamped at zero.
    brdf::Rgbd model_variance(std::size_t bin) const {
        const float* v = &model_var_[3 * bin];
        return brdf::Rgbd(v[0], v[1], v[2]).max(0.0);
    }
    /// The running mean of the model variance as kept (single precision, not clamped).
    const float* model_var_data(std::size_t bin) const { return &model_var_[3 * bin]; }
    /// sqrt(mean model variance / n) (zero for an empty bin: no estimate, no error).
    brdf::Rgbd model_standard_error(std::size_t bin) const {
        const std::uint32_t n = count_[bin];
        if (n == 0) {
            return brdf::Rgbd::Zero();
        }
        return (model_variance(bin) / n).sqrt();
    }
    /// The larger of the empirical sqrt(s^2 / n) (n >= 2) and the noise model's value, so that a
    /// bin of few samples is not overconfident.
    brdf::Rgbd standard_error(std::size_t bin) const {
        const std::uint32_t n = count_[bin];
        const brdf::Rgbd model = model_standard_error(bin);
        if (n < 2) {
            return model;
        }
        const brdf::Rgbd empirical = (sample_variance(bin) / n).sqrt();
        return empirical.max(model);
    }
    std::size_t filled(std::uint32_t min_count) const {
        return static_cast<std::size_t>(std::count_if(
            count_.begin(), count_.end(), [&](std::uint32_t n) { return n >= min_count; }));
    }

  private:
    std::vector<std::uint32_t> count_;
    std::vector<double> mean_;      // 3 per bin
    std::vector<double> m2_;        // 3 per bin
    std::vector<float> model_var_;  // 3 per bin, running mean
    std::uint64_t total_ = 0;
};

/// The running means a table keeps beside the statistics, merged with a group's: dst = (na dst +
/// nb src) / (na + nb), `k` values.
inline void merge_means(float* dst, const float* src, int k, double na, double nb) {
    const double n = na + nb;
    for (int i = 0; i < k; ++i) {
        dst[i] = static_cast<float>((na * dst[i] + nb * src[i]) / n);
    }
}

/// Whether a group's summary is finite in its first `k` values of each array (a journal is checked
/// before its records reach a table; a non-finite value here is a bug and aborts).
inline bool all_finite(std::initializer_list<const float*> arrays, int k = 3) {
    for (const float* a : arrays) {
        for (int i = 0; i < k; ++i) {
            if (!std::isfinite(a[i])) {
                return false;
            }
        }
    }
    return true;
}

/// A table's dataset: one sample per bin with at least max(min_count, 1) samples whose directions
/// `row(bin, &sample)` sets (returning false for a bin left out), value = the bin's mean clamped
/// at zero (noise can push a near-black bin below it; a BRDF is not negative), flags kFlagHdr when
/// `hdr`. With `bins`, each row's bin is appended to it.
template <class Row>
brdf::Dataset bins_to_dataset(const BinStatistics& stats,
                              const std::string& source,
                              std::uint32_t min_count,
                              bool hdr,
                              Row row,
                              std::vector<std::size_t>* bins = nullptr) {
    brdf::Dataset d;
    d.source = source;
    d.has_sigma = true;
    d.has_flags = true;
    for (std::size_t b = 0; b < stats.size(); ++b) {
        if (stats.count(b) < std::max<std::uint32_t>(min_count, 1)) {
            continue;
        }
        brdf::Sample s;
        if (!row(b, &s)) {
            continue;
        }
        s.value = stats.mean(b).max(0.0);
        s.flags = hdr ? brdf::kFlagHdr : 0u;
        d.samples.push_back(s);
        if (bins != nullptr) {
            bins->push_back(b);
        }
    }
    return d;
}

}  // namespace gonio::acquisition::detail
