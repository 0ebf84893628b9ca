// Camera model of image mode: projection against rays, the detector-arm pose, JSON in the rig
// description, and OpenCV calibration on chessboard views rendered from a known camera.

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "gonio/acquisition/image/camera_model.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::Vec3d;

CameraIntrinsics truth_intrinsics() {
    CameraIntrinsics k;
    k.width = 480;
    k.height = 360;
    k.fx = 615;
    k.fy = 611;
    k.cx = 245.5;
    k.cy = 177.0;
    k.pixel_size_um = 4.8;
    k.distortion = {-0.12, 0.06, 0.0005, -0.0004, 0.0};
    return k;
}

double ray_point_distance(const Ray& r, const Vec3d& x) {
    const Vec3d w = x - r.origin;
    return (w - w.dot(r.direction) * r.direction).norm();
}

TEST(ImageCameraModel, PerspectiveProjectionAndRayAgree) {
    const CameraModel cam =
        camera_on_detector_arm(truth_intrinsics(), Projection::kPerspective, 0.7, 0.6);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-0.05, 0.05);
    for (int i = 0; i < 200; ++i) {
        const Vec3d x(u(rng), u(rng), u(rng));
        const Eigen::Vector2d p = cam.project(x);
        ASSERT_TRUE(p.allFinite());
        const Ray r = cam.pixel_ray(p.x(), p.y());
        EXPECT_LT(ray_point_distance(r, x), 1e-9) << "point " << x.transpose();
        EXPECT_NEAR(r.direction.norm(), 1.0, 1e-12);
    }
    // A point behind the camera has no image.
    EXPECT_FALSE(cam.project(cam.centre_world() - 0.1 * cam.axis_world()).allFinite());
}

TEST(ImageCameraModel, OrthographicProjectionAndRayAgree) {
    CameraIntrinsics k = truth_intrinsics();
    k.distortion = {};
    k.fx = k.fy = 5000;
    const CameraModel cam = camera_on_detector_arm(k, Projection::kOrthographic, -1.2, 1.0);
    const Vec3d x(0.01, -0.02, 0.005);
    const Eigen::Vector2d p = cam.project(x);
    const Ray r = cam.pixel_ray(p.x(), p.y());
    EXPECT_LT(ray_point_distance(r, x), 1e-12);
    EXPECT_NEAR(r.direction.dot(-Vec3d(std::cos(-1.2), std::sin(-1.2), 0)), 1.0, 1e-12);
}

TEST(ImageCameraModel, DetectorArmPoseLooksAtTheSample) {
    const double a = 0.4;
    const CameraModel cam =
        camera_on_detector_arm(truth_intrinsics(), Projection::kPerspective, a, 0.5);
    EXPECT_NEAR((cam.centre_world() - 0.5 * Vec3d(std::cos(a), std::sin(a), 0)).norm(), 0, 1e-12);
    // The origin images at the principal point (no distortion there).
    const Eigen::Vector2d o = cam.project(Vec3d::Zero());
    EXPECT_NEAR(o.x(), cam.intrinsics.cx, 1e-9);
    EXPECT_NEAR(o.y(), cam.intrinsics.cy, 1e-9);
    // World up appears above the centre (smaller v), and R is a rotation.
    EXPECT_LT(cam.project(Vec3d(0, 0, 0.01)).y(), cam.intrinsics.cy);
    EXPECT_NEAR(cam.rotation.determinant(), 1.0, 1e-12);
}

TEST(ImageCameraModel, JsonRoundTripKeepsOtherRigKeys) {
    const CameraModel cam =
        camera_on_detector_arm(truth_intrinsics(), Projection::kPerspective, 0.3, 0.45);
    const std::string path =
        (std::filesystem::temp_directory_path() / "gonio_image_camera_rig.json").string();
    {
        std::ofstream out(path);
        out << R"({"name": "bench rig", "axes": [1, 2]})";
    }
    ASSERT_TRUE(write_camera_model(path, cam));
    auto back = read_camera_model(path);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->projection, Projection::kPerspective);
    EXPECT_DOUBLE_EQ(back->intrinsics.fx, 615);
    EXPECT_DOUBLE_EQ(back->intrinsics.distortion[1], 0.06);
    EXPECT_LT((back->rotation - cam.rotation).norm(), 1e-15);
    EXPECT_LT((back->translation - cam.translation).norm(), 1e-15);
    std::ifstream in(path);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("bench rig"), std::string::npos);
    std::filesystem::remove(path);
}

TEST(ImageCameraModel, JsonErrorsNameTheKey) {
    const std::string good = camera_model_to_json(
        camera_on_detector_arm(truth_intrinsics(), Projection::kPerspective, 0.3, 0.45));
    auto missing = camera_model_from_json(R"({"width": 10, "height": 10})", "rig.json");
    ASSERT_FALSE(missing);
    EXPECT_EQ(missing.error().message, "rig.json: camera_model.fx: missing");
    std::string bad = good;
    bad.replace(bad.find("\"fy\""), 4, "\"fq\"");
    auto e2 = camera_model_from_json(bad, "rig.json");
    ASSERT_FALSE(e2);
    EXPECT_NE(e2.error().message.find("camera_model.fy"), std::string::npos);
    auto e3 = camera_model_from_json(
        R"({"width": 10, "height": 10, "fx": 1, "fy": 1, "cx": 0, "cy": 0,
            "rotation_world_to_camera": [1,0,0, 0,2,0, 0,0,1],
            "translation_world_to_camera_m": [0,0,0]})",
        "rig.json");
    ASSERT_FALSE(e3);
    EXPECT_NE(e3.error().message.find("not a rotation"), std::string::npos);
    auto e4 = read_camera_model("/nonexistent/rig.json");
    ASSERT_FALSE(e4);
    EXPECT_NE(e4.error().message.find("cannot open"), std::string::npos);
}

TEST(ImageCameraModel, JsonRefusesUnknownKeysAndWrongTypesNamingTheKeyPath) {
    const std::string good = camera_model_to_json(
        camera_on_detector_arm(truth_intrinsics(), Projection::kPerspective, 0.3, 0.45));
    ASSERT_TRUE(camera_model_from_json(good, "rig.json"));
    // `good` with one more key, or one key's value replaced.
    auto with = [&](const std::string& key, const std::string& value) {
        nlohmann::json j = nlohmann::json::parse(good);
        j[key] = nlohmann::json::parse(value);
        auto m = camera_model_from_json(j.dump(), "rig.json");
        return m ? std::string() : m.error().message;
    };
    EXPECT_EQ(
        with("distorsion", "[0, 0, 0, 0, 0]")
            .rfind("rig.json: camera_model.distorsion: unknown key (allowed here: projection, "
                   "width, height, fx, fy, cx, cy, pixel_size_um, distortion, ",
                   0),
        0u)
        << with("distorsion", "[0, 0, 0, 0, 0]");
    EXPECT_EQ(with("pixel_size_um", "\"5\""),
              "rig.json: camera_model.pixel_size_um: expected a number, got string");
    EXPECT_EQ(with("width", "10.5"),
              "rig.json: camera_model.width = 10.5: must be a positive integer");
    EXPECT_EQ(with("projection", "3"),
              "rig.json: camera_model.projection: expected a string, got number");
    EXPECT_EQ(with("rotation_world_to_camera", "[1, 0, 0, 0, \"1\", 0, 0, 0, 1]"),
              "rig.json: camera_model.rotation_world_to_camera[4]: expected a number, got string");
    EXPECT_EQ(with("distortion", "[0, 0]"),
              "rig.json: camera_model.distortion: must be an array of 5 numbers, got 2 values");
    EXPECT_EQ(camera_model_from_json("[]", "rig.json").error().message,
              "rig.json: camera_model: expected an object, got array");
    // In a rig description: the same rules, the rig file named.
    const std::string path = (std::filesystem::temp_directory_path() /
                              ("gonio_camera_model_keys_" + std::to_string(::getpid()) + ".json"))
                                 .string();
    nlohmann::json rig = {{"name", "r"}, {"camera_model", nlohmann::json::parse(good)}};
    rig["camera_model"]["fx"] = "1200";
    std::ofstream(path) << rig.dump();
    auto bad = read_camera_model(path);
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().message, path + ": camera_model.fx: expected a number, got string");
    std::filesystem::remove(path);
}

/// Renders a chessboard view seen by `k` with the board at (r_bc, t_bc) (board -> camera).
/// Board: (cols + 1) x (rows + 1) squares around the inner corners, one square of white border,
/// grey background. 2 x 2 sub-pixel samples per pixel.
cv::Mat render_board(const CameraIntrinsics& k,
                     const ChessboardTarget& t,
                     const Eigen::Matrix3d& r_bc,
                     const Eigen::Vector3d& t_bc) {
    std::vector<cv::Point2d> px;
    const int ss = 2;
    for (int y = 0; y < k.height; ++y) {
        for (int x = 0; x < k.width; ++x) {
            for (int j = 0; j < ss; ++j) {
                for (int i = 0; i < ss; ++i) {
                    px.emplace_back(x - 0.5 + (i + 0.5) / ss, y - 0.5 + (j + 0.5) / ss);
                }
            }
        }
    }
    std::vector<cv::Point2d> norm;
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(k.distortion.data()));
    cv::undistortPoints(
        px,
        norm,
        cv::Mat(k.camera_matrix()),
        dist,
        cv::noArray(),
        cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
    // Plane z_b = 0: n . x_c = n . t_bc with n = r_bc col 2.
    const Eigen::Vector3d n = r_bc.col(2);
    cv::Mat img(k.height, k.width, CV_32F, cv::Scalar(0));
    const double sq = t.square_m;
    for (std::size_t s = 0; s < px.size(); ++s) {
        const Eigen::Vector3d d(norm[s].x, norm[s].y, 1.0);
        const double lambda = n.dot(t_bc) / n.dot(d);
        double v = 0.5;
        if (lambda > 0) {
            const Eigen::Vector3d xb = r_bc.transpose() * (lambda * d - t_bc);
            const double bx = xb.x() / sq + 1;  // squares start one square before corner 0
            const double by = xb.y() / sq + 1;
            if (bx >= -1 && by >= -1 && bx < t.inner_cols + 2 && by < t.inner_rows + 2) {
                v = 1.0;  // white border
                if (bx >= 0 && by >= 0 && bx < t.inner_cols + 1 && by < t.inner_rows + 1) {
                    v = ((static_cast<int>(bx) + static_cast<int>(by)) % 2 == 0) ? 0.05 : 0.95;
                }
            }
        }
        const std::size_t p = s / (ss * ss);
        img.at<float>(static_cast<int>(p / k.width), static_cast<int>(p % k.width)) +=
            static_cast<float>(v / (ss * ss));
    }
    cv::Mat out;
    img.convertTo(out, CV_8U, 255);
    return out;
}

Eigen::Matrix3d rot(double ax, double ay, double az) {
    return (Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
}

TEST(ImageCameraModel, CalibrationRecoversIntrinsicsAndPose) {
    const CameraIntrinsics k = truth_intrinsics();
    ChessboardTarget target;
    target.inner_cols = 8;
    target.inner_rows = 6;
    target.square_m = 0.02;
    const Eigen::Vector3d board_centre(3.5 * 0.02, 2.5 * 0.02, 0);
    std::vector<cv::Mat> views;
    const double tilts[][3] = {{0.0, 0.0, 0.0},
                               {0.35, 0.0, 0.1},
                               {-0.35, 0.1, -0.1},
                               {0.0, 0.4, 0.05},
                               {0.1, -0.4, 0.2},
                               {0.3, 0.3, -0.2},
                               {-0.3, -0.3, 0.0},
                               {0.2, -0.2, 0.3}};
    const double shifts[][2] = {{0, 0},
                                {0.03, 0.02},
                                {-0.03, -0.02},
                                {0.02, -0.03},
                                {-0.02, 0.03},
                                {0.04, 0.0},
                                {-0.04, 0.01},
                                {0.0, 0.03}};
    for (int v = 0; v < 8; ++v) {
        const Eigen::Matrix3d r = rot(tilts[v][0], tilts[v][1], tilts[v][2]);
        const Eigen::Vector3d t =
            Eigen::Vector3d(shifts[v][0], shifts[v][1], 0.5) - r * board_centre;
        views.push_back(render_board(k, target, r, t));
    }
    // A view without a board is reported, not fatal.
    views.push_back(cv::Mat(k.height, k.width, CV_8U, cv::Scalar(128)));
    auto cal = calibrate_intrinsics(views, target, 4.8);
    ASSERT_TRUE(cal) << cal.error().message;
    EXPECT_EQ(cal->views_used, 8);
    ASSERT_EQ(cal->views_rejected.size(), 1u);
    EXPECT_NE(cal->views_rejected[0].find("view 8"), std::string::npos);
    EXPECT_LT(cal->rms_reprojection_px, 0.3);
    const CameraIntrinsics& e = cal->intrinsics;
    EXPECT_NEAR(e.fx, k.fx, 0.01 * k.fx);
    EXPECT_NEAR(e.fy, k.fy, 0.01 * k.fy);
    EXPECT_NEAR(e.cx, k.cx, 3.0);
    EXPECT_NEAR(e.cy, k.cy, 3.0);
    EXPECT_NEAR(e.distortion[0], k.distortion[0], 0.03);
    EXPECT_NEAR(e.focal_length_mm(), k.fx * 4.8e-3, 0.01 * k.fx * 4.8e-3);

    // Pose: the board lies on the sample holder, its centre at the rig origin, facing the camera
    // on the detector arm at 0.5 rad, 0.45 m away.
    const CameraModel truth = camera_on_detector_arm(k, Projection::kPerspective, 0.5, 0.45);
    Eigen::Isometry3d board_to_world = Eigen::Isometry3d::Identity();
    // Board axes in the world: x along the camera's x, y along the camera's y (image down),
    // normal toward the camera.
    board_to_world.linear() = truth.rotation.transpose();
    board_to_world.translation() = -truth.rotation.transpose() * board_centre;
    const Eigen::Matrix3d r_bc = truth.rotation * board_to_world.linear();
    const Eigen::Vector3d t_bc = truth.rotation * board_to_world.translation() + truth.translation;
    const cv::Mat pose_view = render_board(k, target, r_bc, t_bc);
    auto pose = calibrate_pose(pose_view, target, e, board_to_world);
    ASSERT_TRUE(pose) << pose.error().message;
    EXPECT_LT((pose->centre_world() - truth.centre_world()).norm(), 0.005);  // 5 mm at 0.45 m
    EXPECT_GT(pose->axis_world().dot(truth.axis_world()), std::cos(0.5 * kPi / 180));
}

}  // namespace
}  // namespace gonio::acquisition
