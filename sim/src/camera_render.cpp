// Radiance seen by the simulated camera's pixels.

#include "gonio/sim/camera_render.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"

namespace gonio::sim {

using brdf::Vec3d;

bool in_point_patch(double x, double y, int sensor_width, int sensor_height) {
    const double r = 0.25 * std::min(sensor_width, sensor_height);
    const double dx = x - 0.5 * sensor_width;
    const double dy = y - 0.5 * sensor_height;
    return dx * dx + dy * dy <= r * r;
}

double patch_radiance(const brdf::Brdf& f,
                      const Vec3d& wi,
                      const Vec3d& wo,
                      double irradiance_w_m2,
                      const brdf::Rgbd& filter,
                      bool* nonfinite) {
    const double cos_theta_i = wi.z();
    const double cos_theta_o = wo.z();
    // Light or detector at or below the horizon: no reflected radiance reaches the pixel.
    if (cos_theta_i <= 0 || cos_theta_o <= 0) {
        return 0.0;
    }
    const brdf::Rgbd fr = f.eval(wi, wo);
    const double f_mono = (filter * fr).sum();
    if (!std::isfinite(f_mono)) {
        // A non-finite BRDF value is reported, not propagated into the image.
        if (nonfinite != nullptr) {
            *nonfinite = true;
        }
        return 0.0;
    }
    return f_mono * irradiance_w_m2 * cos_theta_i;
}

double patch_radiance_over(const brdf::Brdf& f, const SceneState& scene) {
    if (scene.path.empty()) {
        return patch_radiance(
            f, scene.wi.normalized(), scene.wo.normalized(), scene.irradiance_w_m2, scene.filter);
    }
    double sum = 0;
    for (const brdf::PathNode& n : scene.path) {
        sum += n.weight * patch_radiance(f, n.wi, n.wo, scene.irradiance_w_m2, scene.filter);
    }
    return sum;
}

namespace {

// Right-handed frame (t, b, n) with n the given unit normal.
void frame_from(const Vec3d& n, Vec3d* t, Vec3d* b) {
    // Pick the axis least aligned with n for a well-conditioned cross product.
    const Vec3d a = std::abs(n.x()) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
    *t = a.cross(n).normalized();
    *b = n.cross(*t);
}

}  // namespace

GeometryFn scene_geometry(const SceneState& scene, int sensor_width, int sensor_height) {
    if (scene.shape == SampleShape::kFlatPatch) {
        const Vec3d wi = scene.wi.normalized();
        const Vec3d wo = scene.wo.normalized();
        return [=](double x, double y) {
            PixelGeometry g;
            g.valid = in_point_patch(x, y, sensor_width, sensor_height);
            g.wi = wi;
            g.wo = wo;
            return g;
        };
    }
    // Sphere seen by an orthographic camera looking along -wo.
    const Vec3d wo = scene.wo.normalized();
    const Vec3d wi = scene.wi.normalized();
    Vec3d e1 = Vec3d(0, 1, 0).cross(wo);
    if (e1.norm() < 1e-9) {
        // wo along +-y: the y axis cannot define "right"; use x.
        e1 = Vec3d(1, 0, 0);
    }
    e1.normalize();
    const Vec3d e2 = wo.cross(e1);
    const double radius =
        scene.sphere_radius_fraction * 0.5 * std::min(sensor_width, sensor_height);
    const double cx = 0.5 * sensor_width;
    const double cy = 0.5 * sensor_height;
    return [=](double x, double y) {
        PixelGeometry g;
        const double u = (x - cx) / radius;
        const double v = (y - cy) / radius;
        const double r2 = u * u + v * v;
        if (radius <= 0 || r2 >= 1) {
            return g;  // background
        }
        const Vec3d n = u * e1 - v * e2 + std::sqrt(1 - r2) * wo;
        Vec3d t, b;
        frame_from(n, &t, &b);
        g.valid = true;
        g.wi = Vec3d(wi.dot(t), wi.dot(b), wi.dot(n));
        g.wo = Vec3d(wo.dot(t), wo.dot(b), wo.dot(n));
        return g;
    };
}

cv::Mat render_radiance(const brdf::Brdf& f,
                        const GeometryFn& geometry,
                        double irradiance_w_m2,
                        const brdf::Rgbd& filter,
                        const devices::Roi& roi) {
    GONIO_CHECK(roi.width > 0 && roi.height > 0);
    cv::Mat out(roi.height, roi.width, CV_32F, cv::Scalar(0));
    // Rows in parallel: BRDF evaluation is const without shared mutable state (brdf/resample.h
    // relies on it too), and so must the geometry be (scene_geometry's are pure functions of
    // the pixel).
    cv::parallel_for_(cv::Range(0, roi.height), [&](const cv::Range& rows) {
        for (int y = rows.start; y < rows.end; ++y) {
            float* row = out.ptr<float>(y);
            for (int x = 0; x < roi.width; ++x) {
                const PixelGeometry g = geometry(roi.x + x + 0.5, roi.y + y + 0.5);
                if (!g.valid) {
                    continue;
                }
                row[x] = static_cast<float>(patch_radiance(f, g.wi, g.wo, irradiance_w_m2, filter));
            }
        }
    });
    return out;
}

cv::Mat render_scene(const brdf::Brdf& f,
                     const SceneState& scene,
                     int sensor_width,
                     int sensor_height,
                     const devices::Roi& roi) {
    GONIO_CHECK(roi.width > 0 && roi.height > 0);
    // Shutter closed: no light reaches the sample.
    if (!scene.shutter_open) {
        return cv::Mat(roi.height, roi.width, CV_32F, cv::Scalar(0));
    }
    if (scene.shape != SampleShape::kFlatPatch) {
        return render_radiance(f,
                               scene_geometry(scene, sensor_width, sensor_height),
                               scene.irradiance_w_m2,
                               scene.filter,
                               roi);
    }
    // Point mode: one geometry for the whole patch, one BRDF evaluation (or the mean over the
    // stages' path during the exposure).
    const float L =
        static_cast<float>(patch_radiance_over(f, scene) + scene.stray_radiance_w_m2_sr);
    cv::Mat out(roi.height, roi.width, CV_32F);
    const double r = 0.25 * std::min(sensor_width, sensor_height);
    const double cx = 0.5 * sensor_width;
    // Rows in parallel (a 5 MP frame is 20 MB of radiance): each row is cleared, then the disc's
    // chord on it is filled.
    cv::parallel_for_(cv::Range(0, roi.height), [&](const cv::Range& rows) {
        for (int y = rows.start; y < rows.end; ++y) {
            float* row = out.ptr<float>(y);
            std::fill(row, row + roi.width, 0.0f);
            const double dy = roi.y + y + 0.5 - 0.5 * sensor_height;
            if (dy * dy > r * r) {
                continue;
            }
            // The pixel centres inside the chord: bracketed from its ends, then the ends found
            // with the same test as in_point_patch (a disc's row section is one interval).
            const double half = std::sqrt(r * r - dy * dy);
            int x0 = std::max(0, static_cast<int>(std::floor(cx - half - roi.x - 0.5)) - 1);
            int x1 = std::min(roi.width, static_cast<int>(std::ceil(cx + half - roi.x - 0.5)) + 2);
            const auto inside = [&](int x) {
                return in_point_patch(
                    roi.x + x + 0.5, roi.y + y + 0.5, sensor_width, sensor_height);
            };
            while (x0 < x1 && !inside(x0)) {
                ++x0;
            }
            while (x1 > x0 && !inside(x1 - 1)) {
                --x1;
            }
            std::fill(row + x0, row + x1, L);
        }
    });
    return out;
}

}  // namespace gonio::sim
