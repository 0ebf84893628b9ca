#pragma once

// The imaging camera of image-based acquisition: intrinsics, lens distortion and pose in the rig's
// world frame (the frame of brdf/rig_geometry.h: sample at the origin, arms in the plane z = 0).
//
// Pinhole projection with the distortion model of OpenCV (Brown-Conrady; OpenCV documentation,
// "Camera Calibration and 3D Reconstruction", calib3d module):
//   x_c = R x_w + t                      (world -> camera; camera z along the optical axis,
//                                         x to the right of the image, y down)
//   x' = x_c / z_c, y' = y_c / z_c,  r^2 = x'^2 + y'^2
//   x'' = x' (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x' y' + p2 (r^2 + 2 x'^2)
//   y'' = y' (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y'^2) + 2 p2 x' y'
//   u = fx x'' + cx,  v = fy y'' + cy     (pixels; pixel centres at integer coordinates)
// An orthographic (telecentric) camera has u = fx x_c + cx, v = fy y_c + cy with fx, fy in pixels
// per metre, and no distortion.
//
// Calibration (Z. Zhang, "A Flexible New Technique for Camera Calibration", IEEE TPAMI 22(11),
// 2000) runs OpenCV's chessboard detector and cv::calibrateCamera over views of a planar target;
// the pose in the rig comes from cv::solvePnP on one view of the target at a known place in the
// rig (for example on the sample holder at zero tilt and spin).
//
// JSON (the "camera_model" object of a rig description; docs/image-acquisition.md):
//   {"projection": "perspective"|"orthographic", "width": px, "height": px,
//    "fx": px, "fy": px, "cx": px, "cy": px, "pixel_size_um": um,
//    "distortion": [k1, k2, p1, p2, k3],
//    "rotation_world_to_camera": [9 numbers, row-major], "translation_world_to_camera_m": [3]}

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::acquisition {

enum class Projection {
    kPerspective,   ///< Pinhole with OpenCV distortion.
    kOrthographic,  ///< Telecentric: parallel rays along the optical axis; fx, fy in px/m.
};

const char* to_string(Projection p);

struct CameraIntrinsics {
    int width = 0;   ///< Image width, px.
    int height = 0;  ///< Image height, px.
    double fx = 0;   ///< Focal length in pixels (perspective) or px/m (orthographic).
    double fy = 0;
    double cx = 0;  ///< Principal point, px.
    double cy = 0;
    double pixel_size_um = 0;  ///< Pixel pitch (for reporting the focal length in mm), um.
    std::array<double, 5> distortion{};  ///< k1, k2, p1, p2, k3 (perspective only).

    /// Focal length in millimetres (fx * pixel size), 0 when the pixel size is unknown.
    double focal_length_mm() const { return fx * pixel_size_um * 1e-3; }
    cv::Matx33d camera_matrix() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }
};

/// A ray in the world frame: origin and unit direction.
struct Ray {
    brdf::Vec3d origin;
    brdf::Vec3d direction;
};

struct CameraModel {
    Projection projection = Projection::kPerspective;
    CameraIntrinsics intrinsics;
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< World -> camera.
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< World -> camera, metres.

    /// Camera centre in the world frame, -R^T t (perspective).
    brdf::Vec3d centre_world() const { return -rotation.transpose() * translation; }
    /// Optical axis in the world frame (unit).
    brdf::Vec3d axis_world() const { return rotation.transpose().col(2); }
    /// Pixel coordinates of a world point (distortion applied). The point must be in front of a
    /// perspective camera (z_c > 0); behind it the result is (NaN, NaN).
    Eigen::Vector2d project(const brdf::Vec3d& x_world) const;
    /// The ray through pixel (u, v): undistorted with OpenCV's iterative inverse, then back
    /// projected. Batch version below for whole images.
    Ray pixel_ray(double u, double v) const;
    /// Rays of many pixels at once (one undistortion call).
    std::vector<Ray> pixel_rays(const std::vector<cv::Point2d>& pixels) const;
};

/// A camera on the detector arm at angle `arm_rad` (rig_geometry.h), at `distance_m` from the
/// sample, looking at the origin, image x horizontal and image y toward -W_z (down). For an
/// orthographic camera distance only places the (irrelevant) origin of the rays.
CameraModel camera_on_detector_arm(const CameraIntrinsics& intrinsics,
                                   Projection projection,
                                   double arm_rad,
                                   double distance_m);

/// The default image-mode camera: a square `size` x `size` sensor of 5.5 um pixels on the detector
/// arm at 0, 0.5 m from the sample, the sphere of radius `sphere_radius_m` filling 80% of the
/// frame (image radius 0.4 size); telecentric, or perspective (no distortion) when asked.
CameraModel default_image_camera(int size, bool perspective, double sphere_radius_m);

/// Known planar calibration target: a chessboard with inner_cols x inner_rows inner corners and
/// squares of square_m metres; target frame: x along the columns, y along the rows, z = 0 plane.
struct ChessboardTarget {
    int inner_cols = 9;
    int inner_rows = 6;
    double square_m = 0.01;
    /// Target-frame coordinates of the inner corners, row by row.
    std::vector<cv::Point3f> corners() const;
};

struct CalibrationResult {
    CameraIntrinsics intrinsics;
    double rms_reprojection_px = 0;
    int views_used = 0;
    std::vector<std::string> views_rejected;  ///< "view 3: chessboard not found"
};

/// Intrinsic calibration from views of the chessboard (8- or 16-bit single channel, or float
/// scaled to [0, 1]). Views where the board is not found are listed and skipped; fewer than three
/// usable views is an error.
Expected<CalibrationResult> calibrate_intrinsics(const std::vector<cv::Mat>& views,
                                                 const ChessboardTarget& target,
                                                 double pixel_size_um);

/// Pose of the camera in the world frame from one view of the target placed at `target_to_world`
/// (x_w = target_to_world * x_target). Returns the full model (intrinsics + pose).
Expected<CameraModel> calibrate_pose(const cv::Mat& view,
                                     const ChessboardTarget& target,
                                     const CameraIntrinsics& intrinsics,
                                     const Eigen::Isometry3d& target_to_world);

/// The JSON text of a camera model (schema in the file comment).
std::string camera_model_to_json(const CameraModel& m);
/// Parses a "camera_model" object; errors name `where` and the key ("rig.json: camera_model.fx:
/// must be > 0").
Expected<CameraModel> camera_model_from_json(const std::string& text, const std::string& where);
/// Reads the "camera_model" object of a rig description file.
Expected<CameraModel> read_camera_model(const std::string& rig_path);
/// Sets (or replaces) the "camera_model" object of a rig description file, keeping its other keys;
/// creates the file when it does not exist. Written to path + ".tmp" and renamed.
Expected<void> write_camera_model(const std::string& rig_path, const CameraModel& m);

}  // namespace gonio::acquisition
