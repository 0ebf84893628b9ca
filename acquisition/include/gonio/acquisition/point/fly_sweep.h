#pragma once

// One fly-scan sweep on the devices (fly_plan.h): the arm set to the sweep's speed and started
// from its lead-in toward its lead-out; a frame is exposed as the arm's encoder passes each
// configuration's trigger (half the coming exposure before it, so that mid-exposure falls on the
// configuration), and the drive's touch probe latches the positions at the exposure's start and
// end. Two ways to trigger (SweepTrigger):
//   - position compare (the default where the drive has one; docs/profiles.md, "Position
//     compare"): the trigger positions are written to the drive's compare table before the move;
//     its compare output, wired to the camera's trigger input Line1, starts each exposure the
//     instant the encoder passes its entry, whatever the host is doing. The frames stream in as
//     they come and are matched to their configurations by order (the drive's pulse count), or,
//     when some were lost, by the camera's frame ids; the touch probe's latch table gives each
//     pulse's exposure. The exposure is chosen per sweep: the table and the camera are set before
//     the move, and a frame's exposure cannot follow the frame before it without racing its
//     pulse over the network (the next frame can be less than a readout away). It starts from
//     the level carried from the sweep before and ends at the level of the sweep's brightest
//     frame, for the next sweep;
//   - polled (a rig whose axis says "position_compare": false): the host polls the encoder and
//     fires a software trigger as it passes each position; each frame's exposure then follows the
//     last frame's level (auto exposure without stopping). A loaded host misses positions (they
//     are measured standing afterwards).
// Either way each exposure is at most the sweep's smear allows. The frames are calibrated after
// the sweep (the dark frames need the shutter closed); nothing is journaled here, so a sweep cut
// short is run again whole.

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

/// How a sweep's frames are triggered (the rig's axes[].position_compare).
enum class SweepTrigger {
    kPositionCompare,  ///< The drive's compare output on the camera's trigger input Line1.
    kPolled,           ///< The host polls the encoder and fires a software trigger.
};

/// The camera's trigger input the drives' compare outputs are wired to.
inline constexpr const char* kTriggerLine = "Line1";

struct SweepFrames {
    std::vector<FlyFrame> frames;
    /// Members whose trigger the arm had passed (by more than half the way to the next) before
    /// the camera was ready, or that the arm never reached.
    std::vector<std::size_t> missed;
};

/// Runs sweep `s` on `axis` from where it stands (its lead-in): `targets_deg[k]` is member k's
/// angle. `exposure_us` carries the auto exposure from frame to frame (polled) or sweep to sweep.
/// The axis's speed is restored afterwards. Errors: a device error, or the move not ending
/// within `timeout`.
Expected<SweepFrames> run_sweep(devices::Axis& axis,
                                CaptureSession& session,
                                const Sweep& s,
                                const std::vector<double>& targets_deg,
                                double* exposure_us,
                                std::chrono::milliseconds timeout,
                                SweepTrigger trigger = SweepTrigger::kPositionCompare);

/// The next frame's exposure (microseconds) from a frame at `exposure_us` whose ROI reached
/// `high_fraction` of the linear range: auto exposure (next_exposure_us) on the session's ladder,
/// at most `max_us`.
double next_fly_exposure_us(const CaptureSession& session,
                            double exposure_us,
                            double high_fraction,
                            double max_us);

}  // namespace gonio::acquisition
