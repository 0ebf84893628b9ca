#include "gonio/acquisition/image/sphere_geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <tuple>

#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {

PixelCounts& PixelCounts::operator+=(const PixelCounts& o) {
    on_sphere += o.on_sphere;
    edge += o.edge;
    grazing_view += o.grazing_view;
    shadow += o.shadow;
    grazing_light += o.grazing_light;
    saturated += o.saturated;
    nonfinite += o.nonfinite;
    used += o.used;
    pole += o.pole;
    return *this;
}

Expected<ImageCircle> fit_circle_algebraic(const std::vector<cv::Point2d>& points) {
    if (points.size() < 3) {
        return make_error("circle fit: " + std::to_string(points.size()) +
                          " points, need at least 3");
    }
    // Centre the data for conditioning, then solve [x y 1] [D E F]^T = -(x^2 + y^2).
    double mx = 0;
    double my = 0;
    for (const auto& p : points) {
        mx += p.x;
        my += p.y;
    }
    mx /= points.size();
    my /= points.size();
    Eigen::MatrixXd a(points.size(), 3);
    Eigen::VectorXd b(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double x = points[i].x - mx;
        const double y = points[i].y - my;
        a(i, 0) = x;
        a(i, 1) = y;
        a(i, 2) = 1;
        b[i] = -(x * x + y * y);
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
    if (qr.rank() < 3) {
        // Collinear points: no circle through them.
        return make_error("circle fit: points are collinear");
    }
    const Eigen::Vector3d s = qr.solve(b);
    ImageCircle c;
    c.cx = -s[0] / 2 + mx;
    c.cy = -s[1] / 2 + my;
    const double r2 = s[0] * s[0] / 4 + s[1] * s[1] / 4 - s[2];
    if (!(r2 > 0) || !std::isfinite(r2)) {
        return make_error("circle fit: no real circle (r^2 = " + std::to_string(r2) + ")");
    }
    c.r = std::sqrt(r2);
    return c;
}

namespace {

/// Distance from point s to a ray and its gradient with respect to s.
double ray_distance(const brdf::Vec3d& s, const Ray& ray, brdf::Vec3d* grad) {
    const brdf::Vec3d w = s - ray.origin;
    const brdf::Vec3d p = w - w.dot(ray.direction) * ray.direction;
    const double d = p.norm();
    if (grad != nullptr) {
        // At d = 0 (the centre on the ray) the gradient is undefined; zero keeps the step finite.
        *grad = d > 0 ? brdf::Vec3d(p / d) : brdf::Vec3d::Zero();
    }
    return d;
}

/// The 99.5th percentile of a single-channel image's values (as float).
double high_percentile(const cv::Mat& f) {
    std::vector<float> v;
    v.reserve(f.total());
    for (int y = 0; y < f.rows; ++y) {
        const float* row = f.ptr<float>(y);
        v.insert(v.end(), row, row + f.cols);
    }
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(0.995 * v.size()));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

/// Median of the values (the vector is reordered).
double median_of(std::vector<float> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return static_cast<double>(v[v.size() / 2]);
}

/// Background level and noise from the frame's border (robust: median and MAD), so that the
/// threshold stays clear of the noise whatever the sphere's brightness.
struct Background {
    double level = 0;
    double noise_sigma = 0;
};
Background border_background(const cv::Mat& f) {
    std::vector<float> border;
    for (int x = 0; x < f.cols; ++x) {
        border.push_back(f.at<float>(0, x));
        border.push_back(f.at<float>(f.rows - 1, x));
    }
    for (int y = 1; y + 1 < f.rows; ++y) {
        border.push_back(f.at<float>(y, 0));
        border.push_back(f.at<float>(y, f.cols - 1));
    }
    Background b;
    b.level = median_of(border);
    for (float& v : border) {
        v = static_cast<float>(std::abs(v - b.level));
    }
    b.noise_sigma = 1.4826 * median_of(border);
    return b;
}

/// Largest outline above a threshold, and its area.
std::pair<std::vector<cv::Point>, double> largest_outline(const cv::Mat& f, double threshold) {
    cv::Mat mask;
    cv::threshold(f, mask, threshold, 255, cv::THRESH_BINARY);
    mask.convertTo(mask, CV_8U);
    // Close small holes (noise, dark texture) before taking the outline.
    cv::morphologyEx(
        mask, mask, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    std::vector<cv::Point> best;
    double best_area = -1;
    for (auto& c : contours) {
        const double a = cv::contourArea(c);
        if (a > best_area) {
            best_area = a;
            best = std::move(c);
        }
    }
    return std::make_pair(std::move(best), std::max(best_area, 0.0));
}

/// The outline of the lit sphere and the threshold that gave it.
struct Outline {
    std::vector<cv::Point> contour;
    double threshold = 0;
    bool glossy = false;  ///< The threshold was taken at the sphere's level, not its highlight's.
};

Outline sphere_outline(const cv::Mat& f,
                       const Background& bg,
                       double hi,
                       const SilhouetteOptions& options) {
    const double lo = bg.level;
    const double floor = lo + 5 * bg.noise_sigma;
    Outline o;
    o.threshold = std::max(lo + options.threshold_fraction * (hi - lo), floor);
    double area = 0;
    std::tie(o.contour, area) = largest_outline(f, o.threshold);
    // A glossy sphere: its highlight is orders of magnitude above the rest of it, and a threshold
    // at a fraction of the highlight outlines the highlight instead of the limb. When the pixels
    // clear of the noise cover half as much again as that outline, the threshold is taken at the
    // same fraction of their median instead (the level of the sphere, not of its highlight).
    std::vector<float> object;
    for (int y = 0; y < f.rows; ++y) {
        const float* row = f.ptr<float>(y);
        for (int x = 0; x < f.cols; ++x) {
            if (row[x] > floor) {
                object.push_back(row[x]);
            }
        }
    }
    if (object.size() >= 20 && static_cast<double>(object.size()) > 1.5 * area) {
        o.glossy = true;
        const double level = median_of(std::move(object));
        o.threshold = std::max(lo + options.threshold_fraction * (level - lo), floor);
        std::tie(o.contour, area) = largest_outline(f, o.threshold);
    }
    return o;
}

/// The frame bilinearly interpolated at (x, y); `outside` beyond its pixels.
double bilinear(const cv::Mat& f, double x, double y, double outside) {
    const int x0 = static_cast<int>(std::floor(x));
    const int y0 = static_cast<int>(std::floor(y));
    if (x0 < 0 || y0 < 0 || x0 + 1 >= f.cols || y0 + 1 >= f.rows) {
        return outside;
    }
    const double ax = x - x0;
    const double ay = y - y0;
    return (1 - ay) * ((1 - ax) * f.at<float>(y0, x0) + ax * f.at<float>(y0, x0 + 1)) +
           ay * ((1 - ax) * f.at<float>(y0 + 1, x0) + ax * f.at<float>(y0 + 1, x0 + 1));
}

/// A glossy sphere's limb is a step (its tails do not fade to zero there, as a Lambertian limb
/// lit from the camera does), blurred by the pixels: its edge is where the profile `at(q)` (q
/// along the outward radial line) crosses half way between the background and the level 2 px
/// inside `edge`, which a threshold near the background would place outside.
template <class Profile>
double glossy_edge(double edge, double background, Profile at, double step) {
    const double half = 0.5 * (background + at(edge - 2));
    double q_prev = edge + 1;
    double w_prev = at(q_prev);
    for (double q = edge + 1 - step; q >= edge - 2; q -= step) {
        const double w = at(q);
        if (w >= half && w_prev < half) {
            return q + (half - w) / (w_prev - w) * (q_prev - q);
        }
        q_prev = q;
        w_prev = w;
    }
    return edge;
}

/// Sub-pixel boundary: along the radial line through each contour pixel, the outermost place
/// where the bilinearly interpolated frame crosses the threshold.
std::vector<cv::Point2d> subpixel_boundary(const cv::Mat& f,
                                           const std::vector<cv::Point2d>& pixel_pts,
                                           const ImageCircle& coarse,
                                           const Outline& o,
                                           double lo) {
    std::vector<cv::Point2d> pts;
    for (const cv::Point2d& p : pixel_pts) {
        const double dx = p.x - coarse.cx;
        const double dy = p.y - coarse.cy;
        const double n = std::hypot(dx, dy);
        if (!(n > 0)) {
            // A contour pixel at the centre: no radial direction (a degenerate blob).
            continue;
        }
        const double ux = dx / n;
        const double uy = dy / n;
        const auto at = [&](double s) { return bilinear(f, p.x + s * ux, p.y + s * uy, lo); };
        constexpr double kStep = 0.05;
        double prev_s = 2.0;
        double prev_v = at(prev_s);
        for (double s = 2.0 - kStep; s >= -2.0; s -= kStep) {
            const double v = at(s);
            if (v >= o.threshold && prev_v < o.threshold) {
                const double t = (o.threshold - v) / (prev_v - v);
                double edge = s + t * (prev_s - s);
                if (o.glossy) {
                    edge = glossy_edge(edge, lo, at, kStep);
                }
                pts.emplace_back(p.x + edge * ux, p.y + edge * uy);
                break;
            }
            prev_s = s;
            prev_v = v;
        }
    }
    return pts;
}

/// Trim points inside the circle (where the lit region ends at the shadow terminator rather than
/// at the limb) and refit, a few times; the points kept.
std::vector<cv::Point2d> trim_terminator(const std::vector<cv::Point2d>& pts,
                                         const SilhouetteOptions& options,
                                         ImageCircle* circle) {
    std::vector<cv::Point2d> kept = pts;
    for (int round = 0; round < 5; ++round) {
        std::vector<cv::Point2d> next;
        for (const auto& p : pts) {
            if (std::hypot(p.x - circle->cx, p.y - circle->cy) >
                circle->r - options.trim_inside_px) {
                next.push_back(p);
            }
        }
        if (next.size() < 20) {
            break;
        }
        auto c2 = fit_circle_algebraic(next);
        if (!c2) {
            break;
        }
        kept = std::move(next);
        *circle = *c2;
    }
    return kept;
}

/// The image circle with sub-pixel limb points (the outline, its coarse circle, the boundary,
/// the terminator trimmed); `kept` receives the points the circle was fitted to.
Expected<ImageCircle> silhouette_circle(const cv::Mat& f,
                                        const Background& bg,
                                        const Outline& o,
                                        const SilhouetteOptions& options,
                                        std::vector<cv::Point2d>* kept) {
    if (o.contour.empty()) {
        return make_error("sphere detection: nothing above the threshold " +
                          std::to_string(o.threshold));
    }
    if (o.contour.size() < 20) {
        return make_error("sphere detection: largest contour has " +
                          std::to_string(o.contour.size()) + " points, need at least 20");
    }
    std::vector<cv::Point2d> pixel_pts;
    for (const cv::Point& p : o.contour) {
        pixel_pts.emplace_back(p.x, p.y);
    }
    auto coarse = fit_circle_algebraic(pixel_pts);
    if (!coarse) {
        return make_error("sphere detection: " + coarse.error().message);
    }
    const std::vector<cv::Point2d> pts = subpixel_boundary(f, pixel_pts, *coarse, o, bg.level);
    auto circle = fit_circle_algebraic(pts);
    if (!circle) {
        return make_error("sphere detection: " + circle.error().message);
    }
    *kept = trim_terminator(pts, options, &*circle);
    return circle;
}

/// The sphere's first estimate from its image circle. Orthographic: depth along the axis is
/// unobservable, the centre goes in the plane through the origin. Perspective: angular radius
/// from the circle, distance from the known physical radius.
Expected<void> initial_sphere(const CameraModel& camera,
                              const ImageCircle& circle,
                              const SilhouetteOptions& options,
                              SphereGeometry* g) {
    const Ray centre_ray = camera.pixel_ray(circle.cx, circle.cy);
    if (camera.projection == Projection::kOrthographic) {
        const double s = -centre_ray.origin.dot(centre_ray.direction);
        g->centre = centre_ray.origin + s * centre_ray.direction;
        g->radius_m =
            options.orthographic_known_radius ? options.radius_m : circle.r / camera.intrinsics.fx;
        return {};
    }
    const Ray edge = camera.pixel_ray(circle.cx + circle.r, circle.cy);
    const double alpha = std::acos(std::clamp(edge.direction.dot(centre_ray.direction), -1.0, 1.0));
    if (!(alpha > 0)) {
        return make_error("sphere detection: zero apparent radius");
    }
    g->radius_m = options.radius_m;
    g->centre = centre_ray.origin + centre_ray.direction * (options.radius_m / std::sin(alpha));
    return {};
}

/// Geometric refinement: contour rays tangent to the sphere. Perspective: unknown centre (3),
/// radius known. Orthographic: centre moves in the plane perpendicular to the axis (2) and the
/// radius (1) is unknown unless given. Returns the rms distance of the rays from the sphere, m.
Expected<double> refine_sphere(const CameraModel& camera,
                               const std::vector<Ray>& rays,
                               const SilhouetteOptions& options,
                               SphereGeometry* g) {
    const bool ortho = camera.projection == Projection::kOrthographic;
    const bool fit_radius = ortho && !options.orthographic_known_radius;
    const brdf::Vec3d axis = camera.axis_world();
    brdf::Vec3d e1 = axis.unitOrthogonal();
    brdf::Vec3d e2 = axis.cross(e1);
    double rms = 0;
    for (int it = 0; it < options.iterations; ++it) {
        Eigen::MatrixXd jac(rays.size(), 3);
        Eigen::VectorXd res(rays.size());
        for (std::size_t k = 0; k < rays.size(); ++k) {
            brdf::Vec3d grad;
            res[k] = ray_distance(g->centre, rays[k], &grad) - g->radius_m;
            if (ortho) {
                jac(k, 0) = grad.dot(e1);
                jac(k, 1) = grad.dot(e2);
                // A known radius: no change (a zero column, the step's third component 0).
                jac(k, 2) = fit_radius ? -1 : 0;
            } else {
                jac.row(k) = grad.transpose();
            }
        }
        const Eigen::Vector3d step = jac.colPivHouseholderQr().solve(-res);
        if (!step.allFinite()) {
            return make_error("sphere detection: the least-squares refinement diverged");
        }
        if (ortho) {
            g->centre += step[0] * e1 + step[1] * e2;
            if (fit_radius) {
                g->radius_m += step[2];
            }
        } else {
            g->centre += step;
        }
        rms = std::sqrt(res.squaredNorm() / res.size());
        if (step.norm() < 1e-12 * std::max(1.0, g->radius_m)) {
            break;
        }
    }
    if (!(g->radius_m > 0) || !g->centre.allFinite()) {
        return make_error("sphere detection: the refinement gave no valid sphere");
    }
    return rms;
}

}  // namespace

Expected<SphereGeometry> detect_sphere(const cv::Mat& frame,
                                       const CameraModel& camera,
                                       const SilhouetteOptions& options) {
    if (frame.empty() || frame.channels() != 1) {
        return make_error("sphere detection: the frame must be a non-empty single-channel image");
    }
    cv::Mat f;
    frame.convertTo(f, CV_32F);
    const Background bg = border_background(f);
    const double hi = high_percentile(f);
    if (!(hi > bg.level + 5 * bg.noise_sigma) || !(hi > bg.level)) {
        return make_error("sphere detection: the frame is uniform (nothing lit above the noise)");
    }
    std::vector<cv::Point2d> kept;
    auto circle = silhouette_circle(f, bg, sphere_outline(f, bg, hi, options), options, &kept);
    if (!circle) {
        return tl::unexpected(circle.error());
    }
    SphereGeometry g;
    g.silhouette = *circle;
    std::vector<Ray> rays = camera.pixel_rays(kept);
    if (auto s = initial_sphere(camera, *circle, options, &g); !s) {
        return tl::unexpected(s.error());
    }
    auto rms = refine_sphere(camera, rays, options, &g);
    if (!rms) {
        return tl::unexpected(rms.error());
    }
    // Residuals in pixels: metres at the sphere's distance times pixels per metre.
    const bool ortho = camera.projection == Projection::kOrthographic;
    const double px_per_m =
        ortho ? camera.intrinsics.fx
              : camera.intrinsics.fx / std::max((g.centre - camera.centre_world()).norm(), 1e-12);
    g.rms_residual_px = *rms * px_per_m;
    g.contour_points = static_cast<int>(rays.size());
    // Silhouette circle consistent with the refined sphere (used for the edge margin).
    const Eigen::Vector2d c_px = camera.project(g.centre);
    if (c_px.allFinite()) {
        g.silhouette.cx = c_px.x();
        g.silhouette.cy = c_px.y();
        // Orthographic: radius times pixels per metre; perspective: the fitted image circle's
        // radius (the outline of an off-axis sphere is slightly elliptical; the margin is small).
        g.silhouette.r = ortho ? g.radius_m * camera.intrinsics.fx : circle->r;
    }
    return g;
}

brdf::Vec3d reference_tangent(const brdf::Vec3d& normal) {
    brdf::Vec3d r(0, 0, 1);
    brdf::Vec3d t = r - r.dot(normal) * normal;
    if (t.norm() < 1e-6) {
        // Normal along the vertical: fall back to world +y.
        r = brdf::Vec3d(0, 1, 0);
        t = r - r.dot(normal) * normal;
    }
    return t.normalized();
}

namespace {

/// Bounding rows and columns of the silhouette (two pixels of margin) within the image.
struct PixelBox {
    int x0 = 0;
    int x1 = -1;
    int y0 = 0;
    int y1 = -1;
};

PixelBox silhouette_box(const CameraModel& camera, const ImageCircle& c) {
    PixelBox b;
    b.x0 = std::max(0, static_cast<int>(std::floor(c.cx - c.r - 2)));
    b.x1 = std::min(camera.intrinsics.width - 1, static_cast<int>(std::ceil(c.cx + c.r + 2)));
    b.y0 = std::max(0, static_cast<int>(std::floor(c.cy - c.r - 2)));
    b.y1 = std::min(camera.intrinsics.height - 1, static_cast<int>(std::ceil(c.cy + c.r + 2)));
    return b;
}

/// How many pixels of the box lie within `radius` of the centre (those the edge test keeps at
/// most): the room sphere_pixels() reserves, so that its list never grows by reallocation.
std::size_t pixels_within(const PixelBox& b, const ImageCircle& c, double radius) {
    if (!(radius > 0)) {
        return 0;
    }
    std::size_t n = 0;
    for (int y = b.y0; y <= b.y1; ++y) {
        const double dy = y - c.cy;
        if (std::abs(dy) > radius) {
            continue;
        }
        const double half = std::sqrt(radius * radius - dy * dy);
        const int lo = std::max(b.x0, static_cast<int>(std::ceil(c.cx - half)));
        const int hi = std::min(b.x1, static_cast<int>(std::floor(c.cx + half)));
        n += hi >= lo ? static_cast<std::size_t>(hi - lo + 1) : 0;
    }
    return n;
}

/// Rows [y0, y1) of the box: each pixel whose ray meets the sphere within the rules appended to
/// `out`, the others counted.
void trace_rows(const CameraModel& camera,
                const SphereGeometry& sphere,
                const ExclusionRules& rules,
                const PixelBox& box,
                int y0,
                int y1,
                std::vector<SpherePixel>* out,
                PixelCounts* counts) {
    const ImageCircle& c = sphere.silhouette;
    std::vector<cv::Point2d> px;
    px.reserve(static_cast<std::size_t>(y1 - y0) * (box.x1 - box.x0 + 1));
    for (int y = y0; y < y1; ++y) {
        for (int x = box.x0; x <= box.x1; ++x) {
            px.emplace_back(x, y);
        }
    }
    const std::vector<Ray> rays = camera.pixel_rays(px);
    const double cos_max_o = std::cos(rules.max_theta_o);
    for (std::size_t k = 0; k < px.size(); ++k) {
        const Ray& ray = rays[k];
        const brdf::Vec3d wvec = ray.origin - sphere.centre;
        const double b = wvec.dot(ray.direction);
        const double disc = b * b - (wvec.squaredNorm() - sphere.radius_m * sphere.radius_m);
        if (!(disc > 0)) {
            // The ray misses the sphere (or grazes it at one point): background.
            continue;
        }
        ++counts->on_sphere;
        if (std::hypot(px[k].x - c.cx, px[k].y - c.cy) > c.r - rules.edge_margin_px) {
            ++counts->edge;
            continue;
        }
        const double s = -b - std::sqrt(disc);
        const brdf::Vec3d x = ray.origin + s * ray.direction;
        SpherePixel p;
        p.x = static_cast<int>(px[k].x);
        p.y = static_cast<int>(px[k].y);
        p.normal = ((x - sphere.centre) / sphere.radius_m).normalized();
        p.wo_world = -ray.direction;
        if (p.normal.dot(p.wo_world) < cos_max_o) {
            ++counts->grazing_view;
            continue;
        }
        p.tangent = reference_tangent(p.normal);
        out->push_back(p);
    }
}

}  // namespace

std::size_t sphere_pixel_bound(const CameraModel& camera,
                               const SphereGeometry& sphere,
                               const ExclusionRules& rules) {
    const ImageCircle& c = sphere.silhouette;
    const PixelBox box = silhouette_box(camera, c);
    if (box.x1 < box.x0 || box.y1 < box.y0) {
        return 0;
    }
    // One pixel of slack: rounding at the circle's edge must not make the list reallocate.
    return pixels_within(box, c, c.r - rules.edge_margin_px + 1);
}

std::vector<SpherePixel> sphere_pixels(const CameraModel& camera,
                                       const SphereGeometry& sphere,
                                       const ExclusionRules& rules,
                                       PixelCounts* counts) {
    const PixelBox box = silhouette_box(camera, sphere.silhouette);
    std::vector<SpherePixel> out;
    if (box.x1 < box.x0 || box.y1 < box.y0) {
        // The silhouette lies outside the image.
        return out;
    }
    out.reserve(sphere_pixel_bound(camera, sphere, rules));
    // Rows of the box in tiles of about kPixelsPerTile rays: a zoomed view filling a 5 MP frame
    // traces tens of megabytes of rays at a time, not hundreds.
    const std::size_t width = static_cast<std::size_t>(box.x1 - box.x0 + 1);
    const int rows_per_tile = static_cast<int>(std::max<std::size_t>(1, kPixelsPerTile / width));
    PixelCounts local;
    for (int y = box.y0; y <= box.y1; y += rows_per_tile) {
        trace_rows(
            camera, sphere, rules, box, y, std::min(box.y1 + 1, y + rows_per_tile), &out, &local);
    }
    if (counts != nullptr) {
        *counts += local;
    }
    return out;
}

brdf::Vec3d lathe_axis_world(double tilt_rad, double spin_rad) {
    return brdf::sample_to_world(brdf::Vec3d(0, 1, 0), tilt_rad, spin_rad);
}

brdf::Vec3d lathe_tangent(const brdf::Vec3d& normal, const brdf::Vec3d& axis, double pole_rad) {
    const brdf::Vec3d c = axis.cross(normal);
    const double s = c.norm();
    if (!(s >= std::sin(pole_rad)) || !(s > 0)) {
        // Within the pole cap (or exactly at the pole): no usable tangent.
        return brdf::Vec3d::Zero();
    }
    return c / s;
}

std::pair<brdf::Vec3d, brdf::Vec3d> local_directions(const SpherePixel& p,
                                                     const brdf::Vec3d& light_world) {
    return local_directions(p, p.tangent, light_world);
}

std::pair<brdf::Vec3d, brdf::Vec3d> local_directions(const SpherePixel& p,
                                                     const brdf::Vec3d& tangent,
                                                     const brdf::Vec3d& light_world) {
    const brdf::Vec3d& z = p.normal;
    const brdf::Vec3d& x = tangent;
    const brdf::Vec3d y = z.cross(x);
    const auto to_local = [&](const brdf::Vec3d& v) {
        return brdf::Vec3d(v.dot(x), v.dot(y), v.dot(z));
    };
    return {to_local(light_world), to_local(p.wo_world)};
}

}  // namespace gonio::acquisition
