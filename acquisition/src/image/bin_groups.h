#pragma once

// Per-frame samples gathered by bin (image_binning.cpp, image_aniso.cpp): the groups of a stable
// sort by bin and the running statistics of each group.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

namespace gonio::acquisition::detail {

/// Calls visit(bin, first, last) for each bin's samples in increasing bin order, [first, last)
/// being indices into `samples`. Stable: within a bin the samples keep their order (pixel order),
/// so that a summary of a frame is deterministic.
template <class Entry, class Visit>
void for_each_bin_group(const std::vector<Entry>& samples, Visit visit) {
    std::vector<std::uint32_t> order(samples.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return samples[a].bin < samples[b].bin;
    });
    std::size_t i = 0;
    while (i < order.size()) {
        const std::uint32_t bin = samples[order[i]].bin;
        std::size_t j = i;
        while (j < order.size() && samples[order[j]].bin == bin) {
            ++j;
        }
        visit(bin, order.data() + i, order.data() + j);
        i = j;
    }
}

/// Welford's running mean and sum of squared deviations per channel, with the running mean of the
/// model variances (B. P. Welford, Technometrics 4(3), 1962).
struct ChannelWelford {
    std::uint32_t bin = 0;  ///< The group's bin.
    std::uint32_t n = 0;
    double mean[3] = {0, 0, 0};
    double m2[3] = {0, 0, 0};
    double model_var[3] = {0, 0, 0};

    void add(const double value[3], const double variance[3]) {
        ++n;
        for (int c = 0; c < 3; ++c) {
            const double delta = value[c] - mean[c];
            mean[c] += delta / n;
            m2[c] += delta * (value[c] - mean[c]);
            model_var[c] += (variance[c] - model_var[c]) / n;
        }
    }
};

/// Each bin group of `samples` summarised: Welford over the samples' value and model_var, and
/// the running means of the K floats `values(entry)` points to (their positions or directions);
/// then emit(welford, means, first index of the group's stable order, one past its last).
template <int K, class Entry, class Values, class Emit>
void summarise_bin_groups(const std::vector<Entry>& samples, Values values, Emit emit) {
    for_each_bin_group(
        samples, [&](std::uint32_t bin, const std::uint32_t* first, const std::uint32_t* last) {
            ChannelWelford w;
            w.bin = bin;
            double means[K] = {};
            for (const std::uint32_t* k = first; k != last; ++k) {
                const Entry& e = samples[*k];
                w.add(e.value, e.model_var);
                const float* v = values(e);
                for (int c = 0; c < K; ++c) {
                    means[c] += (v[c] - means[c]) / w.n;
                }
            }
            emit(w, static_cast<const double*>(means), first, last);
        });
}

/// The statistics part of a bin's aggregate (BinAggregate, AnisoBinAggregate) from its group's
/// Welford summary.
template <class Aggregate>
Aggregate aggregate_of(const ChannelWelford& w) {
    Aggregate a;
    a.bin = w.bin;
    a.count = w.n;
    for (int c = 0; c < 3; ++c) {
        a.mean[c] = static_cast<float>(w.mean[c]);
        a.m2[c] = static_cast<float>(w.m2[c]);
        a.model_var[c] = static_cast<float>(w.model_var[c]);
    }
    return a;
}

}  // namespace gonio::acquisition::detail
