#pragma once

// The capture side of an image campaign (image_campaign.h, "Per light position and colour
// channel"): the rig reached through the capture function, with its frames checked against the
// camera model and its dark frames cached per exposure; HDR capture of a pixel list by exposure
// bracketing; which pixels a light reaches; the pixels of a pose binned as BRDF samples.

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "gonio/acquisition/image/image_campaign.h"

namespace gonio::acquisition::detail {

extern const char* const kChannelName[3];

/// "capture (light arm ..., filter, exposure, shutter ...)": the request in words, for errors.
std::string describe(const CaptureRequest& r);

/// Runs the capture function and checks the frame against the camera model; counts the captures
/// and their exposure time in the result.
class Rig {
  public:
    Rig(const CaptureFn& capture, const ImageCampaignConfig& config, ImageCampaignResult* result)
        : capture_(capture), config_(config), result_(result) {}

    Expected<devices::Frame> grab(const CaptureRequest& r);
    /// Mean of config.dark_frames dark frames at this exposure (cached), CV_64F.
    Expected<cv::Mat> dark(double exposure_us, bool reference);
    /// The pose dark frames are taken at (they need no move of their own).
    void set_pose(double light, double spin = 0, int placement = 0) {
        last_light_ = light;
        last_spin_ = spin;
        last_placement_ = placement;
    }

  private:
    const CaptureFn& capture_;
    const ImageCampaignConfig& config_;
    ImageCampaignResult* result_;
    std::map<double, cv::Mat> dark_;
    double last_light_ = 0;
    double last_spin_ = 0;
    int last_placement_ = 0;
};

/// Per-pixel HDR signal over a pixel list.
struct HdrSamples {
    std::vector<double> signal;    ///< counts / us, dark subtracted
    std::vector<double> variance;  ///< (counts / us)^2
    std::vector<std::uint8_t> ok;  ///< 0 = saturated at every exposure
    int exposures = 0;
};

/// The `wanted` pixels of one channel at the request's pose: the base exposure, then shorter
/// ones for the pixels still saturated (image_campaign.h, "HDR capture").
Expected<HdrSamples> capture_hdr(Rig& rig,
                                 const ImageCampaignConfig& cfg,
                                 CaptureRequest req,
                                 const std::vector<SpherePixel>& pixels,
                                 const std::vector<std::uint8_t>& wanted);

/// One pose in the three colour channels (capture_hdr each); the exposures each took go to
/// rec->exposures, *bracketed is set when any needed a shorter one.
Expected<std::array<HdrSamples, 3>> capture_channels(Rig& rig,
                                                     const ImageCampaignConfig& cfg,
                                                     const CaptureRequest& pose,
                                                     const std::vector<SpherePixel>& pixels,
                                                     const std::vector<std::uint8_t>& lit,
                                                     FrameRecord* rec,
                                                     bool* bracketed);

/// Which pixels the light reaches usefully (theta_i within the limit), counting the others.
std::vector<std::uint8_t> lit_pixels(const std::vector<SpherePixel>& pixels,
                                     const brdf::Vec3d& l,
                                     const ExclusionRules& rules,
                                     PixelCounts* counts);

/// Every lit pixel unsaturated in all channels, as f_r = signal / (C_c cos(theta_i)) with its
/// variance, added to `bins` at the directions `dirs(i)` gives; the pixels left out are counted.
template <class Bins, class Directions>
void bin_pixels(const std::array<HdrSamples, 3>& hdr,
                const std::vector<std::uint8_t>& lit,
                const std::array<double, 3>& calibration,
                Directions dirs,
                Bins* bins,
                PixelCounts* counts) {
    for (std::size_t i = 0; i < lit.size(); ++i) {
        if (!lit[i]) {
            continue;
        }
        if (!hdr[0].ok[i] || !hdr[1].ok[i] || !hdr[2].ok[i]) {
            // Saturated at the shortest exposure in some channel.
            ++counts->saturated;
            continue;
        }
        const auto [wi, wo] = dirs(i);
        const double cos_i = wi.z();
        brdf::Rgbd value;
        brdf::Rgbd var;
        for (int ch = 0; ch < 3; ++ch) {
            const double k = calibration[ch] * cos_i;
            value[ch] = hdr[ch].signal[i] / k;
            var[ch] = hdr[ch].variance[i] / (k * k);
        }
        if (!value.allFinite() || !var.allFinite()) {
            // Cannot happen with cos_i >= cos(max_theta_i) > 0 and finite frames; counted.
            ++counts->nonfinite;
            continue;
        }
        bins->add(wi, wo, value, var);
        ++counts->used;
    }
}

}  // namespace gonio::acquisition::detail
