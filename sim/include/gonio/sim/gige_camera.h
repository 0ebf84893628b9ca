#pragma once

// The simulated GigE Vision camera's device logic: bootstrap and feature registers, its own
// GenICam XML in device memory, GVCP command handling with the control-channel privilege and the
// heartbeat, and frame rendering from the ground-truth BRDF and the rig's SceneState through the
// EMVA sensor model. No sockets here (gige_server.h carries the bytes); time is passed in, so the
// heartbeat rules can be exercised without waiting.

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "gonio/brdf/brdf.h"
#include "gonio/devices/camera.h"
#include "gonio/devices/gvcp.h"
#include "gonio/sim/camera_scene.h"
#include "gonio/sim/sensor_model.h"

namespace gonio::sim {

/// How the XML names the exposure feature.
enum class ExposureNaming {
    kSfnc,  ///< "ExposureTime" (SFNC 2.x)
    kAbs,   ///< "ExposureTimeAbs" (the older GigE Vision cameras' name)
};

struct GigeCameraConfig {
    SensorParams sensor;
    std::string vendor = "gonio";
    std::string model = "SimCam GigE";
    std::string serial = "SIM0001";
    std::string device_version = "1.0";
    ExposureNaming exposure_naming = ExposureNaming::kSfnc;
    /// Heartbeat timeout at power-up, ms (the host may write another).
    std::uint32_t heartbeat_timeout_ms = 3000;
    /// Stream packet size at power-up (SCPS, bytes including IP/UDP/GVSP headers).
    std::uint32_t packet_size = 8228;
    /// Temperatures the device reports (DeviceTemperatureSelector Sensor / Mainboard), deg C.
    double sensor_temperature_c = 40.5;
    double mainboard_temperature_c = 35.25;
};

/// Renders the radiance (CV_32F, W m^-2 sr^-1, roi.height x roi.width) the sensor sees in the
/// region `roi` (full-sensor coordinates) of a `sensor_width` x `sensor_height` sensor, for the
/// BRDF in the beam and the rig state sampled at the exposure. The default is the point-mode
/// flat patch (camera_render.h: render_scene); sphere_imaging.h renders a sphere.
using RadianceFn = std::function<cv::Mat(const brdf::Brdf& f,
                                         const SceneState& state,
                                         int sensor_width,
                                         int sensor_height,
                                         const devices::Roi& roi)>;

/// A host on the network: IPv4 address (host order) and UDP port.
struct HostId {
    std::uint32_t ip = 0;
    std::uint16_t port = 0;
    bool operator==(const HostId& o) const { return ip == o.ip && port == o.port; }
    bool operator!=(const HostId& o) const { return !(*this == o); }
};

/// Where and how to send the stream (from SCDA, SCP, SCPS).
struct StreamTarget {
    std::uint32_t ip = 0;  ///< host order
    std::uint16_t port = 0;
    std::uint32_t packet_size = 0;
    std::uint32_t packet_delay_ticks = 0;
};

/// One rendered frame, ready to be cut into GVSP packets.
struct RenderedFrame {
    std::uint16_t block_id = 0;
    std::uint64_t timestamp_ns = 0;
    std::uint32_t pixel_format = 0;
    int width = 0, height = 0, offset_x = 0, offset_y = 0;
    std::vector<std::uint8_t> payload;
    /// The settings it was exposed with.
    ExposureSettings settings;
};

/// Faults armed for the stream.
struct GigeFaults {
    /// Every Nth packet of a block (counting from packet 1) is not sent the first time (0 = off).
    int drop_every_nth_packet = 0;
    /// Dropped packets are not resent either (the host must report the frame incomplete).
    bool refuse_resend = false;
    /// The camera is gone: no acknowledges, no stream.
    bool disappeared = false;
    /// The next N frames are exposed but none of their packets is sent or held for resend (the
    /// host sees a missing frame, as when a cable is pulled for one frame time).
    int drop_frames = 0;
};

class GigeCamera {
  public:
    using Clock = std::chrono::steady_clock;

    /// `brdf` may be null (renders a black scene); `scene` may be empty (default SceneState).
    GigeCamera(GigeCameraConfig config, std::shared_ptr<const brdf::Brdf> brdf, SceneFn scene);
    ~GigeCamera();
    GigeCamera(const GigeCamera&) = delete;
    GigeCamera& operator=(const GigeCamera&) = delete;

    /// Handles one GVCP datagram from `from` at time `now`; returns the acknowledge to send, if
    /// any (none when no acknowledge is requested, for PACKETRESEND, or when the camera is gone).
    /// A PACKETRESEND is returned through `resend`.
    std::optional<devices::gvcp::Bytes> handle_gvcp(
        const std::uint8_t* bytes,
        std::size_t size,
        const HostId& from,
        Clock::time_point now,
        std::optional<devices::gvcp::PacketResend>* resend = nullptr);
    /// Releases control when the primary application has been silent for longer than the
    /// heartbeat timeout (and then stops acquisition and closes the stream channel). Returns true
    /// when control was released now.
    bool check_heartbeat(Clock::time_point now);

    /// Renders the next frame when one is due (continuous acquisition paced by
    /// AcquisitionFrameRate, or a queued software trigger); nothing otherwise. `next_due` receives
    /// when to ask again in continuous mode.
    std::optional<RenderedFrame> next_frame(Clock::time_point now, Clock::time_point* next_due);
    /// The stream destination, or nothing while the channel is closed or acquisition stopped.
    std::optional<StreamTarget> stream_target() const;
    /// True while frames may be due (acquisition running and a stream destination set).
    bool acquiring() const;

    void set_faults(const GigeFaults& f);
    GigeFaults faults() const;
    /// True (and one fewer frame left to drop) when the drop_frames fault claims the next frame.
    bool take_frame_drop();
    void set_brdf(std::shared_ptr<const brdf::Brdf> brdf);
    void set_scene(SceneFn scene);
    /// The stages' path during each exposure (fly scans): called with the exposure time after
    /// the scene is taken. Set it before the camera is used.
    void set_scene_path(ScenePathFn path) { scene_path_ = std::move(path); }
    /// Line-triggered exposures (TriggerSource Line1): the scene at the exposure's start and its
    /// path from there (RigWorld::scene_at, fill_path_at). Set them before the camera is used.
    void set_line_scene(std::function<SceneState(Clock::time_point)> scene,
                        std::function<void(Clock::time_point, double, SceneState*)> path) {
        line_scene_ = std::move(scene);
        line_path_ = std::move(path);
    }
    /// A pulse on the trigger input Line1, rising at `rising` and falling `width` later (the
    /// instants the pulse happened, whenever it is delivered). With TriggerMode On and
    /// TriggerSource Line1 during acquisition, an exposure starts at the edge TriggerActivation
    /// names: `on_expose` is called with its start and length (seconds) before the frame is
    /// queued, and true returned; otherwise the pulse is ignored.
    bool line_pulse(Clock::time_point rising,
                    Clock::duration width,
                    const std::function<void(Clock::time_point, double)>& on_expose);
    /// Line pulses that started an exposure.
    std::uint64_t line_frames() const;
    /// Replaces the radiance renderer (an empty function restores the flat-patch default). Frames
    /// exposed from then on use it.
    void set_renderer(RadianceFn renderer);
    /// Sets the source port written to SCSP (the server's stream socket).
    void set_stream_source_port(std::uint16_t port);
    const GigeCameraConfig& config() const { return config_; }
    const std::string& xml() const { return xml_; }
    std::uint64_t frames_rendered() const;
    /// Sum of the exposure times of the frames rendered, seconds (the rig time the sensor spent
    /// integrating).
    double exposure_s_rendered() const;
    ExposureSettings exposure_settings() const;
    /// The primary application, when one holds control.
    std::optional<HostId> controller() const;

  private:
    struct State;
    devices::gvcp::Status read_reg_locked(std::uint32_t address, std::uint32_t* value) const;
    devices::gvcp::Status write_reg_locked(std::uint32_t address,
                                           std::uint32_t value,
                                           const HostId& from,
                                           Clock::time_point now);
    devices::gvcp::Status read_mem_locked(std::uint32_t address,
                                          std::size_t count,
                                          devices::gvcp::Bytes* out) const;
    std::optional<devices::gvcp::Status> read_bootstrap_reg_locked(std::uint32_t address,
                                                                   std::uint32_t* value) const;
    std::optional<devices::gvcp::Status> read_feature_reg_locked(std::uint32_t address,
                                                                 std::uint32_t* value) const;
    std::optional<devices::gvcp::Status> write_bootstrap_reg_locked(std::uint32_t address,
                                                                    std::uint32_t value,
                                                                    const HostId& from,
                                                                    Clock::time_point now);
    std::optional<devices::gvcp::Status> write_image_reg_locked(std::uint32_t address,
                                                                std::uint32_t value);
    std::optional<devices::gvcp::Status> write_acquisition_reg_locked(std::uint32_t address,
                                                                      std::uint32_t value,
                                                                      Clock::time_point now);
    devices::gvcp::Status write_mem_locked(const devices::gvcp::MemWrite& w,
                                           const HostId& from,
                                           Clock::time_point now,
                                           std::uint16_t* written);
    /// READREG's registers in order into *values, up to the first failure (its status).
    devices::gvcp::Status read_regs_locked(const std::vector<std::uint32_t>& addresses,
                                           bool is_controller,
                                           std::vector<std::uint32_t>* values) const;
    /// WRITEREG's pairs in order, up to the first failure (its status); *index: those written.
    devices::gvcp::Status write_regs_locked(
        const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
        bool others_read_only,
        const HostId& from,
        Clock::time_point now,
        std::uint16_t* index);
    void release_control_locked();
    std::uint64_t ticks_locked(Clock::time_point now) const;

    GigeCameraConfig config_;
    std::string xml_;
    mutable std::mutex mutex_;
    std::shared_ptr<const brdf::Brdf> brdf_;
    SceneFn scene_;
    ScenePathFn scene_path_;
    std::function<SceneState(Clock::time_point)> line_scene_;
    std::function<void(Clock::time_point, double, SceneState*)> line_path_;
    RadianceFn renderer_;
    std::unique_ptr<State> state_;
    GigeFaults faults_;
    SensorModel sensor_;
};

/// The GenICam XML the simulated camera serves (schema 1.1, big-endian registers).
std::string gige_camera_xml(const GigeCameraConfig& config);

/// Device memory map of the simulated camera (exposed for the conformance tests).
namespace gige_map {
inline constexpr std::uint32_t kFeatureBase = 0x00010000;
/// Holds the address of the region-of-interest block (read through pAddress).
inline constexpr std::uint32_t kRoiBasePointer = kFeatureBase + 0x00;
inline constexpr std::uint32_t kRoiBlock = 0x00010100;  ///< Width, Height, OffsetX, OffsetY
inline constexpr std::uint32_t kSensorWidth = kFeatureBase + 0x10;
inline constexpr std::uint32_t kSensorHeight = kFeatureBase + 0x14;
inline constexpr std::uint32_t kPixelFormat = kFeatureBase + 0x18;
inline constexpr std::uint32_t kExposureTicks = kFeatureBase + 0x1C;   ///< 100 ns ticks
inline constexpr std::uint32_t kExposureTickNs = kFeatureBase + 0x20;  ///< RO: 100
inline constexpr std::uint32_t kGainSelector = kFeatureBase + 0x24;
inline constexpr std::uint32_t kGainTable = kFeatureBase + 0x28;  ///< [selector] 0.01 dB units
/// StructReg: bit 0 TriggerMode, bits 15..8 TriggerSource (0 Software, 1 Line1), bits 23..16
/// TriggerActivation (0 RisingEdge, 1 FallingEdge), bits 31..24 TriggerSelector (0 FrameStart).
inline constexpr std::uint32_t kTriggerControl = kFeatureBase + 0x30;
inline constexpr std::uint32_t kTriggerSoftware = kFeatureBase + 0x34;
inline constexpr std::uint32_t kAcquisitionStart = kFeatureBase + 0x38;
inline constexpr std::uint32_t kAcquisitionStop = kFeatureBase + 0x3C;
/// Bit 0 TLParamsLocked, bits 15..8 AcquisitionMode (0 Continuous, 1 SingleFrame).
inline constexpr std::uint32_t kAcquisitionControl = kFeatureBase + 0x40;
inline constexpr std::uint32_t kFrameRate = kFeatureBase + 0x44;   ///< IEEE 754 binary32, Hz
inline constexpr std::uint32_t kBlackLevel = kFeatureBase + 0x48;  ///< IEEE 754 binary32, DN
inline constexpr std::uint32_t kTemperatureSelector = kFeatureBase + 0x4C;
inline constexpr std::uint32_t kTemperatureTable = kFeatureBase + 0x50;  ///< [selector] 1/16 C
inline constexpr std::uint32_t kFeatureEnd = 0x00010200;
inline constexpr std::uint32_t kXmlAddress = 0x00100000;
}  // namespace gige_map

}  // namespace gonio::sim
