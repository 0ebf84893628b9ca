#include "gonio/brdf/direction_rows.h"

#include <cmath>
#include <limits>

namespace gonio::brdf {

void DirectionRows::reserve(std::size_t n) {
    for (std::vector<double>& d : dir_) {
        d.reserve(n);
    }
    refused_.reserve(n);
}

void DirectionRows::add(const Vec3d& wi, const Vec3d& wo) {
    for (int k = 0; k < 3; ++k) {
        dir_[k].push_back(wi[k]);
        dir_[3 + k].push_back(wo[k]);
    }
    refused_.push_back(0);
}

void DirectionRows::add_refused() {
    const Vec3d normal(0, 0, 1);
    add(normal, normal);
    refused_.back() = 1;
}

void DirectionRows::clear() {
    for (std::vector<double>& d : dir_) {
        d.clear();
    }
    refused_.clear();
}

std::vector<std::size_t> DirectionRows::evaluate(const Brdf& brdf, double* const out[3]) const {
    const std::size_t n = size();
    brdf.eval_many(n,
                   {dir_[0].data(),
                    dir_[1].data(),
                    dir_[2].data(),
                    dir_[3].data(),
                    dir_[4].data(),
                    dir_[5].data()},
                   out);
    std::vector<std::size_t> non_finite;
    constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t k = 0; k < n; ++k) {
        const bool finite =
            std::isfinite(out[0][k]) && std::isfinite(out[1][k]) && std::isfinite(out[2][k]);
        if (refused_[k] == 0 && finite) {
            continue;
        }
        if (refused_[k] == 0) {
            non_finite.push_back(k);
        }
        for (int c = 0; c < 3; ++c) {
            out[c][k] = kNan;
        }
    }
    return non_finite;
}

}  // namespace gonio::brdf
