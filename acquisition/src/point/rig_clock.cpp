#include "gonio/acquisition/point/rig_clock.h"

#include <algorithm>
#include <cmath>

namespace gonio::acquisition {

RigTime& RigTime::operator+=(const RigTime& o) {
    motion_s += o.motion_s;
    settle_s += o.settle_s;
    exposure_s += o.exposure_s;
    readout_s += o.readout_s;
    return *this;
}

RigTime move_rig_time(const brdf::RigPosed& a,
                      const brdf::RigPosed& b,
                      const std::array<AxisDynamics, kNumAxes>& dyn,
                      double min_step_rad) {
    const double from[kNumAxes] = {a.light, a.detector, a.tilt, a.spin};
    const double to[kNumAxes] = {b.light, b.detector, b.tilt, b.spin};
    RigTime t;
    for (int k = 0; k < kNumAxes; ++k) {
        const double d = std::abs(to[k] - from[k]);
        if (d < min_step_rad) {
            continue;  // this axis stays: it neither moves nor settles
        }
        // The axes move at once: the slowest decides, then the slowest to settle.
        t.motion_s = std::max(t.motion_s, trapezoid_time(d, dyn[k].speed, dyn[k].accel));
        t.settle_s = std::max(t.settle_s, dyn[k].settle_s);
    }
    return t;
}

void RigClock::move(const brdf::RigPosed& from, const brdf::RigPosed& to) {
    spent_ += move_rig_time(from, to, dyn_);
}

void RigClock::home(int k, double from_rad) {
    spent_.motion_s += trapezoid_time(std::abs(from_rad), dyn_[k].speed, dyn_[k].accel);
    spent_.settle_s += dyn_[k].settle_s;
}

void RigClock::sweep(int k, double d_rad, double speed) {
    spent_.motion_s += trapezoid_time(std::abs(d_rad), speed, dyn_[k].accel);
}

void RigClock::expose(double exposure_s, std::size_t frames) {
    spent_.exposure_s += exposure_s;
    spent_.readout_s += static_cast<double>(frames) * readout_s_;
}

}  // namespace gonio::acquisition
