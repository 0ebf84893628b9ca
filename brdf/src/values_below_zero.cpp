#include "gonio/brdf/values_below_zero.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sample_columns.h"

namespace gonio::brdf {

using namespace detail;  // the dataset columns of sample_columns.h

double implied_noise(const std::vector<Sample>& samples) {
    double peak = 0;
    for (const Sample& s : samples) {
        for (int c = 0; c < 3; ++c) {
            if (std::isfinite(s.value[c])) {
                peak = std::max(peak, s.value[c]);
            }
        }
    }
    return kImpliedRelativeNoise * peak;
}

Rgbd below_zero_allowance(const Sample& s, double implied_noise) {
    Rgbd a;
    for (int c = 0; c < 3; ++c) {
        const double sigma =
            s.sigma[c] > 0 && std::isfinite(s.sigma[c]) ? s.sigma[c] : implied_noise;
        a[c] = std::min(kBelowZeroLimit, kBelowZeroSigmas * sigma);
    }
    return a;
}

std::string below_zero_reason(int channel, double v, double allowance, bool sigma_given) {
    if (!(v < -allowance)) {
        return {};
    }
    char rule[120];
    if (sigma_given) {
        std::snprintf(rule, sizeof rule, "%g x its sigma", kBelowZeroSigmas);
    } else {
        std::snprintf(rule,
                      sizeof rule,
                      "%g x the noise a dataset without sigma implies, %g of its largest value",
                      kBelowZeroSigmas,
                      kImpliedRelativeNoise);
    }
    char buf[300];
    std::snprintf(buf,
                  sizeof buf,
                  "%s = %.17g below zero beyond its noise (allowed down to -%.3g: %s; never "
                  "below -%g)",
                  kColNames[kR + channel],
                  v,
                  allowance,
                  rule,
                  kBelowZeroLimit);
    return buf;
}

std::string validate_sample(const Sample& s, const Rgbd& allowance) {
    for (int c = 0; c < 3; ++c) {
        if (std::isfinite(s.value[c]) && s.value[c] < 0) {
            if (!(s.value[c] >= -allowance[c])) {
                return below_zero_reason(c, s.value[c], allowance[c], s.sigma[c] > 0);
            }
        }
    }
    Sample lifted = s;
    for (int c = 0; c < 3; ++c) {
        if (std::isfinite(s.value[c]) && s.value[c] < 0) {
            lifted.value[c] = 0;  // within its noise: checked as the zero it measures
        }
    }
    return validate_sample(lifted);
}

}  // namespace gonio::brdf
