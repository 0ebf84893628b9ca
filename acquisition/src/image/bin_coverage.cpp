#include "gonio/acquisition/image/bin_coverage.h"

#include "gonio/base/check.h"

namespace gonio::acquisition {

BinCoverage::BinCoverage(std::vector<std::uint8_t> valid)
    : valid_(std::move(valid)), covered_(valid_.size(), 0) {
    for (const std::uint8_t v : valid_) {
        valid_count_ += v != 0 ? 1 : 0;
    }
}

double BinCoverage::fraction() const {
    if (valid_count_ == 0) {
        // A layout without valid bins (never with positive bin counts): nothing to cover.
        return 1.0;
    }
    return static_cast<double>(covered_count_) / static_cast<double>(valid_count_);
}

void BinCoverage::cover(std::size_t bin) {
    GONIO_CHECK(bin < covered_.size());
    if (valid_[bin] && !covered_[bin]) {
        covered_[bin] = 1;
        ++covered_count_;
    }
}

void BinCoverage::cover_all(const std::vector<std::uint32_t>& bins) {
    for (const std::uint32_t b : bins) {
        cover(b);
    }
}

std::size_t BinCoverage::gain(const std::vector<std::uint32_t>& bins) const {
    std::size_t g = 0;
    for (const std::uint32_t b : bins) {
        g += (valid_[b] && !covered_[b]) ? 1 : 0;
    }
    return g;
}

}  // namespace gonio::acquisition
