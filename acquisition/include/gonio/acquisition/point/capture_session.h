#pragma once

// The device side of calibrated capture: auto exposure on a ladder of exposures, dark frames taken
// with the shutter closed and cached per (exposure, gain), exposure bracketing and HDR merge.

#include <functional>
#include <map>
#include <utility>

#include "gonio/acquisition/point/capture.h"
#include "gonio/acquisition/shared/rig_config.h"

namespace gonio::acquisition {

class CaptureSession {
  public:
    /// The camera and shutter stay owned by the caller and must outlive the session.
    CaptureSession(devices::Camera* camera,
                   devices::Light* shutter,
                   const CaptureConfig& cfg,
                   const NoiseModel& noise);

    /// Sets gain and pixel format, reads the sensor size and places the ROI.
    Expected<void> prepare();

    /// One calibrated signal rate at the current geometry (shutter opened for it).
    Expected<SignalRate> measure();

    /// Fly scans: sets the exposure of the next frame taken while an arm moves (set ahead, so that
    /// the trigger sends one command).
    Expected<void> set_moving_exposure(double exposure_us);
    /// Fly scans: one frame at the exposure set by set_moving_exposure (shutter open). Its
    /// exposure and readout overlap the sweep's motion: counted in moving_frames(), not in
    /// frames_taken() or exposure_s_taken().
    Expected<devices::Frame> grab_moving();
    /// Fly scans with a hardware trigger: frames exposed on each pulse of the camera's trigger
    /// input `line` (at the exposure set by set_moving_exposure, shutter open), taken in order
    /// with next_line_frame() (counted as grab_moving's) until stop_line_frames().
    Expected<void> start_line_frames(const std::string& line);
    Expected<devices::Frame> next_line_frame(std::chrono::milliseconds timeout);
    Expected<void> stop_line_frames();
    /// The camera's id of the last frame taken (0 before the first).
    std::uint64_t last_frame_id() const { return last_frame_id_; }
    /// Fly scans: the ROI's level of a frame (black subtracted), for the next frame's exposure.
    Expected<RoiStats> level_of(const devices::Frame& f) const;
    /// Fly scans: the calibrated signal rate of one frame, its dark frame taken (shutter closed,
    /// after the sweep) or reused.
    Expected<SignalRate> rate_of(const devices::Frame& f);
    std::size_t moving_frames() const { return moving_frames_; }
    double moving_exposure_s() const { return moving_exposure_s_; }
    const CaptureConfig& config() const { return cfg_; }

    /// Exposures on the ladder t_min * 2^(k/2): dark frames are reused across measurements.
    double quantise_exposure(double exposure_us) const;
    const PixelRoi& roi() const { return roi_; }
    std::size_t dark_frames_taken() const { return dark_taken_; }
    std::size_t frames_taken() const { return frames_taken_; }
    /// Summed exposure time of the frames taken, seconds (dark frames included).
    double exposure_s_taken() const { return exposure_s_taken_; }
    /// Forgets the cached dark frames (after a camera reconnect).
    void clear_dark_cache() { dark_.clear(); }
    /// Called by measure() with the frame its auto exposure settled on (shutter open, not dark
    /// subtracted); it must return at once.
    void set_frame_observer(std::function<void(const devices::Frame&)> observer) {
        frame_observer_ = std::move(observer);
    }

  private:
    Expected<devices::Frame> grab(double exposure_us);
    /// grab_moving's accounting of a frame taken while an arm moved.
    Expected<devices::Frame> moving_frame(Expected<devices::Frame> f);
    Expected<cv::Mat> dark_for(double exposure_us);
    struct Shot {
        devices::Frame frame;
        cv::Mat dark;
        RoiStats stats;
    };
    Expected<Shot> shot(double exposure_us);

    devices::Camera* camera_;
    devices::Light* shutter_;
    CaptureConfig cfg_;
    NoiseModel noise_;
    PixelRoi roi_;
    double last_exposure_us_ = 0;
    std::map<std::pair<long long, long long>, cv::Mat> dark_;
    std::size_t dark_taken_ = 0;
    std::size_t frames_taken_ = 0;
    double exposure_s_taken_ = 0;
    double moving_exposure_us_ = 0;
    std::size_t moving_frames_ = 0;
    double moving_exposure_s_ = 0;
    std::uint64_t last_frame_id_ = 0;
    std::function<void(const devices::Frame&)> frame_observer_;
};

}  // namespace gonio::acquisition
