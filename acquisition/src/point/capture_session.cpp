#include "gonio/acquisition/point/capture_session.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

namespace gonio::acquisition {

CaptureSession::CaptureSession(devices::Camera* camera,
                               devices::Light* shutter,
                               const CaptureConfig& cfg,
                               const NoiseModel& noise)
    : camera_(camera), shutter_(shutter), cfg_(cfg), noise_(noise) {}

Expected<void> CaptureSession::prepare() {
    if (auto r = camera_->set_pixel_format(devices::PixelFormat::kMono16); !r) {
        return r;
    }
    if (auto r = camera_->set_gain(cfg_.gain); !r) {
        return r;
    }
    auto info = camera_->info();
    if (!info) {
        return tl::unexpected(info.error());
    }
    const int w = info->sensor_width;
    const int h = info->sensor_height;
    if (w <= 0 || h <= 0) {
        return make_error("camera reports a sensor of " + std::to_string(w) + "x" +
                          std::to_string(h) + " pixels");
    }
    const int side = std::max(1, static_cast<int>(cfg_.roi_fraction * std::min(w, h)));
    roi_ = PixelRoi{(w - side) / 2, (h - side) / 2, side, side};
    last_exposure_us_ = quantise_exposure(std::sqrt(cfg_.min_exposure_us * cfg_.max_exposure_us));
    dark_.clear();
    return {};
}

double CaptureSession::quantise_exposure(double exposure_us) const {
    const double k = std::round(
        2 * std::log2(std::max(exposure_us, cfg_.min_exposure_us) / cfg_.min_exposure_us));
    double t = cfg_.min_exposure_us * std::pow(2.0, k / 2);
    // The ladder step just below the maximum when the maximum itself is off the ladder.
    while (t > cfg_.max_exposure_us * (1 + 1e-9)) {
        t /= std::sqrt(2.0);
    }
    return t;
}

Expected<devices::Frame> CaptureSession::grab(double exposure_us) {
    if (auto r = camera_->set_exposure_us(exposure_us); !r) {
        return tl::unexpected(r.error());
    }
    auto f = camera_->capture(
        std::chrono::milliseconds(cfg_.timeout_ms + static_cast<int>(exposure_us / 1000)));
    if (!f) {
        return f;
    }
    ++frames_taken_;
    last_frame_id_ = f->frame_id;
    // Rig time: the exposure the camera reports it used (else the one asked for).
    exposure_s_taken_ += (f->exposure_us > 0 ? f->exposure_us : exposure_us) * 1e-6;
    // Beyond the linear range (full well) a pixel is as good as clipped.
    f->saturation_level =
        f->black_level + cfg_.linear_max_fraction * (f->saturation_level - f->black_level);
    if (!f->linear) {
        return make_error(
            "camera frames are not linear (gamma-encoded): no radiometric measurement");
    }
    return f;
}

Expected<void> CaptureSession::set_moving_exposure(double exposure_us) {
    if (auto r = camera_->set_exposure_us(exposure_us); !r) {
        return r;
    }
    moving_exposure_us_ = exposure_us;
    return {};
}

Expected<devices::Frame> CaptureSession::grab_moving() {
    return moving_frame(camera_->capture(
        std::chrono::milliseconds(cfg_.timeout_ms + static_cast<int>(moving_exposure_us_ / 1000))));
}

Expected<void> CaptureSession::start_line_frames(const std::string& line) {
    if (auto r = shutter_->set_shutter_open(true); !r) {
        return r;
    }
    return camera_->start_line_stream(line);
}

Expected<devices::Frame> CaptureSession::next_line_frame(std::chrono::milliseconds timeout) {
    return moving_frame(camera_->next_frame(timeout));
}

Expected<void> CaptureSession::stop_line_frames() {
    return camera_->stop_stream();
}

Expected<devices::Frame> CaptureSession::moving_frame(Expected<devices::Frame> f) {
    if (!f) {
        return f;
    }
    last_frame_id_ = f->frame_id;
    ++moving_frames_;
    if (!(f->exposure_us > 0)) {
        f->exposure_us = moving_exposure_us_;
    }
    moving_exposure_s_ += f->exposure_us * 1e-6;
    f->saturation_level =
        f->black_level + cfg_.linear_max_fraction * (f->saturation_level - f->black_level);
    if (!f->linear) {
        return make_error(
            "camera frames are not linear (gamma-encoded): no radiometric measurement");
    }
    return f;
}

Expected<RoiStats> CaptureSession::level_of(const devices::Frame& f) const {
    return roi_stats(f, cv::Mat(), roi_, noise_);
}

Expected<SignalRate> CaptureSession::rate_of(const devices::Frame& f) {
    auto dark = dark_for(f.exposure_us);
    if (!dark) {
        return tl::unexpected(dark.error());
    }
    return merge_hdr({f}, {*dark}, roi_, noise_);
}

Expected<cv::Mat> CaptureSession::dark_for(double exposure_us) {
    const auto key =
        std::make_pair(std::llround(exposure_us * 1000), std::llround(cfg_.gain * 1e6));
    auto it = dark_.find(key);
    if (it != dark_.end()) {
        return it->second;
    }
    if (auto r = shutter_->set_shutter_open(false); !r) {
        return tl::unexpected(r.error());
    }
    cv::Mat acc;
    for (int k = 0; k < cfg_.dark_frames; ++k) {
        auto f = grab(exposure_us);
        if (!f) {
            // Leave the shutter as the measurement expects it: open.
            (void)shutter_->set_shutter_open(true);
            return tl::unexpected(f.error());
        }
        cv::Mat fl;
        f->image.convertTo(fl, CV_32F);
        if (acc.empty()) {
            acc = fl;
        } else {
            acc += fl;
        }
    }
    acc /= static_cast<double>(cfg_.dark_frames);
    ++dark_taken_;
    if (auto r = shutter_->set_shutter_open(true); !r) {
        return tl::unexpected(r.error());
    }
    dark_[key] = acc;
    return acc;
}

Expected<CaptureSession::Shot> CaptureSession::shot(double exposure_us) {
    auto dark = dark_for(exposure_us);
    if (!dark) {
        return tl::unexpected(dark.error());
    }
    auto f = grab(exposure_us);
    if (!f) {
        return tl::unexpected(f.error());
    }
    if (!(f->exposure_us > 0)) {
        f->exposure_us = exposure_us;
    }
    auto st = roi_stats(*f, *dark, roi_, noise_);
    if (!st) {
        return tl::unexpected(st.error());
    }
    return Shot{*f, *dark, *st};
}

Expected<SignalRate> CaptureSession::measure() {
    if (auto r = shutter_->set_shutter_open(true); !r) {
        return tl::unexpected(r.error());
    }
    double t = last_exposure_us_;
    Shot s;
    // Auto exposure: a linear response needs one correction; a clipped or empty first shot needs a
    // few more. Bounded.
    for (int iter = 0; iter < 6; ++iter) {
        auto sh = shot(t);
        if (!sh) {
            return tl::unexpected(sh.error());
        }
        s = std::move(*sh);
        const double hf =
            s.stats.saturated > 0 ? std::max(s.stats.high_fraction, 1.0) : s.stats.high_fraction;
        // hf is relative to the linear range; 1 = clipped.
        const bool good = hf < 0.95 && hf >= cfg_.target_fraction / cfg_.linear_max_fraction / 2.5;
        const double next =
            quantise_exposure(next_exposure_us(t,
                                               hf,
                                               cfg_.target_fraction / cfg_.linear_max_fraction,
                                               cfg_.min_exposure_us,
                                               cfg_.max_exposure_us));
        if (good || next == t) {
            // Within range, or at an end of the exposure range: nothing better is possible.
            break;
        }
        t = next;
    }
    last_exposure_us_ = t;
    if (frame_observer_) {
        frame_observer_(s.frame);
    }
    std::vector<devices::Frame> frames{s.frame};
    std::vector<cv::Mat> darks{s.dark};
    // HDR: the darkest part of the ROI sits too low on the sensor for its noise: add longer
    // exposures; the pixels that clip there keep the shorter exposures' values.
    double tb = t;
    double low = s.stats.low_fraction;
    while (static_cast<int>(frames.size()) < cfg_.max_brackets && low < cfg_.hdr_low_fraction &&
           s.stats.high_fraction > 0.5 && tb * cfg_.bracket_ratio <= cfg_.max_exposure_us) {
        tb = quantise_exposure(tb * cfg_.bracket_ratio);
        auto sh = shot(tb);
        if (!sh) {
            return tl::unexpected(sh.error());
        }
        low = sh->stats.low_fraction;
        frames.push_back(sh->frame);
        darks.push_back(sh->dark);
    }
    return merge_hdr(frames, darks, roi_, noise_);
}

}  // namespace gonio::acquisition
