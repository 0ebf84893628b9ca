#pragma once

// A USB3 Vision camera over any U3vTransport: GenCP control channel with request ids, status
// checks, pending-ack deadline extension and bounded retries; bootstrap registers; the GenICam
// XML from the manifest (plain or zipped); features through the node map; frames through the
// stream channel (leader, payload, trailer checked). Mono8, Mono12 and Mono16.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "gonio/devices/camera.h"
#include "gonio/devices/genicam.h"
#include "gonio/devices/u3v_transport.h"

namespace gonio::devices {

struct U3vOptions {
    /// Attempts for one control transaction whose acknowledge timed out (same request id).
    int max_attempts = 3;
    /// Floor of the acknowledge deadline; the device's Maximum Device Response Time is used when
    /// larger.
    std::chrono::milliseconds ack_timeout{200};
    /// Upper bound on the total time one transaction may take through pending acknowledges.
    std::chrono::milliseconds max_pending_total{10000};
    /// Payload transfer size the host configures in the SIRM.
    std::uint32_t payload_transfer_size = 1u << 20;
};

/// Counters of what the control and stream channels had to recover from.
struct U3vStats {
    std::uint64_t commands = 0;
    std::uint64_t retries = 0;
    std::uint64_t pending_acks = 0;
    std::uint64_t frames = 0;
    std::uint64_t bad_frames = 0;     ///< leader/trailer/payload inconsistent
    std::uint64_t stray_packets = 0;  ///< stream packets skipped while resynchronising
};

class U3vCamera : public Camera {
  public:
    /// Opens the device behind the transport: bootstrap registers, manifest, XML, node map.
    static Expected<std::unique_ptr<U3vCamera>> open(std::unique_ptr<U3vTransport> transport,
                                                     U3vOptions options = {});
    ~U3vCamera() override;

    Expected<CameraInfo> info() override;
    Expected<void> set_exposure_us(double exposure_us) override;
    Expected<double> exposure_us() override;
    Expected<void> set_gain(double gain) override;
    Expected<void> set_pixel_format(PixelFormat f) override;
    Expected<void> set_roi(const Roi& roi) override;
    Expected<Frame> capture(std::chrono::milliseconds timeout) override;
    Expected<void> start_stream() override;
    Expected<Frame> next_frame(std::chrono::milliseconds timeout) override;
    Expected<void> stop_stream() override;

    /// Current gain (linear factor).
    Expected<double> gain();
    /// The node map (feature access by name).
    const genicam::NodeMap& node_map() const { return node_map_; }
    /// The GenICam XML as fetched from the device (unzipped).
    const std::string& xml() const { return xml_; }
    bool xml_was_zipped() const { return xml_zipped_; }
    const U3vStats& stats() const { return stats_; }

    // Raw GenCP memory access (for tools and tests).
    Expected<std::vector<std::uint8_t>> read_memory(std::uint64_t address, std::size_t length);
    Expected<void> write_memory(std::uint64_t address, const std::vector<std::uint8_t>& data);

  private:
    U3vCamera(std::unique_ptr<U3vTransport> transport, U3vOptions options);
    Expected<void> bootstrap();
    Expected<std::vector<std::uint8_t>> transact(const std::vector<std::uint8_t>& command,
                                                 std::uint16_t request_id,
                                                 std::uint16_t expected_ack,
                                                 const std::string& what);
    Expected<void> configure_stream();
    Expected<void> enable_stream(bool on);
    Expected<Frame> receive_frame(std::chrono::milliseconds timeout);
    Expected<void> refresh_settings();

    std::unique_ptr<U3vTransport> transport_;
    U3vOptions options_;
    U3vStats stats_;
    std::uint16_t next_request_id_ = 1;
    std::uint32_t max_cmd_len_ = 1024;
    std::uint32_t max_ack_len_ = 1024;
    std::chrono::milliseconds response_time_{200};
    std::uint64_t sirm_address_ = 0;
    std::uint64_t payload_size_ = 0;
    std::uint32_t transfer_size_ = 0, transfer_count_ = 0, final1_size_ = 0;
    CameraInfo info_;
    std::string xml_;
    bool xml_zipped_ = false;
    genicam::NodeMap node_map_;
    bool streaming_ = false;
    bool stream_enabled_ = false;
    bool trigger_mode_on_ = false;
    // Cached settings stamped on each frame.
    double exposure_us_ = 0;
    double gain_ = 1;
    double black_level_ = 0;
};

}  // namespace gonio::devices
