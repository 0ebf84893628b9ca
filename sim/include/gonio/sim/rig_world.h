#pragma once

// The virtual rig's world: what the simulated camera sees, derived from the simulated motor
// controllers' stage angles through the four-axis geometry (gonio/brdf/rig_geometry.h), the lamp
// shutter coil, the reference changer coil that puts the white standard in place of the sample, and
// the colour filter coils.

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "gonio/brdf/brdf.h"
#include "gonio/brdf/rig_geometry.h"
#include "gonio/sim/camera_scene.h"
#include "gonio/sim/instrument_errors.h"
#include "gonio/sim/motor_controller_server.h"

namespace gonio::sim {

/// Which unit drives which stage; which unit carries the shutter and the reference changer coils
/// (0 = none).
struct RigUnits {
    int light = 1;
    int detector = 2;
    int tilt = 3;
    int spin = 4;
    int shutter = 5;
    int reference_changer = 0;
    /// Units whose coil puts the red, green, blue filter in front of the camera (0 = no filter
    /// wheel: the camera sees the unfiltered mean of R, G and B).
    std::array<int, 3> filters{0, 0, 0};
    /// Units whose coil switches in a zoomed camera placement, in the rig's order (the lowest
    /// one on wins; none on: the wide view).
    std::vector<int> placements;
};

/// A BRDF that is the sample's or the white standard's, whichever is in the beam.
class MountedBrdf : public brdf::Brdf {
  public:
    MountedBrdf(std::shared_ptr<const brdf::Brdf> sample, double white_reflectance);
    brdf::Rgbd eval(const brdf::Vec3d& wi, const brdf::Vec3d& wo) const override;
    bool isotropic() const override;
    std::string describe() const override;
    void set_white(bool white) { white_.store(white); }
    bool white() const { return white_.load(); }

  private:
    std::shared_ptr<const brdf::Brdf> sample_;
    double white_reflectance_;
    std::atomic<bool> white_{false};
};

class RigWorld {
  public:
    /// `server` must outlive the world.
    RigWorld(const MotorControllerServer* server,
             RigUnits units,
             std::shared_ptr<MountedBrdf> mounted,
             double irradiance_w_m2);

    /// The state at this instant: wi, wo from the stage angles (radians = degrees * pi / 180 of
    /// the physical load angles), the shutter, the irradiance times the lamp factor, the filter
    /// (channel c's unit vector while filter c's coil is on, the lowest such c; the unfiltered
    /// mean while none is); also switches the mounted BRDF to the white standard while the
    /// changer coil is on.
    SceneState scene() const;
    SceneFn scene_fn() const;
    /// The state at the instant `at` (past or future): the stages where their profiles had them
    /// then (the line-triggered exposure of a compare pulse); the coils as they are now.
    SceneState scene_at(std::chrono::steady_clock::time_point at) const;
    /// fill_path for an exposure starting at `at`; the drives' touch probes latch its edges.
    void fill_path_at(std::chrono::steady_clock::time_point at,
                      double exposure_s,
                      SceneState* scene) const;
    /// Point mode, fly scans: when a stage moves during an exposure of `exposure_s` that starts
    /// now, fills scene->path with the directions along the stages' trajectory (their profiles as
    /// the drives run them, sampled by composite Gauss-Legendre quadrature in time: pieces of at
    /// most kPathPieceRad of stage travel, kPathNodesPerPiece nodes each); leaves it empty while
    /// every stage stands.
    void fill_path(double exposure_s, SceneState* scene) const;
    ScenePathFn scene_path_fn() const;
    /// Longest stage travel of one quadrature piece of an exposure's path: 0.1 deg.
    static constexpr double kPathPieceRad = 0.1 * brdf::kPi / 180;
    static constexpr int kPathNodesPerPiece = 4;
    /// Multiplies the lamp's irradiance (1 = nominal): simulates lamp drift.
    void set_lamp_factor(double f) { lamp_factor_.store(f); }
    /// Called with the running count (1, 2, ...) at every exposure the camera asks the world
    /// about, before the state is returned: lets tests act at an exact point of a campaign (change
    /// the lamp, stop, kill the process). Set it before the camera is used.
    void set_exposure_hook(std::function<void(std::uint64_t)> hook) { hook_ = std::move(hook); }
    std::uint64_t exposures() const { return exposures_.load(); }
    /// The instrument's errors (instrument_errors.h) from now on: the arms' true directions, the
    /// lamp's fluctuation and drift (with `clock_s`, the rig's simulated seconds), stray light.
    /// Null: the ideal instrument. Set it before the camera is used.
    void set_instrument(std::shared_ptr<const InstrumentErrors> instrument,
                        std::function<double()> clock_s);
    const InstrumentErrors* instrument() const { return instrument_.get(); }

  private:
    using UnitPathFn = std::function<std::vector<double>(int unit, const std::vector<double>&)>;
    /// The scene of the stages at pose `p` (degrees read from the drives, as radians).
    SceneState scene_of(const brdf::RigPosed& p) const;
    /// fill_path's quadrature with the stages' angles from `path` (seconds after the start).
    void fill_path_along(double exposure_s, const UnitPathFn& path, SceneState* scene) const;
    /// Counts the moves of each arm (a new encoder reading since the last exposure is a move).
    std::array<std::uint64_t, 2> arm_moves(double light_rad, double detector_rad) const;
    /// The directions (wi, wo) of a pose, through the instrument's errors when it has them.
    std::pair<brdf::Vec3d, brdf::Vec3d> pose_directions(const brdf::RigPosed& p) const;
    /// The scene's directions and stage angles as the imperfect instrument has them.
    void apply_instrument(const brdf::RigPosed& p, std::uint64_t exposure, SceneState* s) const;

    const MotorControllerServer* server_;
    RigUnits units_;
    std::shared_ptr<MountedBrdf> mounted_;
    double irradiance_;
    std::atomic<double> lamp_factor_{1.0};
    std::function<void(std::uint64_t)> hook_;
    mutable std::atomic<std::uint64_t> exposures_{0};
    std::shared_ptr<const InstrumentErrors> instrument_;
    std::function<double()> clock_s_;
    mutable std::mutex moves_mutex_;
    mutable std::array<double, 2> last_arm_rad_{std::nan(""), std::nan("")};
    mutable std::array<std::uint64_t, 2> moves_{0, 0};
};

}  // namespace gonio::sim
