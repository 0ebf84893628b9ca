#pragma once

// Camera placements of image mode: besides the wide view that shows the whole sphere, a rig may
// have zoomed views (a longer lens, or the camera moved closer on a slide) that show a small patch
// of the sphere at a higher magnification. The first theta_h rows of a MERL table are 0.01 to
// 0.4 degrees wide: around the highlight of a wide view they get a few pixels each, too few for
// their 180 phi_d bins; a view magnified m times puts m^2 as many pixels on them.
//
// A placement is the wide camera model (camera_model.h) with
//   - its focal length (perspective: px; telecentric: px per metre) multiplied by `magnification`,
//   - the camera moved by `offset_m` = (ox, oy) across its optical axis, in the camera's own x
//     (image right) and y (image down) directions: x_c' = R x_w + t - (ox, oy, 0),
// so that the point of the plane through the rig origin at (ox, oy) from the axis is imaged at
// the principal point. The sensor, its principal point, the distortion and the orientation are
// the wide camera's (a real zoom lens is calibrated at each of its settings; a rig that has
// calibrated them gives them in its own camera model). The sphere stays where the wide view
// found it: a placement's pixels map to normals through the same sphere, seen by the placement's
// camera (placement_sphere).
//
// Rig description ("placements": one object per zoomed view, docs/image-acquisition.md):
//   {"name": "zoom-1", "magnification": 8, "offset_m": [0.004, 0], "unit": 10, "coil": 0}
// The coil (on the shutter's bus unless "address" is given) switches the view in: while it is on
// the camera sees through that placement, while every placement's coil is off, the wide view.

#include <array>
#include <string>
#include <vector>

#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/image/sphere_geometry.h"

namespace gonio::acquisition {

struct Placement {
    std::string name;
    double magnification = 1;              ///< Relative to the wide view, >= 1.
    std::array<double, 2> offset_m{0, 0};  ///< Camera x, y offset across the axis, metres.
};

/// The camera model of a placement: the wide camera `wide` magnified and moved (file comment).
CameraModel placement_camera(const CameraModel& wide, const Placement& p);

/// The sphere `wide_sphere` (found in the wide view) as the placement's camera `camera` sees it:
/// the same centre and radius in the world, the silhouette circle projected into the
/// placement's image (centre projected, radius times the magnification).
SphereGeometry placement_sphere(const SphereGeometry& wide_sphere,
                                const CameraModel& camera,
                                double magnification);

/// The exclusion rules in a placement's pixels: the edge margin, a distance on the sphere's
/// outline, scaled by the magnification.
ExclusionRules placement_rules(const ExclusionRules& wide_rules, double magnification);

/// Whether the highlight of a light toward `light_world` (unit) falls inside the placement's
/// frame, at least `margin_fraction` of the frame's smaller side from its border: the point of
/// the sphere whose normal is the half vector of the light and the view (the view toward the
/// camera: along minus the optical axis for a telecentric camera, toward the camera centre for
/// a perspective one).
bool placement_sees_highlight(const CameraModel& camera,
                              const SphereGeometry& sphere,
                              const brdf::Vec3d& light_world,
                              double margin_fraction = 0.05);

}  // namespace gonio::acquisition
