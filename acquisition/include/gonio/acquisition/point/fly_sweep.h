#pragma once

// One fly-scan sweep on the devices (fly_plan.h): the arm set to the sweep's speed and started
// from its lead-in toward its lead-out; as its encoder passes each configuration's trigger (half
// the coming exposure before it, so that mid-exposure falls on the configuration) a frame is
// taken, and the drive's touch probe gives the positions at the exposure's start and end. Each
// frame's exposure follows the last frame's level (auto exposure without stopping), never longer
// than the sweep's smear allows. The frames are calibrated after the sweep (the dark frames need
// the shutter closed); nothing is journaled here, so a sweep cut short is run again whole.

#include <array>
#include <atomic>
#include <chrono>
#include <vector>

#include "gonio/acquisition/point/capture_session.h"
#include "gonio/acquisition/point/fly_plan.h"
#include "gonio/devices/axis.h"

namespace gonio::acquisition {

/// A frame taken during a sweep.
struct FlyFrame {
    std::size_t member = 0;  ///< Index into Sweep::members.
    devices::Frame frame;
    std::array<double, 2> latch_deg{};  ///< The arm at the exposure's start and end.
};

struct SweepFrames {
    std::vector<FlyFrame> frames;
    /// Members whose trigger the arm had passed (by more than half the way to the next) before
    /// the camera was ready, or that the arm never reached.
    std::vector<std::size_t> missed;
};

/// Runs sweep `s` on `axis` from where it stands (its lead-in): `targets_deg[k]` is member k's
/// angle. `exposure_us` carries the auto exposure from frame to frame and from sweep to sweep.
/// The axis's speed is restored afterwards. Errors: a device error, or the move not ending
/// within `timeout`.
Expected<SweepFrames> run_sweep(devices::Axis& axis,
                                CaptureSession& session,
                                const Sweep& s,
                                const std::vector<double>& targets_deg,
                                double* exposure_us,
                                std::chrono::milliseconds timeout);

/// The next frame's exposure (microseconds) from a frame at `exposure_us` whose ROI reached
/// `high_fraction` of the linear range: auto exposure (next_exposure_us) on the session's ladder,
/// at most `max_us`.
double next_fly_exposure_us(const CaptureSession& session,
                            double exposure_us,
                            double high_fraction,
                            double max_us);

}  // namespace gonio::acquisition
