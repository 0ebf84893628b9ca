#pragma once

// Any GenICam camera (GigE Vision or USB3 Vision) through Aravis, which implements GenICam, GVCP/
// GVSP and USB3 Vision. The GLib/Aravis types stay inside the implementation.
//
// Features are looked up by their SFNC names with the fallbacks real cameras use:
// - exposure: ExposureTime, else ExposureTimeAbs (both Float, microseconds unless the node states
//   another time unit), else ExposureTimeRaw scaled by ExposureTimeBaseAbs (microseconds);
// - gain: Gain (Float, in the node's unit, dB by SFNC), else GainRaw (Integer, raw units);
// - capture: TriggerMode/TriggerSource=Software/TriggerSoftware when the camera has them, else one
//   AcquisitionStart per frame in AcquisitionMode SingleFrame;
// - TLParamsLocked is set to 1 before AcquisitionStart and back to 0 after AcquisitionStop.
// A feature that is missing gives an error naming the feature and the camera.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gonio/devices/camera.h"

namespace gonio::devices {

/// One camera Aravis found.
struct AravisDeviceEntry {
    std::string id;        ///< Aravis device id ("Basler-21234567"), opened as "aravis:ID"
    std::string protocol;  ///< "GigEVision", "USB3Vision"
    std::string vendor;
    std::string model;
    std::string serial;
    std::string address;  ///< IP address (GigE) or USB bus path
    std::string physical_id;
};

/// Cameras Aravis finds (GigE Vision discovery broadcast and USB3 Vision on libusb). A USB3 Vision
/// camera without access permission is not among them: see list_usb_devices().
Expected<std::vector<AravisDeviceEntry>> list_aravis_devices();

struct AravisOptions {
    int n_buffers = 4;          ///< stream buffers, each sized from PayloadSize
    bool packet_resend = true;  ///< GigE Vision: ask the camera to resend lost packets
    /// GigE Vision: the camera-side heartbeat timeout in ms (0 = leave the camera's value).
    int heartbeat_timeout_ms = 0;
};

/// What the stream had to put up with, since the camera was opened.
struct AravisStreamStats {
    std::uint64_t frames_completed = 0;   ///< frames handed out complete
    std::uint64_t frames_incomplete = 0;  ///< frames that arrived with missing packets or aborted
    std::uint64_t frames_missing = 0;     ///< triggered or expected frames that never arrived
    std::uint64_t resent_packets = 0;     ///< GigE Vision packets recovered by resend
    std::uint64_t missing_packets = 0;    ///< GigE Vision packets never recovered
    std::uint64_t underruns = 0;          ///< frames the stream dropped for want of a free buffer
    std::uint64_t buffers_recycled = 0;   ///< buffers returned empty (status cleared), reused
    std::uint64_t streams_opened = 0;     ///< streams created (one more after every failed capture)
    /// Frames a triggered capture set aside because the camera stamped them before its trigger:
    /// the late frame of an earlier capture that timed out (only with a timestamp latch).
    std::uint64_t frames_stale = 0;
};

/// How exposure is set on this camera.
struct ExposureFeature {
    std::string name;        ///< ExposureTime, ExposureTimeAbs or ExposureTimeRaw
    std::string unit;        ///< the node's unit ("us", "ms", "" = microseconds by SFNC)
    double us_per_unit = 1;  ///< microseconds per feature unit
    double min_us = 0, max_us = 0;
};

/// How gain is set on this camera.
struct GainFeature {
    std::string name;  ///< Gain or GainRaw; empty when the camera has no gain
    std::string unit;  ///< "dB", or "raw" for GainRaw
    double min = 0, max = 0;
};

class AravisCamera : public Camera {
  public:
    /// Opens the camera Aravis calls `device_id` (as `arv-tool-0.8` lists it; an IP address also
    /// works for GigE Vision).
    static Expected<std::unique_ptr<AravisCamera>> open_id(const std::string& device_id,
                                                           AravisOptions options = {});
    /// Opens the GigE Vision camera at HOST (name or IPv4 address) directly, without discovery.
    static Expected<std::unique_ptr<AravisCamera>> open_gige(const std::string& host,
                                                             AravisOptions options = {});
    /// Opens the USB3 Vision camera with this serial number.
    static Expected<std::unique_ptr<AravisCamera>> open_u3v(const std::string& serial,
                                                            AravisOptions options = {});
    ~AravisCamera() override;
    AravisCamera(const AravisCamera&) = delete;
    AravisCamera& operator=(const AravisCamera&) = delete;

    Expected<CameraInfo> info() override;
    Expected<void> set_exposure_us(double exposure_us) override;
    Expected<double> exposure_us() override;
    /// Linear gain factor: converted to dB for a Gain in dB; with only GainRaw (no linear scale)
    /// only 1 is accepted and selects GainRaw's minimum.
    Expected<void> set_gain(double gain) override;
    Expected<void> set_pixel_format(PixelFormat f) override;
    Expected<void> set_roi(const Roi& roi) override;
    Expected<Frame> capture(std::chrono::milliseconds timeout) override;
    Expected<void> start_stream() override;
    Expected<Frame> next_frame(std::chrono::milliseconds timeout) override;
    Expected<void> stop_stream() override;
    Expected<void> start_line_stream(const std::string& line) override;

    /// Any PixelFormat entry of the camera by its PFNC name ("Mono12Packed", "BayerRG8").
    Expected<void> set_pixel_format_name(const std::string& name);
    /// Gain in the camera's own unit (GainFeature::unit).
    Expected<void> set_gain_native(double value);
    Expected<ExposureFeature> exposure_feature();
    Expected<GainFeature> gain_feature();
    /// "software trigger" or "single frame".
    std::string trigger_method() const;
    /// The name used in messages: "Aravis Fake (GV01) at gige://127.0.0.1".
    const std::string& name() const;
    /// Names of the camera's available PixelFormat entries.
    Expected<std::vector<std::string>> pixel_formats();
    /// Current value of any feature, as Aravis prints it (for diagnostics).
    Expected<std::string> feature_string(const std::string& feature);
    AravisStreamStats stream_stats() const;

    struct Impl;  ///< Aravis objects; defined in the implementation only.

  private:
    explicit AravisCamera(std::unique_ptr<Impl> impl);
    /// The configured stream's start: the exposure known, stale frames drained, acquisition
    /// started with at least `min_buffers` buffers queued, and the camera marked streaming.
    Expected<void> begin_streaming(int min_buffers);
    std::unique_ptr<Impl> impl_;
};

}  // namespace gonio::devices
