#pragma once

// Rig time: the seconds a rig spends on a campaign, motion, settling, exposure and readout, as its
// kinematics and its camera spend them (not the wall clock, which a virtual rig's time scale
// compresses and a slow computer stretches). A move lasts as long as its slowest axis's
// trapezoidal profile (kinematics.h: trapezoid_time), then the slowest-settling axis that moved
// settles; an exposure lasts its exposure time, and each frame is then read out (the rig
// description's camera.readout_ms).

#include <array>
#include <cstddef>

#include "gonio/acquisition/shared/kinematics.h"

namespace gonio::acquisition {

/// Rig seconds by kind.
struct RigTime {
    double motion_s = 0;
    double settle_s = 0;
    double exposure_s = 0;
    double readout_s = 0;
    double total_s() const { return motion_s + settle_s + exposure_s + readout_s; }
    RigTime& operator+=(const RigTime& o);
};

/// Motion and settle of one move from `a` to `b`: an axis moves when its position changes by more
/// than `min_step_rad`.
RigTime move_rig_time(const brdf::RigPosed& a,
                      const brdf::RigPosed& b,
                      const std::array<AxisDynamics, kNumAxes>& dyn,
                      double min_step_rad = 1e-7);

class RigClock {
  public:
    RigClock(const std::array<AxisDynamics, kNumAxes>& dyn, double readout_s)
        : dyn_(dyn), readout_s_(readout_s) {}
    /// A move (and its settling).
    void move(const brdf::RigPosed& from, const brdf::RigPosed& to);
    /// A homing move of axis k from `from_rad` to its zero.
    void home(int k, double from_rad);
    /// A fly scan's sweep of axis k over `d_rad` at cruise speed `speed` (its trapezoid, the
    /// drive's acceleration); its exposures and readouts happen during it and add nothing.
    void sweep(int k, double d_rad, double speed);
    /// Exposures: their summed exposure time and the frames read out.
    void expose(double exposure_s, std::size_t frames);
    const RigTime& spent() const { return spent_; }

  private:
    std::array<AxisDynamics, kNumAxes> dyn_;
    double readout_s_;
    RigTime spent_;
};

}  // namespace gonio::acquisition
