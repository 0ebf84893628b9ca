#pragma once

// Geometry of a spherical sample seen by the calibrated camera (camera_model.h): the sphere's
// centre from its silhouette, then for every pixel on it the surface point, the normal, the view
// direction and the local frame in which wi and wo are expressed.
//
// Silhouette: threshold of a frame lit from near the camera, largest external contour, each contour
// pixel moved to the sub-pixel threshold crossing along its radial line, algebraic
// circle fit (I. Kasa, "A circle fitting procedure and its error analysis", IEEE Trans. Instrum.
// Meas. IM-25(1), 1976: minimise sum (x^2 + y^2 + D x + E y + F)^2, linear in D, E, F), then a
// geometric refinement in 3D: every contour pixel's back-projected ray is tangent to the sphere,
// so the distance from the centre S to the ray (origin o, unit direction d),
//   dist(S) = |(S - o) - ((S - o) . d) d|,
// equals the radius R. Gauss-Newton on r_k = dist_k(S) - R with the analytic Jacobian
// d dist / dS = p / |p| (p the perpendicular part above). Contour points lying more than a few
// pixels inside the circle (where the lit region ends at the shadow terminator rather than at the
// limb) are trimmed between iterations. For a perspective camera R is the known physical radius
// (it fixes the distance); for an orthographic camera the depth of S along the axis is undefined
// and S is placed in the plane through the world origin perpendicular to the optical axis, R from
// the fit.
//
// Per pixel: the first intersection of the pixel's ray with the sphere, x = o + s d with
// s = -(w . d) - sqrt((w . d)^2 - (|w|^2 - R^2)), w = o - S; normal n = (x - S) / R;
// wo = -d (toward the camera). Local frame: z = n, x = the reference direction (world +z, the
// rig's vertical) projected on the tangent plane, y = z cross x; where the reference is parallel
// to n (within 1e-6) world +y is used instead. For an isotropic material only the angle between
// the projections of wi and wo matters, so the choice does not change the binned values.
//
// Anisotropic samples (docs/image-acquisition.md) are spheres turned on a lathe: the tool marks,
// the direction the material is brushed in, run along the circles of latitude about the lathe
// axis a, so the material's tangent at the normal n is t = (a x n) / |a x n|, defined everywhere
// but at the two poles n = +-a. The sphere is mounted with its lathe axis along the sample
// holder's local y (brdf/rig_geometry.h), so that at the point facing along the holder's normal
// the brushing runs along the holder's x axis, as on a flat sample (orientation_deg keeps its
// meaning); the holder's tilt and spin turn the axis (and with it every pixel's tangent) and leave
// the sphere, centred on the rig origin, where it is.

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "gonio/acquisition/image/camera_model.h"
#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::acquisition {

/// A circle in the image, pixels.
struct ImageCircle {
    double cx = 0;
    double cy = 0;
    double r = 0;
};

/// Kasa's algebraic circle fit through at least three points not on a line; error otherwise.
Expected<ImageCircle> fit_circle_algebraic(const std::vector<cv::Point2d>& points);

struct SphereGeometry {
    brdf::Vec3d centre{0, 0, 0};  ///< World frame, metres.
    double radius_m = 0;
    ImageCircle silhouette;      ///< The silhouette circle in the image (for the edge margin).
    double rms_residual_px = 0;  ///< RMS of the final fit's residuals, in pixels.
    int contour_points = 0;      ///< Contour points kept in the final fit.
};

struct SilhouetteOptions {
    /// Threshold between the background (median of the frame's border) and the 99.5th percentile,
    /// at least 5 noise sigmas (MAD of the border) above the background. Low, because a sphere lit
    /// from near the camera darkens toward its limb (the threshold contour lies inside the limb
    /// by about r t^2 / 2 for a Lambertian sphere and fraction t). A glossy sphere, whose pixels
    /// clear of the noise cover half as much again as that outline (the outline is its
    /// highlight's), is outlined at the same fraction of the median of those pixels instead.
    double threshold_fraction = 0.05;
    /// Physical radius of the sphere, metres (perspective cameras: fixes the distance).
    double radius_m = 0.02;
    /// Orthographic cameras: hold the radius at radius_m (a calibrated camera's pixels per metre
    /// and a sphere of known size) and fit only the centre. The outline's threshold crossing
    /// lies a fraction of a pixel off the limb (partly covered pixels, a limb darkening toward
    /// it), which a fitted radius takes up as a scale error of every normal's tangential part.
    bool orthographic_known_radius = false;
    /// Contour points deeper than this inside the fitted silhouette are trimmed (terminator).
    double trim_inside_px = 0.5;
    int iterations = 20;
};

/// Finds the sphere in a frame (any single-channel type; dark-subtracted or not) lit from close to
/// the camera; where a side light leaves a shadow crescent, the pixel-wise maximum of frames lit
/// from both sides of the camera has none (image_campaign does this). The frame's border must
/// show background. Errors: empty frame, nothing above the threshold, a contour too small (< 20
/// points), or a fit that does not converge, each named.
Expected<SphereGeometry> detect_sphere(const cv::Mat& frame,
                                       const CameraModel& camera,
                                       const SilhouetteOptions& options);

/// Rules that exclude pixels from measurement (radians; each exclusion is counted).
struct ExclusionRules {
    double max_theta_o = 80.0 * brdf::kPi / 180.0;  ///< Grazing view beyond this is excluded.
    double max_theta_i = 80.0 * brdf::kPi / 180.0;  ///< Grazing light beyond this is excluded.
    double edge_margin_px = 2.0;  ///< Pixels closer than this to the silhouette are excluded.
};

/// One pixel on the sphere: what the geometry says, independent of the light.
struct SpherePixel {
    int x = 0;
    int y = 0;
    brdf::Vec3d normal;    ///< World frame, unit.
    brdf::Vec3d wo_world;  ///< Toward the camera, unit.
    brdf::Vec3d tangent;   ///< Local x axis in the world frame (reference direction), unit.
};

/// Counts of the pixels of one frame by fate.
struct PixelCounts {
    std::uint64_t on_sphere = 0;      ///< Pixels whose ray meets the sphere.
    std::uint64_t edge = 0;           ///< Within the edge margin of the silhouette.
    std::uint64_t grazing_view = 0;   ///< theta_o > max_theta_o.
    std::uint64_t shadow = 0;         ///< n . l <= 0: in the sphere's own shadow.
    std::uint64_t grazing_light = 0;  ///< 0 < n . l but theta_i > max_theta_i.
    std::uint64_t saturated = 0;      ///< Saturated even at the shortest exposure.
    std::uint64_t nonfinite = 0;      ///< A non-finite value (never expected; counted, not used).
    std::uint64_t used = 0;           ///< Turned into a BRDF sample.
    /// Anisotropic image mode: within a pole cap of the turned sphere (no tangent).
    std::uint64_t pole = 0;

    PixelCounts& operator+=(const PixelCounts& o);
};

/// Pixels whose rays sphere_pixels() traces at a time (whole rows of the silhouette's box).
constexpr std::size_t kPixelsPerTile = std::size_t{1} << 18;

/// At most this many pixels pass sphere_pixels(): those within the silhouette's radius less the
/// edge margin (plus one pixel of slack), inside the image. The room sphere_pixels() reserves.
std::size_t sphere_pixel_bound(const CameraModel& camera,
                               const SphereGeometry& sphere,
                               const ExclusionRules& rules);

/// Pixels of the image whose ray meets the sphere, outside the edge margin and with theta_o within
/// the limit; the others are counted into `counts` (on_sphere, edge, grazing_view).
std::vector<SpherePixel> sphere_pixels(const CameraModel& camera,
                                       const SphereGeometry& sphere,
                                       const ExclusionRules& rules,
                                       PixelCounts* counts);

/// wi and wo in a pixel's local frame (z = normal, x = tangent) for a light direction in the
/// world frame (unit, toward the light).
std::pair<brdf::Vec3d, brdf::Vec3d> local_directions(const SpherePixel& p,
                                                     const brdf::Vec3d& light_world);

/// The tangent reference direction for a normal (file comment).
brdf::Vec3d reference_tangent(const brdf::Vec3d& normal);

/// The lathe axis of a turned sphere in the world frame for the holder's tilt and spin (radians):
/// the holder's local y, brdf::sample_to_world((0, 1, 0), tilt, spin).
brdf::Vec3d lathe_axis_world(double tilt_rad, double spin_rad);

/// The turned sphere's tangent (the brushing direction) at a unit normal: (a x n) / |a x n| for
/// the unit lathe axis a. Near a pole, where |a x n| < sin(pole_rad), the tangent turns faster
/// than the normal's error allows: returns the zero vector (the caller counts the pixel out).
brdf::Vec3d lathe_tangent(const brdf::Vec3d& normal, const brdf::Vec3d& axis, double pole_rad);

/// wi and wo in the frame (z = the pixel's normal, x = `tangent`, y = z x x) for a light direction
/// in the world frame (unit, toward the light); `tangent` unit and perpendicular to the normal.
std::pair<brdf::Vec3d, brdf::Vec3d> local_directions(const SpherePixel& p,
                                                     const brdf::Vec3d& tangent,
                                                     const brdf::Vec3d& light_world);

}  // namespace gonio::acquisition
