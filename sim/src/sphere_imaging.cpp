#include "gonio/sim/sphere_imaging.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::sim {

SphereCamera sphere_camera_at_arm(const SphereCamera& at_zero, double arm_rad) {
    const double c = std::cos(arm_rad);
    const double s = std::sin(arm_rad);
    Eigen::Matrix3d rz;
    rz << c, -s, 0, s, c, 0, 0, 0, 1;
    SphereCamera cam = at_zero;
    cam.rotation = at_zero.rotation * rz.transpose();
    return cam;
}

SphereCamera zoomed_camera(const SphereCamera& camera, const ZoomPlacement& placement) {
    SphereCamera c = camera;
    c.fx *= placement.magnification;
    c.fy *= placement.magnification;
    c.translation -= Eigen::Vector3d(placement.offset_m[0], placement.offset_m[1], 0);
    return c;
}

SphereScene sphere_scene(const SphereImaging& imaging, const SceneState& state) {
    SphereScene scene;
    scene.camera = sphere_camera_at_arm(imaging.camera, state.detector_arm_rad);
    if (state.placement > 0 && state.placement <= static_cast<int>(imaging.placements.size())) {
        // The camera's own translation is unchanged by the arm's turn: move it after.
        scene.camera = zoomed_camera(
            scene.camera, imaging.placements[static_cast<std::size_t>(state.placement - 1)]);
    }
    scene.centre = imaging.centre;
    scene.radius_m = imaging.radius_m;
    scene.supersample = imaging.supersample;
    scene.light_world = brdf::arm_direction(state.light_arm_rad);
    scene.irradiance_w_m2 = state.irradiance_w_m2;
    scene.filter = state.filter;
    scene.shutter_open = state.shutter_open;
    // The holder's tilt and spin turn the sphere about its centre: its image stays, its tangent
    // field (the lathe axis along the holder's local y) turns with them.
    scene.lathe_axis = brdf::sample_to_world(brdf::Vec3d(0, 1, 0), state.tilt_rad, state.spin_rad);
    return scene;
}

RadianceFn sphere_renderer(SphereImaging imaging) {
    GONIO_CHECK(imaging.camera.width > 0 && imaging.camera.height > 0 && imaging.supersample >= 1 &&
                imaging.radius_m > 0);
    return [imaging](const brdf::Brdf& f,
                     const SceneState& state,
                     int /*sensor_width*/,
                     int /*sensor_height*/,
                     const devices::Roi& roi) -> cv::Mat {
        cv::Mat out(roi.height, roi.width, CV_32F, cv::Scalar(0));
        if (!state.shutter_open) {
            return out;
        }
        const cv::Mat full = render_sphere_radiance(f, sphere_scene(imaging, state));
        const int x0 = std::max(roi.x, 0);
        const int y0 = std::max(roi.y, 0);
        const int x1 = std::min(roi.x + roi.width, full.cols);
        const int y1 = std::min(roi.y + roi.height, full.rows);
        if (x1 > x0 && y1 > y0) {
            full(cv::Rect(x0, y0, x1 - x0, y1 - y0))
                .copyTo(out(cv::Rect(x0 - roi.x, y0 - roi.y, x1 - x0, y1 - y0)));
        }
        return out;
    };
}

}  // namespace gonio::sim
