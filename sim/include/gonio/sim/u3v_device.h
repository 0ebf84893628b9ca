#pragma once

// The simulated USB3 Vision camera: serves the bytes a real device would (bootstrap registers, a
// manifest and its own GenICam XML, plain or zipped; GenCP acknowledges; stream leader, payload and
// trailer) and renders each frame from the ground-truth BRDF and the rig's SceneState through the
// sensor model. Fault injection for dropped frames, corrupted trailers, slow acknowledges, lost
// acknowledges and a device that disappears.

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "gonio/brdf/brdf.h"
#include "gonio/devices/u3v_transport.h"
#include "gonio/sim/camera_scene.h"
#include "gonio/sim/sensor_model.h"

namespace gonio::sim {

struct U3vDeviceConfig {
    SensorParams sensor;
    std::string vendor = "gonio";
    std::string model = "SimCam U3V";
    std::string serial = "SIM0001";
    bool zipped_xml = false;
    /// Maximum Device Response Time advertised in the ABRM, ms.
    std::uint32_t response_time_ms = 100;
};

/// Faults armed for the next events; each counter is decremented as the fault fires.
struct U3vFaults {
    int drop_frames = 0;       ///< next N frames are never sent
    int corrupt_trailers = 0;  ///< next N trailers have a bad magic
    int pending_acks = 0;      ///< next N commands get a PENDING_ACK before their ack
    std::uint16_t pending_ms = 50;
    int lose_acks = 0;                   ///< next N commands get no acknowledge at all
    int never_answer_after_pending = 0;  ///< next N commands: PENDING_ACK, then nothing
    bool disappeared = false;            ///< the device is gone: no acknowledges, no frames
};

class U3vDevice {
  public:
    /// `brdf` may be null (renders a black scene); `scene` may be empty (default SceneState).
    U3vDevice(U3vDeviceConfig config, std::shared_ptr<const brdf::Brdf> brdf, SceneFn scene);

    /// Handles one command transfer; returns the acknowledge transfers to send (none when the
    /// device is gone or loses the ack).
    std::vector<devices::Bytes> handle_control(const devices::Bytes& command);
    /// Returns the transfers of the next frame when one is due (software trigger fired, or
    /// continuous acquisition running), else nothing.
    std::vector<devices::Bytes> poll_stream();
    /// True while frames are due without a trigger (continuous acquisition).
    bool streaming_continuous() const;

    void set_faults(const U3vFaults& f);
    U3vFaults faults() const;
    void set_brdf(std::shared_ptr<const brdf::Brdf> brdf);
    void set_scene(SceneFn scene);
    const U3vDeviceConfig& config() const { return config_; }
    /// The device's GenICam XML (uncompressed).
    const std::string& xml() const { return xml_; }
    std::uint64_t frames_sent() const;
    /// Current exposure settings (as set through the features).
    ExposureSettings exposure_settings() const;

  private:
    struct State;
    devices::Bytes read_mem(std::uint64_t address, std::size_t length, std::uint16_t* status);
    std::uint16_t write_mem(std::uint64_t address, const devices::Bytes& data);
    std::vector<devices::Bytes> render_frame_locked();

    U3vDeviceConfig config_;
    std::string xml_;
    devices::Bytes xml_file_;
    mutable std::mutex mutex_;
    std::shared_ptr<const brdf::Brdf> brdf_;
    SceneFn scene_;
    std::unique_ptr<State> state_;
    U3vFaults faults_;
    SensorModel sensor_;

  public:
    ~U3vDevice();
};

/// The GenICam XML the simulator serves for a sensor size.
std::string simulated_camera_xml(const U3vDeviceConfig& config);

/// A transport to the device in the same process (synchronous: acknowledges and frames are
/// produced when asked for, so a "timeout" is reported at once).
std::unique_ptr<devices::U3vTransport> make_memory_transport(std::shared_ptr<U3vDevice> device);

/// Makes the device reachable as "u3v-mem:NAME" through devices::open_camera.
void register_in_process_camera(const std::string& name, std::shared_ptr<U3vDevice> device);

}  // namespace gonio::sim
