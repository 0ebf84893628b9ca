#include "gonio/acquisition/image/camera_model.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "gonio/base/atomic_file.h"
#include "gonio/base/check.h"
#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"

namespace gonio::acquisition {

const char* to_string(Projection p) {
    switch (p) {
        case Projection::kPerspective:
            return "perspective";
        case Projection::kOrthographic:
            return "orthographic";
    }
    return "?";
}

Eigen::Vector2d CameraModel::project(const brdf::Vec3d& x_world) const {
    const Eigen::Vector3d xc = rotation * x_world + translation;
    const CameraIntrinsics& k = intrinsics;
    if (projection == Projection::kOrthographic) {
        return {k.fx * xc.x() + k.cx, k.fy * xc.y() + k.cy};
    }
    if (!(xc.z() > 0)) {
        // Behind (or on the plane of) a perspective camera: no image.
        const double nan = std::numeric_limits<double>::quiet_NaN();
        return {nan, nan};
    }
    const double x = xc.x() / xc.z();
    const double y = xc.y() / xc.z();
    const double r2 = x * x + y * y;
    const auto& d = k.distortion;  // k1, k2, p1, p2, k3
    const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
    const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
    return {k.fx * xd + k.cx, k.fy * yd + k.cy};
}

Ray CameraModel::pixel_ray(double u, double v) const {
    return pixel_rays({cv::Point2d(u, v)}).front();
}

std::vector<Ray> CameraModel::pixel_rays(const std::vector<cv::Point2d>& pixels) const {
    std::vector<Ray> rays(pixels.size());
    const Eigen::Matrix3d rt = rotation.transpose();
    const CameraIntrinsics& k = intrinsics;
    if (projection == Projection::kOrthographic) {
        const brdf::Vec3d dir = rt.col(2);
        for (std::size_t i = 0; i < pixels.size(); ++i) {
            const Eigen::Vector3d xc((pixels[i].x - k.cx) / k.fx, (pixels[i].y - k.cy) / k.fy, 0);
            rays[i] = {rt * (xc - translation), dir};
        }
        return rays;
    }
    if (pixels.empty()) {
        return rays;
    }
    std::vector<cv::Point2d> normalised;
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(k.distortion.data()));
    // Iterate the inverse of the distortion to convergence (the default stops after 5 steps).
    cv::undistortPoints(
        pixels,
        normalised,
        cv::Mat(k.camera_matrix()),
        dist,
        cv::noArray(),
        cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
    const brdf::Vec3d c = centre_world();
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        const Eigen::Vector3d dc(normalised[i].x, normalised[i].y, 1.0);
        rays[i] = {c, (rt * dc).normalized()};
    }
    return rays;
}

CameraModel camera_on_detector_arm(const CameraIntrinsics& intrinsics,
                                   Projection projection,
                                   double arm_rad,
                                   double distance_m) {
    const brdf::Vec3d v(std::cos(arm_rad), std::sin(arm_rad), 0);  // sample -> camera
    const brdf::Vec3d z_c = -v;                                    // optical axis
    const brdf::Vec3d y_c(0, 0, -1);                               // image down = world down
    const brdf::Vec3d x_c = y_c.cross(z_c);
    CameraModel m;
    m.projection = projection;
    m.intrinsics = intrinsics;
    m.rotation.row(0) = x_c.transpose();
    m.rotation.row(1) = y_c.transpose();
    m.rotation.row(2) = z_c.transpose();
    m.translation = -m.rotation * (distance_m * v);
    return m;
}

CameraModel default_image_camera(int size, bool perspective, double sphere_radius_m) {
    GONIO_CHECK(size > 0 && sphere_radius_m > 0 && sphere_radius_m < 0.5);
    constexpr double kDistance = 0.5;
    CameraIntrinsics k;
    k.width = size;
    k.height = size;
    k.cx = (size - 1) / 2.0;
    k.cy = (size - 1) / 2.0;
    k.pixel_size_um = 5.5;
    const double fill_px = 0.4 * size;
    if (perspective) {
        // Angular radius asin(R / d), image radius f tan(angle).
        k.fx = k.fy = fill_px / std::tan(std::asin(sphere_radius_m / kDistance));
    } else {
        k.fx = k.fy = fill_px / sphere_radius_m;  // px per metre
    }
    return camera_on_detector_arm(
        k, perspective ? Projection::kPerspective : Projection::kOrthographic, 0.0, kDistance);
}

std::vector<cv::Point3f> ChessboardTarget::corners() const {
    std::vector<cv::Point3f> out;
    for (int r = 0; r < inner_rows; ++r) {
        for (int c = 0; c < inner_cols; ++c) {
            out.emplace_back(
                static_cast<float>(c * square_m), static_cast<float>(r * square_m), 0.f);
        }
    }
    return out;
}

namespace {

/// An 8-bit view for the chessboard detector: 8-bit as is, 16-bit and float rescaled to their
/// own range.
cv::Mat to_8bit(const cv::Mat& view) {
    cv::Mat gray = view;
    if (view.channels() == 3) {
        cv::cvtColor(view, gray, cv::COLOR_BGR2GRAY);
    }
    if (gray.depth() == CV_8U) {
        return gray;
    }
    double lo = 0;
    double hi = 0;
    cv::minMaxLoc(gray, &lo, &hi);
    cv::Mat out;
    const double scale = hi > lo ? 255.0 / (hi - lo) : 1.0;
    gray.convertTo(out, CV_8U, scale, -lo * scale);
    return out;
}

Expected<std::vector<cv::Point2f>> find_corners(const cv::Mat& view,
                                                const ChessboardTarget& target) {
    if (view.empty()) {
        return make_error("empty image");
    }
    const cv::Mat gray = to_8bit(view);
    std::vector<cv::Point2f> corners;
    const cv::Size size(target.inner_cols, target.inner_rows);
    const bool found = cv::findChessboardCorners(
        gray, size, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found) {
        return make_error("chessboard of " + std::to_string(target.inner_cols) + "x" +
                          std::to_string(target.inner_rows) + " inner corners not found");
    }
    cv::cornerSubPix(gray,
                     corners,
                     cv::Size(5, 5),
                     cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
    return corners;
}

}  // namespace

Expected<CalibrationResult> calibrate_intrinsics(const std::vector<cv::Mat>& views,
                                                 const ChessboardTarget& target,
                                                 double pixel_size_um) {
    CalibrationResult result;
    std::vector<std::vector<cv::Point3f>> object_points;
    std::vector<std::vector<cv::Point2f>> image_points;
    cv::Size image_size;
    for (std::size_t i = 0; i < views.size(); ++i) {
        auto corners = find_corners(views[i], target);
        if (!corners) {
            result.views_rejected.push_back("view " + std::to_string(i) + ": " +
                                            corners.error().message);
            continue;
        }
        if (image_size.width == 0) {
            image_size = views[i].size();
        } else if (views[i].size() != image_size) {
            result.views_rejected.push_back("view " + std::to_string(i) +
                                            ": size differs from the first view");
            continue;
        }
        object_points.push_back(target.corners());
        image_points.push_back(*corners);
    }
    if (object_points.size() < 3) {
        std::string msg = "camera calibration: " + std::to_string(object_points.size()) +
                          " usable views of " + std::to_string(views.size()) + ", need at least 3";
        for (const std::string& r : result.views_rejected) {
            msg += "; " + r;
        }
        return make_error(msg);
    }
    cv::Mat k;
    cv::Mat dist;
    std::vector<cv::Mat> rvecs;
    std::vector<cv::Mat> tvecs;
    const double rms =
        cv::calibrateCamera(object_points, image_points, image_size, k, dist, rvecs, tvecs);
    if (!std::isfinite(rms)) {
        return make_error("camera calibration: non-finite reprojection error");
    }
    CameraIntrinsics& in = result.intrinsics;
    in.width = image_size.width;
    in.height = image_size.height;
    in.fx = k.at<double>(0, 0);
    in.fy = k.at<double>(1, 1);
    in.cx = k.at<double>(0, 2);
    in.cy = k.at<double>(1, 2);
    in.pixel_size_um = pixel_size_um;
    for (int i = 0; i < 5 && i < static_cast<int>(dist.total()); ++i) {
        in.distortion[i] = dist.at<double>(i);
    }
    result.rms_reprojection_px = rms;
    result.views_used = static_cast<int>(object_points.size());
    return result;
}

Expected<CameraModel> calibrate_pose(const cv::Mat& view,
                                     const ChessboardTarget& target,
                                     const CameraIntrinsics& intrinsics,
                                     const Eigen::Isometry3d& target_to_world) {
    auto corners = find_corners(view, target);
    if (!corners) {
        return make_error("camera pose: " + corners.error().message);
    }
    cv::Mat rvec;
    cv::Mat tvec;
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(intrinsics.distortion.data()));
    if (!cv::solvePnP(target.corners(),
                      *corners,
                      cv::Mat(intrinsics.camera_matrix()),
                      dist,
                      rvec,
                      tvec,
                      false,
                      cv::SOLVEPNP_ITERATIVE)) {
        return make_error("camera pose: solvePnP found no pose");
    }
    cv::Mat r;
    cv::Rodrigues(rvec, r);
    Eigen::Matrix3d r_tc;  // target -> camera
    Eigen::Vector3d t_tc;
    for (int i = 0; i < 3; ++i) {
        t_tc[i] = tvec.at<double>(i);
        for (int j = 0; j < 3; ++j) {
            r_tc(i, j) = r.at<double>(i, j);
        }
    }
    // x_c = R_tc x_t + t_tc and x_t = T^-1 x_w, so x_c = R_tc R_wt^T (x_w - p_wt) + t_tc.
    const Eigen::Matrix3d r_wt = target_to_world.linear();
    const Eigen::Vector3d p_wt = target_to_world.translation();
    CameraModel m;
    m.projection = Projection::kPerspective;
    m.intrinsics = intrinsics;
    m.rotation = r_tc * r_wt.transpose();
    m.translation = t_tc - m.rotation * p_wt;
    return m;
}

std::string camera_model_to_json(const CameraModel& m) {
    nlohmann::json j;
    const CameraIntrinsics& k = m.intrinsics;
    j["projection"] = to_string(m.projection);
    j["width"] = k.width;
    j["height"] = k.height;
    j["fx"] = k.fx;
    j["fy"] = k.fy;
    j["cx"] = k.cx;
    j["cy"] = k.cy;
    j["pixel_size_um"] = k.pixel_size_um;
    j["distortion"] = k.distortion;
    std::vector<double> r(9);
    for (int i = 0; i < 3; ++i) {
        for (int c = 0; c < 3; ++c) {
            r[3 * i + c] = m.rotation(i, c);
        }
    }
    j["rotation_world_to_camera"] = r;
    j["translation_world_to_camera_m"] = {m.translation.x(), m.translation.y(), m.translation.z()};
    return j.dump(2);
}

namespace {

/// `n` finite numbers at `at` (a key path).
std::vector<double> numbers_at(const nlohmann::json& v, const std::string& at, std::size_t n) {
    if (!v.is_array() || v.size() != n) {
        json_fail(at + ": must be an array of " + std::to_string(n) + " numbers, got " +
                  (v.is_array() ? std::to_string(v.size()) + " values" : json_type(v)));
    }
    std::vector<double> out;
    for (std::size_t i = 0; i < n; ++i) {
        out.push_back(json_number_at(v[i], at + "[" + std::to_string(i) + "]"));
    }
    return out;
}

/// The camera model object at key path `path` ("camera_model"), read with the strict reader:
/// every key known, every value typed, finite and in its domain. Throws JsonFailure (inside
/// read_strict_json).
CameraModel read_model_object(const nlohmann::json& j, const std::string& path) {
    JsonObject o(j, path);
    auto required = [&](const char* key) -> const nlohmann::json& {
        if (!o.has(key)) {
            json_fail(o.key_path(key) + ": missing");
        }
        return o.raw(key);
    };
    CameraModel m;
    const std::string proj = o.string("projection", "perspective", 32);
    if (proj == "perspective") {
        m.projection = Projection::kPerspective;
    } else if (proj == "orthographic") {
        m.projection = Projection::kOrthographic;
    } else {
        json_fail(o.key_path("projection") + ": \"" + excerpt(proj) +
                  "\" is not perspective or orthographic");
    }
    CameraIntrinsics& k = m.intrinsics;
    for (const char* key : {"width", "height"}) {
        const double v = json_number_at(required(key), o.key_path(key));
        if (v < 1 || v > 1e6 || std::floor(v) != v) {
            json_fail(o.key_path(key) + " = " + show_number(v) + ": must be a positive integer");
        }
        (std::string(key) == "width" ? k.width : k.height) = static_cast<int>(v);
    }
    double* fields[] = {&k.fx, &k.fy, &k.cx, &k.cy};
    const char* names[] = {"fx", "fy", "cx", "cy"};
    for (int i = 0; i < 4; ++i) {
        const double v = json_number_at(required(names[i]), o.key_path(names[i]));
        if (i < 2 && !(v > 0)) {
            json_fail(o.key_path(names[i]) + " = " + show_number(v) + ": must be > 0");
        }
        *fields[i] = v;
    }
    if (const nlohmann::json* v = o.find("pixel_size_um")) {
        k.pixel_size_um = json_number_at(*v, o.key_path("pixel_size_um"));
        if (k.pixel_size_um < 0) {
            json_fail(o.key_path("pixel_size_um") + " = " + show_number(k.pixel_size_um) +
                      ": must be >= 0");
        }
    }
    if (const nlohmann::json* v = o.find("distortion")) {
        const std::vector<double> d = numbers_at(*v, o.key_path("distortion"), 5);
        std::copy(d.begin(), d.end(), k.distortion.begin());
    }
    const std::string rot = o.key_path("rotation_world_to_camera");
    const std::vector<double> r = numbers_at(required("rotation_world_to_camera"), rot, 9);
    for (int i = 0; i < 3; ++i) {
        for (int c = 0; c < 3; ++c) {
            m.rotation(i, c) = r[3 * i + c];
        }
    }
    const double ortho_err =
        (m.rotation * m.rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (ortho_err > 1e-6 || m.rotation.determinant() < 0) {
        json_fail(rot + ": not a rotation (R R^T differs from I by " + show_number(ortho_err) +
                  " or det < 0)");
    }
    const std::vector<double> t = numbers_at(
        required("translation_world_to_camera_m"), o.key_path("translation_world_to_camera_m"), 3);
    m.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    o.finish();
    return m;
}

}  // namespace

Expected<CameraModel> camera_model_from_json(const std::string& text, const std::string& where) {
    return read_strict_json(
        where, [&] { return read_model_object(parse_json_checked(text, where), "camera_model"); });
}

Expected<CameraModel> read_camera_model(const std::string& rig_path) {
    Expected<std::string> text = read_input_file(rig_path, kMaxJsonBytes);
    if (!text) {
        return tl::unexpected(text.error());
    }
    return read_strict_json(rig_path, [&] {
        const nlohmann::json j = parse_json_checked(*text, rig_path);
        require_json_object(j, "");
        if (!j.contains("camera_model")) {
            json_fail("camera_model: missing (calibrate the camera first)");
        }
        return read_model_object(j["camera_model"], "camera_model");
    });
}

Expected<void> write_camera_model(const std::string& rig_path, const CameraModel& m) {
    nlohmann::json j = nlohmann::json::object();
    {
        std::ifstream in(rig_path);
        if (in) {
            try {
                in >> j;
            } catch (const nlohmann::json::exception& e) {
                return make_error(rig_path + ": " + json_error_text(e.what()));
            }
            if (!j.is_object()) {
                return make_error(rig_path + ": the rig description must be a JSON object");
            }
        }
    }
    j["camera_model"] = nlohmann::json::parse(camera_model_to_json(m));
    return write_file_atomic(rig_path, j.dump(2) + "\n");
}

}  // namespace gonio::acquisition
