#pragma once

// Calibrated capture: from frames to a dark-subtracted signal rate (counts per microsecond at unit
// gain) over the sample's region of interest, with its uncertainty. Pure functions on frames here;
// the device loop (auto exposure, bracketing, dark cache) is capture_session.h.
//
// Frame model (docs/calibration.md): counts c = black + g * (rate_e * t + dark_e * t + noise), so
// after subtracting a dark frame of the same exposure and gain, (c - c_dark) / (t * g) estimates
// the signal rate; pixels at or above the saturation level carry no information and are excluded.

#include <cstdint>
#include <map>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"
#include "gonio/devices/camera.h"

namespace gonio::acquisition {

/// Sensor noise model used next to the pixel statistics (from the camera's data sheet or a photon
/// transfer measurement): variance in counts^2 of a dark-subtracted pixel with mean m counts is
/// m / e_per_count * gain + 2 * read_noise^2 (signal shot noise plus read noise of frame and dark).
struct NoiseModel {
    double e_per_count = 1.0;      ///< Electrons per count at unit gain (0 = unknown).
    double read_noise_counts = 0;  ///< Read noise, counts rms.
};

/// The sample's region of interest on the sensor, in pixels (inclusive x, y; width, height > 0).
struct PixelRoi {
    int x = 0, y = 0, width = 0, height = 0;
};

/// Statistics of one frame (or a merged rate image) over the ROI.
struct RoiStats {
    brdf::Rgbd mean = brdf::Rgbd::Zero();   ///< Per channel (mono frames: the same value thrice).
    brdf::Rgbd sigma = brdf::Rgbd::Zero();  ///< One-sigma uncertainty of the mean.
    double high_fraction = 0;   ///< 99th percentile of (counts - black) / (saturation - black).
    double low_fraction = 0;    ///< 1st percentile, same scale.
    std::size_t valid = 0;      ///< Pixels used.
    std::size_t saturated = 0;  ///< Pixels at or above the saturation level.
};

/// Dark-subtracted ROI statistics of a raw frame. `dark` is a float image of the same size (the
/// mean dark frame, counts) or empty (then the black level is subtracted). Saturated pixels are
/// excluded from the mean; the uncertainty is the larger of the pixel scatter / sqrt(N) and the
/// noise model's prediction / sqrt(N). Errors: empty ROI, ROI outside the frame, unsupported pixel
/// type, every pixel saturated.
Expected<RoiStats> roi_stats(const devices::Frame& f,
                             const cv::Mat& dark,
                             const PixelRoi& roi,
                             const NoiseModel& noise);

/// Result of a (possibly single-exposure) measurement: the signal rate at unit gain, counts/us.
struct SignalRate {
    brdf::Rgbd rate = brdf::Rgbd::Zero();
    brdf::Rgbd sigma = brdf::Rgbd::Zero();
    bool saturated = false;  ///< Some ROI pixels saturated even at the shortest exposure.
    bool hdr = false;        ///< Merged from more than one exposure.
    double exposure_us = 0;  ///< Longest exposure used.
    std::size_t pixels = 0;  ///< ROI pixels merged.
};

/// HDR merge of an exposure bracket, per pixel: each frame k gives the rate r_k = (c - d_k) / (t_k
/// g_k) (counts per microsecond at unit gain) where its pixel is below the saturation level; the
/// rates of a pixel combine with weights t_k g_k (inverse variance when shot noise dominates, whose
/// variance in rate units falls as 1 / (t g)). A pixel saturated in every frame keeps its shortest
/// frame's (clipped) rate and the result is flagged saturated (a lower bound). The ROI mean of the
/// merged rates is returned; its uncertainty is the larger of the pixel scatter / sqrt(N) and the
/// noise model's prediction for the longest frame / sqrt(N). `darks[k]` is the float dark frame of
/// frame k. Errors: empty bracket, mismatched sizes, ROI outside the frames, non-finite pixels.
Expected<SignalRate> merge_hdr(const std::vector<devices::Frame>& frames,
                               const std::vector<cv::Mat>& darks,
                               const PixelRoi& roi,
                               const NoiseModel& noise);

/// Auto exposure: the exposure that puts the ROI's 99th percentile at `target` of the usable range,
/// from a shot at `exposure_us` whose 99th percentile sits at `high_fraction` (the response is
/// linear). A saturated shot (high_fraction >= 1) gives no scale: the exposure is divided by 8.
/// A shot with no signal (high_fraction <= 1e-6) multiplies it by 8. Clamped to [min_us, max_us].
double next_exposure_us(
    double exposure_us, double high_fraction, double target, double min_us, double max_us);

}  // namespace gonio::acquisition
