#include "gonio/acquisition/image/placement.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"

namespace gonio::acquisition {

CameraModel placement_camera(const CameraModel& wide, const Placement& p) {
    GONIO_CHECK_MSG(p.magnification > 0 && std::isfinite(p.magnification) &&
                        std::isfinite(p.offset_m[0]) && std::isfinite(p.offset_m[1]),
                    "placement " << p.name << ": magnification " << p.magnification);
    CameraModel c = wide;
    c.intrinsics.fx *= p.magnification;
    c.intrinsics.fy *= p.magnification;
    // The camera moved by (ox, oy) along its own x and y: every point's camera coordinates move
    // by minus that.
    c.translation -= Eigen::Vector3d(p.offset_m[0], p.offset_m[1], 0);
    return c;
}

SphereGeometry placement_sphere(const SphereGeometry& wide_sphere,
                                const CameraModel& camera,
                                double magnification) {
    SphereGeometry s = wide_sphere;
    const Eigen::Vector2d c = camera.project(wide_sphere.centre);
    s.silhouette.cx = c.x();
    s.silhouette.cy = c.y();
    s.silhouette.r = wide_sphere.silhouette.r * magnification;
    return s;
}

ExclusionRules placement_rules(const ExclusionRules& wide_rules, double magnification) {
    ExclusionRules r = wide_rules;
    r.edge_margin_px = wide_rules.edge_margin_px * magnification;
    return r;
}

bool placement_sees_highlight(const CameraModel& camera,
                              const SphereGeometry& sphere,
                              const brdf::Vec3d& light_world,
                              double margin_fraction) {
    const brdf::Vec3d v = camera.projection == Projection::kOrthographic
                              ? brdf::Vec3d(-camera.axis_world())
                              : brdf::Vec3d((camera.centre_world() - sphere.centre).normalized());
    const brdf::Vec3d sum = light_world + v;
    if (sum.norm() < 1e-9) {
        // Light opposite the camera: the highlight is on the limb, nowhere in the image.
        return false;
    }
    const brdf::Vec3d h = sum.normalized();
    const Eigen::Vector2d px = camera.project(sphere.centre + sphere.radius_m * h);
    if (!px.allFinite()) {
        return false;
    }
    const CameraIntrinsics& k = camera.intrinsics;
    const double margin = margin_fraction * std::min(k.width, k.height);
    return px.x() >= margin && px.x() <= k.width - 1 - margin && px.y() >= margin &&
           px.y() <= k.height - 1 - margin;
}

}  // namespace gonio::acquisition
