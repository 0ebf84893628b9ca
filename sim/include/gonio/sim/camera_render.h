#pragma once

// Rendering of the radiance each pixel of the simulated camera sees. The radiance leaving a
// surface element lit by a collimated beam of perpendicular irradiance E from direction wi is
//   L(wo) = f_r(wi, wo) * E * cos(theta_i)            [W m^-2 sr^-1]
// (the reflection equation with a delta-distributed incident radiance; Nicodemus et al. 1977,
// "Geometrical considerations and nomenclature for reflectance", NBS Monograph 160, eq. 8 with the
// collimated-beam limit). cos(theta_i) <= 0 or cos(theta_o) <= 0 gives L = 0. A mono pixel sees
// filter . L_rgb. The sensor model turns radiance into counts (sensor_model.h).

#include <functional>
#include <opencv2/core.hpp>

#include "gonio/brdf/brdf.h"
#include "gonio/devices/camera.h"
#include "gonio/sim/camera_scene.h"

namespace gonio::sim {

/// Geometry at one pixel: the local surface frame's wi and wo, or `valid = false` where the pixel
/// sees the black background.
struct PixelGeometry {
    bool valid = false;
    brdf::Vec3d wi{0, 0, 1};
    brdf::Vec3d wo{0, 0, 1};
};

/// Per-pixel geometry, from the full-sensor coordinates of the pixel centre (x + 0.5, y + 0.5).
using GeometryFn = std::function<PixelGeometry(double x, double y)>;

/// Point mode: the flat patch fills the central disc of radius 0.25 * min(W, H) pixels around
/// (W/2, H/2) of the full sensor; pixels outside see a black background.
bool in_point_patch(double x, double y, int sensor_width, int sensor_height);

/// L = filter . f_r(wi, wo) * E * cos(theta_i), 0 when a direction is at or below the horizon or
/// the shutter is closed. Never NaN (a non-finite BRDF value counts as 0 and is reported through
/// `nonfinite` when given).
double patch_radiance(const brdf::Brdf& f,
                      const brdf::Vec3d& wi,
                      const brdf::Vec3d& wo,
                      double irradiance_w_m2,
                      const brdf::Rgbd& filter,
                      bool* nonfinite = nullptr);

/// The flat patch's radiance over an exposure: patch_radiance at the scene's wi and wo, or, when
/// the stages moved during it, the weighted mean over SceneState::path (the time mean the sensor
/// integrates; stray light not included).
double patch_radiance_over(const brdf::Brdf& f, const SceneState& scene);

/// Geometry for the scene: point mode (flat patch) or a sphere.
GeometryFn scene_geometry(const SceneState& scene, int sensor_width, int sensor_height);

/// Radiance image (CV_32F, W m^-2 sr^-1) of the region `roi` (full-sensor coordinates, resolved:
/// non-zero width and height) for any per-pixel geometry. Rows are rendered in parallel: `geometry`
/// and `f.eval` are called from several threads at once.
cv::Mat render_radiance(const brdf::Brdf& f,
                        const GeometryFn& geometry,
                        double irradiance_w_m2,
                        const brdf::Rgbd& filter,
                        const devices::Roi& roi);

/// Radiance image of the scene (fast path for point mode: one BRDF evaluation per frame).
cv::Mat render_scene(const brdf::Brdf& f,
                     const SceneState& scene,
                     int sensor_width,
                     int sensor_height,
                     const devices::Roi& roi);

}  // namespace gonio::sim
