#include "gonio/sim/sphere_render.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "gonio/base/check.h"
#include "gonio/sim/camera_render.h"

namespace gonio::sim {
namespace {

struct WorldRay {
    brdf::Vec3d origin;
    brdf::Vec3d direction;
};

/// Rays of the given pixel positions (OpenCV pixel coordinates).
std::vector<WorldRay> rays_of(const SphereCamera& cam, const std::vector<cv::Point2d>& px) {
    std::vector<WorldRay> out(px.size());
    const Eigen::Matrix3d rt = cam.rotation.transpose();
    if (cam.projection == SphereProjection::kOrthographic) {
        const brdf::Vec3d dir = rt.col(2);
        for (std::size_t i = 0; i < px.size(); ++i) {
            const Eigen::Vector3d xc((px[i].x - cam.cx) / cam.fx, (px[i].y - cam.cy) / cam.fy, 0);
            out[i] = {rt * (xc - cam.translation), dir};
        }
        return out;
    }
    if (px.empty()) {
        return out;
    }
    std::vector<cv::Point2d> norm;
    const cv::Matx33d k(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(cam.distortion.data()));
    cv::undistortPoints(
        px,
        norm,
        cv::Mat(k),
        dist,
        cv::noArray(),
        cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
    const brdf::Vec3d c = -rt * cam.translation;
    for (std::size_t i = 0; i < px.size(); ++i) {
        out[i] = {c, (rt * Eigen::Vector3d(norm[i].x, norm[i].y, 1.0)).normalized()};
    }
    return out;
}

/// First intersection of a ray with the sphere; false when it misses.
bool intersect(const WorldRay& ray, const brdf::Vec3d& centre, double radius, brdf::Vec3d* hit) {
    const brdf::Vec3d w = ray.origin - centre;
    const double b = w.dot(ray.direction);
    const double disc = b * b - (w.squaredNorm() - radius * radius);
    if (!(disc > 0)) {
        // Miss, or a single tangent point (zero-area): background.
        return false;
    }
    const double s = -b - std::sqrt(disc);
    *hit = ray.origin + s * ray.direction;
    return true;
}

/// The surface's tangent at the normal n: the circle of latitude about the lathe axis when there
/// is one, else world +x projected (file comment).
brdf::Vec3d tangent_at(const brdf::Vec3d& n, const brdf::Vec3d& lathe_axis) {
    const brdf::Vec3d c = lathe_axis.cross(n);
    if (c.norm() > 1e-9) {
        return c.normalized();
    }
    // No lathe axis, or the pole itself: the reference tangent.
    brdf::Vec3d t = brdf::Vec3d(1, 0, 0) - n.x() * n;
    if (t.norm() < 1e-6) {
        // Normal along world x: use world +y as the reference.
        t = brdf::Vec3d(0, 1, 0) - n.y() * n;
    }
    return t.normalized();
}

/// Local frame (z = n, x = t, y = z x x) of a world vector.
brdf::Vec3d to_local(const brdf::Vec3d& n, const brdf::Vec3d& t, const brdf::Vec3d& v) {
    const brdf::Vec3d b = n.cross(t);
    return {v.dot(t), v.dot(b), v.dot(n)};
}

SpherePixelTruth truth_of(const SphereScene& scene, const WorldRay& ray) {
    SpherePixelTruth p;
    brdf::Vec3d x;
    if (!intersect(ray, scene.centre, scene.radius_m, &x)) {
        return p;
    }
    p.hit = true;
    p.normal_world = ((x - scene.centre) / scene.radius_m).normalized();
    const brdf::Vec3d t = tangent_at(p.normal_world, scene.lathe_axis);
    p.wi = to_local(p.normal_world, t, scene.light_world.normalized());
    p.wo = to_local(p.normal_world, t, -ray.direction);
    return p;
}

}  // namespace

std::vector<SpherePixelTruth> sphere_truth(const SphereScene& scene) {
    const SphereCamera& cam = scene.camera;
    std::vector<cv::Point2d> px;
    px.reserve(static_cast<std::size_t>(cam.width) * cam.height);
    for (int y = 0; y < cam.height; ++y) {
        for (int x = 0; x < cam.width; ++x) {
            px.emplace_back(x, y);
        }
    }
    const std::vector<WorldRay> rays = rays_of(cam, px);
    std::vector<SpherePixelTruth> out(rays.size());
    for (std::size_t i = 0; i < rays.size(); ++i) {
        out[i] = truth_of(scene, rays[i]);
    }
    return out;
}

namespace {

/// Sub-pixel rays traced per batch: whole pixel rows, about this many rays, so that a frame's
/// rays never need more than a few tens of megabytes whatever the camera's size.
constexpr std::size_t kRaysPerTile = std::size_t{1} << 18;

/// Adds the radiance of pixel rows [y0, y1) of `cam` to `out`: n x n sub-pixel rays per pixel,
/// each pixel's in the same order (sub-row j, then sub-column i) whatever the tile.
void render_rows(const brdf::Brdf& f,
                 const SphereScene& scene,
                 int y0,
                 int y1,
                 cv::Mat* out,
                 std::size_t* nonfinite) {
    const SphereCamera& cam = scene.camera;
    const int n = scene.supersample;
    std::vector<cv::Point2d> px;
    std::vector<int> owner;
    const std::size_t rays_in_tile = static_cast<std::size_t>(y1 - y0) * cam.width * n * n;
    px.reserve(rays_in_tile);
    owner.reserve(rays_in_tile);
    for (int y = y0; y < y1; ++y) {
        for (int x = 0; x < cam.width; ++x) {
            for (int j = 0; j < n; ++j) {
                for (int i = 0; i < n; ++i) {
                    px.emplace_back(x - 0.5 + (i + 0.5) / n, y - 0.5 + (j + 0.5) / n);
                    owner.push_back(y * cam.width + x);
                }
            }
        }
    }
    const std::vector<WorldRay> rays = rays_of(cam, px);
    const double weight = 1.0 / (n * n);
    float* data = out->ptr<float>();
    for (std::size_t k = 0; k < rays.size(); ++k) {
        const SpherePixelTruth t = truth_of(scene, rays[k]);
        if (!t.hit) {
            continue;
        }
        bool bad = false;
        const double l = patch_radiance(f, t.wi, t.wo, scene.irradiance_w_m2, scene.filter, &bad);
        if (bad && nonfinite != nullptr) {
            ++*nonfinite;
        }
        data[owner[k]] += static_cast<float>(weight * l);
    }
}

}  // namespace

cv::Mat render_sphere_radiance(const brdf::Brdf& f,
                               const SphereScene& scene,
                               std::size_t* nonfinite) {
    const SphereCamera& cam = scene.camera;
    GONIO_CHECK(cam.width > 0 && cam.height > 0 && scene.supersample >= 1 && scene.radius_m > 0);
    cv::Mat out(cam.height, cam.width, CV_32F, cv::Scalar(0));
    if (!scene.shutter_open) {
        // Dark frame: no light reaches the sample.
        return out;
    }
    // Row tiles: the rays of a whole frame (68 bytes each, n^2 per pixel) would be 1.4 GB on a
    // 5 MP camera at n = 2.
    const std::size_t rays_per_row =
        static_cast<std::size_t>(cam.width) * scene.supersample * scene.supersample;
    const int rows_per_tile =
        static_cast<int>(std::max<std::size_t>(1, kRaysPerTile / rays_per_row));
    for (int y0 = 0; y0 < cam.height; y0 += rows_per_tile) {
        render_rows(f, scene, y0, std::min(cam.height, y0 + rows_per_tile), &out, nonfinite);
    }
    return out;
}

devices::Frame frame_metadata(const SensorModel& sensor, const ExposureSettings& settings) {
    devices::Frame frame;
    frame.exposure_us = settings.exposure_us;
    frame.gain = settings.gain;
    frame.black_level = sensor.black_level(settings.format);
    frame.saturation_level = sensor.saturation_level(settings.format);
    frame.bit_depth = settings.format == devices::PixelFormat::kMono8    ? 8
                      : settings.format == devices::PixelFormat::kMono12 ? 12
                                                                         : 16;
    frame.linear = true;
    return frame;
}

devices::Frame render_sphere_frame(const brdf::Brdf& f,
                                   const SphereScene& scene,
                                   SensorModel& sensor,
                                   const ExposureSettings& settings) {
    devices::Frame frame = frame_metadata(sensor, settings);
    frame.image = sensor.expose(render_sphere_radiance(f, scene), settings);
    return frame;
}

}  // namespace gonio::sim
