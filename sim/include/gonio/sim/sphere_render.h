#pragma once

// Image-mode ground truth: a sphere of the sample's material, lit by a collimated beam, imaged by
// a perspective (with OpenCV's lens distortion) or orthographic camera, through the same sensor
// model as every simulated frame (sensor_model.h). Each pixel's radiance is
//   L = f_r(wi, wo) E cos(theta_i)    (camera_render.h: patch_radiance)
// at the first intersection of the pixel's ray with the sphere, in the surface's local frame
// (z = outward normal; the tangent is the circle of latitude about the lathe axis a of a turned
// sphere, (a x n) / |a x n|, when the scene has one (at the poles themselves, where it is
// undefined, the reference below); else the reference: world +x projected on the tangent plane,
// world +y where the normal is along x). Pixels whose ray misses the sphere see a black background.
// With `supersample` = n the pixel is the mean over an n x n grid of sub-pixel rays (anti-aliased
// silhouette).
//
// Pixel coordinates follow OpenCV: pixel (x, y) covers [x - 1/2, x + 1/2] x [y - 1/2, y + 1/2].
// Projection (world -> camera x_c = R x_w + t, camera z forward, y down):
//   perspective  (x', y') = (x_c / z_c, y_c / z_c), distorted with k1, k2, p1, p2, k3, then
//                u = fx x'' + cx, v = fy y'' + cy (rays found by inverting the distortion);
//   orthographic u = fx x_c + cx, v = fy y_c + cy (fx, fy in pixels per metre).

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>

#include "gonio/brdf/brdf.h"
#include "gonio/devices/camera.h"
#include "gonio/sim/sensor_model.h"

namespace gonio::sim {

enum class SphereProjection {
    kPerspective,   ///< Pinhole with lens distortion.
    kOrthographic,  ///< Telecentric.
};

/// The simulated imaging camera (ground truth of what calibration should find).
struct SphereCamera {
    SphereProjection projection = SphereProjection::kOrthographic;
    int width = 256;
    int height = 256;
    double fx = 5000;  ///< px (perspective) or px/m (orthographic)
    double fy = 5000;
    double cx = 127.5;
    double cy = 127.5;
    std::array<double, 5> distortion{};                      ///< k1, k2, p1, p2, k3
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< World -> camera.
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< World -> camera, metres.
};

struct SphereScene {
    SphereCamera camera;
    brdf::Vec3d centre{0, 0, 0};  ///< World frame, metres.
    double radius_m = 0.02;
    brdf::Vec3d light_world{1, 0, 0};  ///< Toward the (distant) light, unit.
    double irradiance_w_m2 = 1.0;      ///< Of the collimated beam, perpendicular to it.
    brdf::Rgbd filter{1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0};  ///< Mono pixel sees filter . f_rgb.
    bool shutter_open = true;
    int supersample = 2;  ///< Sub-pixel rays per axis, >= 1.
    /// The lathe axis of a turned sphere (world frame, unit): the material's tangent at the normal
    /// n is (a x n) / |a x n|, the circles of latitude about it (an anisotropic material's
    /// brushing). Zero: the reference tangent of the file comment (enough for isotropic material).
    brdf::Vec3d lathe_axis{0, 0, 0};
};

/// Ground truth at one pixel centre (no supersampling): whether the ray meets the sphere, the
/// world-frame normal and the local-frame wi, wo.
struct SpherePixelTruth {
    bool hit = false;
    brdf::Vec3d normal_world{0, 0, 1};
    brdf::Vec3d wi{0, 0, 1};
    brdf::Vec3d wo{0, 0, 1};
};

/// Truth for every pixel, row-major (width x height).
std::vector<SpherePixelTruth> sphere_truth(const SphereScene& scene);

/// Radiance image (CV_32F, W m^-2 sr^-1) of the scene; zero everywhere with the shutter closed.
/// Non-finite BRDF values count as 0 and are added to *nonfinite when given.
cv::Mat render_sphere_radiance(const brdf::Brdf& f,
                               const SphereScene& scene,
                               std::size_t* nonfinite = nullptr);

/// One exposure through the sensor model: counts with their metadata (exposure, gain, black and
/// saturation level, bit depth).
devices::Frame render_sphere_frame(const brdf::Brdf& f,
                                   const SphereScene& scene,
                                   SensorModel& sensor,
                                   const ExposureSettings& settings);

/// The frame metadata a camera would report for these settings (no pixels).
devices::Frame frame_metadata(const SensorModel& sensor, const ExposureSettings& settings);

}  // namespace gonio::sim
