#pragma once

// What the simulated camera looks at, supplied by whoever builds the virtual rig through a
// callback (the rig reads its simulated motor controllers and shutter to fill it in).

#include <functional>
#include <vector>

#include "gonio/brdf/coords.h"
#include "gonio/brdf/exposure_path.h"

namespace gonio::sim {

/// Shape of the sample in front of the detector.
enum class SampleShape {
    kFlatPatch,  ///< point mode: a flat patch filling the field stop (one geometry for all pixels)
    kSphere,     ///< image mode: a sphere imaged by an orthographic camera, one geometry per pixel
};

/// The state of the rig at the moment of an exposure.
struct SceneState {
    /// Direction toward the light, unit, in the sample frame (z = sample normal).
    brdf::Vec3d wi{0, 0, 1};
    /// Direction toward the detector, unit, in the sample frame.
    brdf::Vec3d wo{0, 0, 1};
    /// False while the light's shutter is closed (dark frame: only dark current and noise).
    bool shutter_open = true;
    /// Irradiance of the collimated beam on a plane perpendicular to it, W/m^2.
    double irradiance_w_m2 = 1.0;
    /// Spectral weights of the filter in front of the mono sensor: the pixel sees
    /// filter . f_rgb. (1,0,0) renders the red channel; the default is the mean of R, G and B.
    brdf::Rgbd filter{1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0};
    /// Sample shape. For kSphere, wi and wo are given in the camera-aligned world frame
    /// (camera looking along -wo); see docs/camera.md.
    SampleShape shape = SampleShape::kFlatPatch;
    /// kSphere only: sphere radius as a fraction of min(sensor width, height) / 2.
    double sphere_radius_fraction = 0.9;
    /// Stage angles at the moment of the exposure (rig_geometry.h: physical load angles,
    /// radians), filled in by the rig's world. An image-mode renderer places the light at
    /// brdf::arm_direction(light_arm_rad) and the camera on the detector arm from them; the flat
    /// patch render uses wi and wo only.
    double light_arm_rad = 0;
    double detector_arm_rad = 0;
    double tilt_rad = 0;
    double spin_rad = 0;
    /// Stray light reaching the detector while the shutter is open, W m^-2 sr^-1: added to the
    /// flat patch's radiance (point mode).
    double stray_radiance_w_m2_sr = 0;
    /// Image mode: the camera placement switched in (0: the wide view; k: the rig's k-th zoomed
    /// placement, sphere_imaging.h).
    int placement = 0;
    /// Point mode, an exposure taken while the stages moved: the directions along the stages'
    /// trajectory during the exposure with the quadrature weights of its time mean
    /// (brdf/exposure_path.h); the patch's radiance is then the mean over these nodes. Empty: the
    /// stages stood still (wi, wo above).
    std::vector<brdf::PathNode> path;
};

/// Called at each exposure to learn the rig's state.
using SceneFn = std::function<SceneState()>;
/// Called after SceneFn with the exposure's duration (seconds): fills SceneState::path when the
/// stages move during it.
using ScenePathFn = std::function<void(double exposure_s, SceneState* scene)>;

/// A fixed point-mode scene from spherical angles (radians; theta from the normal, phi from x).
inline SceneState scene_from_angles(
    double theta_i, double phi_i, double theta_o, double phi_o, double irradiance_w_m2) {
    SceneState s;
    s.wi = brdf::spherical_to_cartesian(theta_i, phi_i);
    s.wo = brdf::spherical_to_cartesian(theta_o, phi_o);
    s.irradiance_w_m2 = irradiance_w_m2;
    return s;
}

}  // namespace gonio::sim
