#include "gonio/acquisition/point/calibration.h"

#include <cmath>
#include <string>

namespace gonio::acquisition {

Expected<void> validate(const WhiteCalibration& w) {
    if (!(w.reflectance > 0 && w.reflectance <= 1)) {
        return make_error("white reference: reflectance " + std::to_string(w.reflectance) +
                          " outside (0, 1]");
    }
    if (!(w.cos_theta_w > 0 && w.cos_theta_w <= 1)) {
        return make_error("white reference: cos(theta_w) " + std::to_string(w.cos_theta_w) +
                          " outside (0, 1]");
    }
    for (int c = 0; c < 3; ++c) {
        if (!(std::isfinite(w.rate[c]) && w.rate[c] > 0)) {
            return make_error("white reference: signal rate of channel " + std::to_string(c) +
                              " is " + std::to_string(w.rate[c]) +
                              " (must be > 0: is the lamp on and the standard in the beam?)");
        }
    }
    return {};
}

Expected<BrdfValue> rate_to_brdf(const WhiteCalibration& w,
                                 const brdf::Rgbd& rate,
                                 const brdf::Rgbd& rate_sigma,
                                 double cos_theta_i) {
    if (!(cos_theta_i > 0)) {
        // Light at or below the horizon: the sample receives no irradiance.
        return make_error("cos(theta_i) = " + std::to_string(cos_theta_i) +
                          ": light at or below the sample's horizon");
    }
    if (auto v = validate(w); !v) {
        return tl::unexpected(v.error());
    }
    const double geometry = (w.reflectance / brdf::kPi) * w.cos_theta_w / cos_theta_i;
    BrdfValue out;
    for (int c = 0; c < 3; ++c) {
        const double k = geometry / w.rate[c];
        out.value[c] = rate[c] * k;
        out.sigma[c] = rate_sigma[c] * k;
        if (!std::isfinite(out.value[c]) || !std::isfinite(out.sigma[c])) {
            return make_error("non-finite BRDF value from rate " + std::to_string(rate[c]));
        }
    }
    return out;
}

}  // namespace gonio::acquisition
