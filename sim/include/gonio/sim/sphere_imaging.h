#pragma once

// Image mode on the virtual rig: the simulated GigE Vision camera on the detector arm looking at a
// sphere of the mounted material (sphere_render.h) instead of the point-mode flat patch. The
// renderer is plugged into GigeCamera (gige_camera.h: RadianceFn) and reads, at trigger time, the
// same SceneState as point mode: the light at brdf::arm_direction(light_arm_rad), the camera at
// detector_arm_rad, the shutter, the filter, the irradiance (with the lamp factor) and the BRDF in
// the beam (MountedBrdf: the sample, or the Lambertian white standard while the reference changer
// is on).
//
// Camera on the detector arm: the arm turns about world z, so the camera at arm angle a is the
// camera at arm 0 turned by R_z(a): x_c = R_0 R_z(a)^T x_w + t_0 (world -> camera). The sample
// holder's tilt and spin turn the sphere about its centre, which leaves its outline and an
// isotropic material's image unchanged; they turn the tangent field of a turned sphere (the
// circles of latitude about its lathe axis, mounted along the holder's local y:
// brdf::sample_to_world((0, 1, 0), tilt, spin)), which is what an anisotropic material's image
// depends on (sphere_render.h: SphereScene::lathe_axis).

#include <array>
#include <vector>

#include "gonio/brdf/brdf.h"
#include "gonio/devices/camera.h"
#include "gonio/sim/camera_scene.h"
#include "gonio/sim/gige_camera.h"
#include "gonio/sim/sphere_render.h"

namespace gonio::sim {

/// A zoomed camera placement: the wide camera's focal length (px, or px per metre for a
/// telecentric camera) times `magnification`, and the camera moved across its optical axis by
/// `offset_m` along its own x (image right) and y (image down): x_c = R x_w + t - (ox, oy, 0).
/// The same sensor; a crop of the sphere around the point (ox, oy) from the axis fills it.
struct ZoomPlacement {
    double magnification = 1;
    std::array<double, 2> offset_m{0, 0};
};

/// The imaging set-up of an image-mode rig.
struct SphereImaging {
    SphereCamera camera;          ///< The camera with the detector arm at 0 (world -> camera pose).
    brdf::Vec3d centre{0, 0, 0};  ///< Sphere centre, world frame, metres.
    double radius_m = 0.02;
    int supersample = 2;  ///< Sub-pixel rays per axis, >= 1.
    /// Zoomed placements, switched in by SceneState::placement (k: placements[k - 1]).
    std::vector<ZoomPlacement> placements;
};

/// `camera` seen through `placement` (ZoomPlacement).
SphereCamera zoomed_camera(const SphereCamera& camera, const ZoomPlacement& placement);

/// The camera of `imaging` with the detector arm at `arm_rad` (file comment).
SphereCamera sphere_camera_at_arm(const SphereCamera& at_zero, double arm_rad);

/// The sphere scene seen at rig state `state`.
SphereScene sphere_scene(const SphereImaging& imaging, const SceneState& state);

/// A GigeCamera renderer drawing the sphere: the full-sensor radiance of sphere_scene() cropped to
/// the region of interest (pixels of the ROI outside the camera's image are black).
RadianceFn sphere_renderer(SphereImaging imaging);

}  // namespace gonio::sim
