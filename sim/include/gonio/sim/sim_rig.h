#pragma once

// The whole virtual rig: simulated motor controllers for the four stages (one Modbus server, one
// unit per drive, the lamp shutter, the reference changer and the colour filters as coils), a
// simulated camera (a GigE Vision device on loopback) rendering the mounted BRDF under
// the rig's geometry, and the world that ties them. It reads the same rig description as
// acquisition (data/rigs/*.json: axes with role, unit, profile; shutter; reference_changer;
// filter_wheel: one coil per colour filter) plus its "sim" section; each drive's position compare
// output is wired to the camera's trigger input Line1:
//   "sim": {"material": "red-plastic" | "brdf": "model.json", "time_scale": 20,
//           "sensor": {"width": 640, "height": 512}, "irradiance_w_m2": 1, "seed": 1,
//           "initial_deg": {"light": 0, "detector": 45}}
// and its "error_budget" (brdf/rig_error_budget.h), from which the virtual instrument draws its
// errors (instrument_errors.h); absent, the reference profile.

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "gonio/base/error.h"
#include "gonio/brdf/rig_error_budget.h"
#include "gonio/sim/gige_camera.h"
#include "gonio/sim/gige_server.h"
#include "gonio/sim/motor_controller_server.h"
#include "gonio/sim/rig_world.h"
#include "gonio/sim/sphere_imaging.h"

namespace gonio::sim {

struct SimRigOptions {
    std::string material;   ///< Named material (overrides the rig's "sim" section).
    std::string brdf_path;  ///< Model JSON or table (overrides material).
    double time_scale = 0;  ///< > 0 overrides.
    /// Address the GigE Vision camera is served on (GVCP port 3956). Empty: a free 127.x.y.z
    /// address of its own (GigeServer::start_on_free_loopback), so that rigs in several processes
    /// never compete for one address.
    std::string camera_ip;
    /// Name the exposure feature ExposureTimeAbs.
    bool exposure_abs = false;
    std::uint64_t seed = 0;  ///< > 0 overrides.
    /// Image mode: the camera on the detector arm sees a sphere of the mounted material
    /// (sphere_imaging.h); its sensor takes the sphere camera's size.
    std::optional<SphereImaging> sphere;
};

class SimRig {
  public:
    /// Builds and starts the rig from a rig description's JSON text.
    static Expected<std::unique_ptr<SimRig>> start(const std::string& rig_json,
                                                   const SimRigOptions& opt = {});
    ~SimRig();
    SimRig(const SimRig&) = delete;
    SimRig& operator=(const SimRig&) = delete;

    std::string motor_address() const;  ///< tcp://127.0.0.1:PORT
    /// gige://ADDRESS of the camera
    std::string camera_address() const;
    std::string describe() const;  ///< Sample, units, addresses.

    MotorControllerServer& motors() { return *motors_; }
    GigeCamera& camera() { return *camera_; }
    GigeServer& camera_server() { return *camera_server_; }
    RigWorld& world() { return *world_; }
    const RigUnits& units() const { return units_; }
    /// The sample's ground truth (not the white standard).
    std::shared_ptr<const brdf::Brdf> sample() const { return sample_; }
    /// The rig description's error budget, which the virtual instrument draws its errors from.
    const brdf::RigErrorBudget& error_budget() const { return budget_; }

    void stop();

  private:
    SimRig() = default;
    /// The wire from the drives' position compare outputs to the camera's trigger input Line1:
    /// delivers each pulse with the instant it happened (the exposure starts then, whenever this
    /// thread gets to run); the pulse's drive latches the exposure's edges.
    void wire_loop();
    std::thread wire_;
    std::atomic<bool> wire_stop_{false};
    double time_scale_ = 1;
    std::unique_ptr<MotorControllerServer> motors_;
    std::shared_ptr<MountedBrdf> mounted_;
    std::shared_ptr<const brdf::Brdf> sample_;
    std::unique_ptr<RigWorld> world_;
    std::shared_ptr<GigeCamera> camera_;
    std::unique_ptr<GigeServer> camera_server_;
    std::string sample_name_;
    RigUnits units_;
    brdf::RigErrorBudget budget_;
};

}  // namespace gonio::sim
