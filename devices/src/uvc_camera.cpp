// UVC/V4L2 webcams through OpenCV's VideoCapture. Frames are 8-bit and usually gamma-encoded and
// processed by the camera: they are marked non-linear.

#include "gonio/devices/uvc_camera.h"

#include <chrono>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

namespace gonio::devices {

namespace {

class UvcCamera : public Camera {
  public:
    UvcCamera(int index, std::unique_ptr<cv::VideoCapture> cap)
        : index_(index), cap_(std::move(cap)) {}

    Expected<CameraInfo> info() override {
        CameraInfo i;
        i.vendor = "UVC";
        i.model = cap_->getBackendName();
        i.serial = "uvc:" + std::to_string(index_);
        i.sensor_width = static_cast<int>(cap_->get(cv::CAP_PROP_FRAME_WIDTH));
        i.sensor_height = static_cast<int>(cap_->get(cv::CAP_PROP_FRAME_HEIGHT));
        i.bit_depth = 8;
        return i;
    }

    // V4L2 takes the absolute exposure in units of 100 us after switching auto exposure off
    // (V4L2_CID_EXPOSURE_ABSOLUTE; OpenCV maps manual mode to the value 1).
    Expected<void> set_exposure_us(double exposure_us) override {
        if (!(exposure_us > 0)) {
            return make_error("uvc:" + std::to_string(index_) + ": exposure_us must be > 0");
        }
        cap_->set(cv::CAP_PROP_AUTO_EXPOSURE, 1);
        if (!cap_->set(cv::CAP_PROP_EXPOSURE, exposure_us / 100.0)) {
            return make_error("uvc:" + std::to_string(index_) + ": the driver refused exposure " +
                              std::to_string(exposure_us) + " us");
        }
        exposure_us_ = exposure_us;
        return {};
    }

    Expected<double> exposure_us() override {
        const double v = cap_->get(cv::CAP_PROP_EXPOSURE);
        if (v > 0) {
            exposure_us_ = v * 100.0;
        }
        return exposure_us_;
    }

    Expected<void> set_gain(double gain) override {
        if (!cap_->set(cv::CAP_PROP_GAIN, gain)) {
            return make_error("uvc:" + std::to_string(index_) + ": the driver refused gain " +
                              std::to_string(gain));
        }
        gain_ = gain;
        return {};
    }

    Expected<void> set_pixel_format(PixelFormat f) override {
        if (f != PixelFormat::kMono8) {
            return make_error("uvc:" + std::to_string(index_) + ": only 8-bit frames (Mono8)");
        }
        return {};
    }

    Expected<void> set_roi(const Roi& roi) override {
        if (roi.x != 0 || roi.y != 0) {
            return make_error("uvc:" + std::to_string(index_) + ": no ROI offsets on UVC");
        }
        if (roi.width > 0) {
            cap_->set(cv::CAP_PROP_FRAME_WIDTH, roi.width);
        }
        if (roi.height > 0) {
            cap_->set(cv::CAP_PROP_FRAME_HEIGHT, roi.height);
        }
        return {};
    }

    Expected<Frame> capture(std::chrono::milliseconds) override {
        cv::Mat bgr;
        if (!cap_->read(bgr) || bgr.empty()) {
            return make_error("uvc:" + std::to_string(index_) + ": no frame from the device");
        }
        cv::Mat grey;
        if (bgr.channels() == 3) {
            cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
        } else {
            grey = bgr;
        }
        Frame f;
        grey.convertTo(f.image, CV_16U);
        f.exposure_us = exposure_us_;
        f.gain = gain_;
        f.timestamp_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                             std::chrono::steady_clock::now().time_since_epoch())
                             .count();
        f.black_level = 0;
        f.saturation_level = 255;
        f.bit_depth = 8;
        f.frame_id = ++frames_;
        f.linear = false;
        return f;
    }

    Expected<void> start_stream() override {
        streaming_ = true;
        return {};
    }
    Expected<Frame> next_frame(std::chrono::milliseconds timeout) override {
        if (!streaming_) {
            return make_error("uvc:" + std::to_string(index_) + ": no stream running");
        }
        return capture(timeout);
    }
    Expected<void> stop_stream() override {
        streaming_ = false;
        return {};
    }

  private:
    int index_;
    std::unique_ptr<cv::VideoCapture> cap_;
    double exposure_us_ = 0;
    double gain_ = 1;
    std::uint64_t frames_ = 0;
    bool streaming_ = false;
};

}  // namespace

const char* uvc_radiometry_warning() {
    return "warning: UVC webcams deliver 8-bit, gamma-encoded, camera-processed frames; they are "
           "not radiometric (Frame::linear = false) and BRDF values derived from them are only "
           "qualitative";
}

Expected<std::unique_ptr<Camera>> open_uvc_camera(int index) {
    auto cap = std::make_unique<cv::VideoCapture>();
    if (!cap->open(index, cv::CAP_ANY) || !cap->isOpened()) {
        return make_error("uvc:" + std::to_string(index) + ": OpenCV could not open video device " +
                          std::to_string(index) + " (is /dev/video" + std::to_string(index) +
                          " present and readable?)");
    }
    return std::unique_ptr<Camera>(new UvcCamera(index, std::move(cap)));
}

}  // namespace gonio::devices
