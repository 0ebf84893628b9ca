#include "hdr_capture.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gonio/base/check.h"

namespace gonio::acquisition::detail {

const char* const kChannelName[3] = {"red", "green", "blue"};

std::string describe(const CaptureRequest& r) {
    char spin[48] = "";
    if (r.spin_rad != 0) {
        std::snprintf(spin, sizeof spin, ", spin %.3f deg", r.spin_rad * 180 / brdf::kPi);
    }
    char placement[48] = "";
    if (r.placement != 0) {
        std::snprintf(placement, sizeof placement, ", zoomed placement %d", r.placement);
    }
    char buf[260];
    std::snprintf(buf,
                  sizeof(buf),
                  "capture (light arm %.3f deg%s%s, %s filter, %.1f us, shutter %s%s)",
                  r.light_arm_rad * 180 / brdf::kPi,
                  spin,
                  placement,
                  kChannelName[std::clamp(r.channel, 0, 2)],
                  r.exposure_us,
                  r.shutter_open ? "open" : "closed",
                  r.reference ? ", white reference" : "");
    return buf;
}

namespace {

/// A pixel's value as double for any supported frame depth.
double pixel(const cv::Mat& m, int x, int y) {
    switch (m.depth()) {
        case CV_8U:
            return m.at<std::uint8_t>(y, x);
        case CV_16U:
            return m.at<std::uint16_t>(y, x);
        case CV_32F:
            return m.at<float>(y, x);
        case CV_64F:
            return m.at<double>(y, x);
        default:
            GONIO_CHECK_MSG(false, "unsupported frame depth " << m.depth());
    }
    return 0;
}

}  // namespace

Expected<devices::Frame> Rig::grab(const CaptureRequest& r) {
    auto f = capture_(r);
    if (!f) {
        return make_error(describe(r) + ": " + f.error().message);
    }
    ++result_->captures;
    result_->exposure_time_s += r.exposure_us * 1e-6;
    const CameraIntrinsics& k = config_.camera.intrinsics;
    if (f->image.cols != k.width || f->image.rows != k.height || f->image.channels() != 1) {
        return make_error(describe(r) + ": frame is " + std::to_string(f->image.cols) + "x" +
                          std::to_string(f->image.rows) + "x" +
                          std::to_string(f->image.channels()) + ", the camera model says " +
                          std::to_string(k.width) + "x" + std::to_string(k.height) +
                          " single channel");
    }
    if (!f->linear) {
        return make_error(describe(r) + ": frame is not linear (gamma-encoded), not radiometric");
    }
    return f;
}

Expected<cv::Mat> Rig::dark(double exposure_us, bool reference) {
    auto it = dark_.find(exposure_us);
    if (it != dark_.end()) {
        return it->second;
    }
    cv::Mat sum;
    const int n = std::max(1, config_.dark_frames);
    for (int i = 0; i < n; ++i) {
        CaptureRequest r;
        r.light_arm_rad = last_light_;
        r.spin_rad = last_spin_;
        r.placement = last_placement_;
        r.exposure_us = exposure_us;
        r.shutter_open = false;
        r.reference = reference;
        auto f = grab(r);
        if (!f) {
            return tl::unexpected(f.error());
        }
        cv::Mat d;
        f->image.convertTo(d, CV_64F);
        if (sum.empty()) {
            sum = d;
        } else {
            sum += d;
        }
    }
    sum /= n;
    dark_[exposure_us] = sum;
    return sum;
}

Expected<HdrSamples> capture_hdr(Rig& rig,
                                 const ImageCampaignConfig& cfg,
                                 CaptureRequest req,
                                 const std::vector<SpherePixel>& pixels,
                                 const std::vector<std::uint8_t>& wanted) {
    HdrSamples h;
    h.signal.assign(pixels.size(), 0.0);
    h.variance.assign(pixels.size(), 0.0);
    h.ok.assign(pixels.size(), 0);
    std::vector<std::uint8_t> pending = wanted;
    double exposure = cfg.exposure_us;
    const double n_dark = std::max(1, cfg.dark_frames);
    for (int b = 0; b < std::max(1, cfg.max_brackets); ++b) {
        req.exposure_us = exposure;
        req.shutter_open = true;
        auto frame = rig.grab(req);
        if (!frame) {
            return tl::unexpected(frame.error());
        }
        auto dark = rig.dark(exposure, req.reference);
        if (!dark) {
            return tl::unexpected(dark.error());
        }
        ++h.exposures;
        const double black = frame->black_level;
        const double sat = black + cfg.saturation_fraction * (frame->saturation_level - black);
        std::size_t left = 0;
        for (std::size_t i = 0; i < pixels.size(); ++i) {
            if (!pending[i]) {
                continue;
            }
            const double counts = pixel(frame->image, pixels[i].x, pixels[i].y);
            if (counts >= sat) {
                // Saturated at this exposure: try the next, shorter one.
                ++left;
                continue;
            }
            const double d = dark->at<double>(pixels[i].y, pixels[i].x);
            const double var_counts =
                std::max(counts - black, 0.0) / cfg.electrons_per_count +
                cfg.read_noise_counts * cfg.read_noise_counts * (1.0 + 1.0 / n_dark) + 1.0 / 12.0;
            h.signal[i] = (counts - d) / exposure;
            h.variance[i] = var_counts / (exposure * exposure);
            h.ok[i] = 1;
            pending[i] = 0;
        }
        const double next = exposure / cfg.bracket_factor;
        if (left == 0 || next < cfg.min_exposure_us) {
            break;
        }
        exposure = next;
    }
    return h;
}

/// Which pixels the light reaches usefully (theta_i within the limit), counting the others.
std::vector<std::uint8_t> lit_pixels(const std::vector<SpherePixel>& pixels,
                                     const brdf::Vec3d& l,
                                     const ExclusionRules& rules,
                                     PixelCounts* counts) {
    const double cos_max_i = std::cos(rules.max_theta_i);
    std::vector<std::uint8_t> lit(pixels.size(), 0);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        const double cos_i = pixels[i].normal.dot(l);
        if (cos_i <= 0) {
            // In the sphere's own shadow.
            ++counts->shadow;
        } else if (cos_i < cos_max_i) {
            // Lit at a grazing angle: too sensitive to the normal's error.
            ++counts->grazing_light;
        } else {
            lit[i] = 1;
        }
    }
    return lit;
}

/// One pose in the three colour channels (capture_hdr each); the exposures each took go to
/// rec->exposures, *bracketed is set when any needed a shorter one.
Expected<std::array<HdrSamples, 3>> capture_channels(Rig& rig,
                                                     const ImageCampaignConfig& cfg,
                                                     const CaptureRequest& pose,
                                                     const std::vector<SpherePixel>& pixels,
                                                     const std::vector<std::uint8_t>& lit,
                                                     FrameRecord* rec,
                                                     bool* bracketed) {
    std::array<HdrSamples, 3> hdr;
    *bracketed = false;
    for (int ch = 0; ch < 3; ++ch) {
        CaptureRequest r = pose;
        r.channel = ch;
        auto h = capture_hdr(rig, cfg, r, pixels, lit);
        if (!h) {
            return tl::unexpected(h.error());
        }
        hdr[ch] = std::move(*h);
        rec->exposures[ch] = hdr[ch].exposures;
        *bracketed = *bracketed || hdr[ch].exposures > 1;
    }
    return hdr;
}

}  // namespace gonio::acquisition::detail
