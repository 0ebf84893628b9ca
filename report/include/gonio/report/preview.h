#pragma once

// Sphere previews: a BRDF rendered on a sphere seen by an orthographic camera, lit by a directional
// light and by a sky/ground environment, so that two BRDFs (a measured table and its fit) can be
// compared at a glance.
//
// World frame of the picture: x to the right, y up, z toward the camera (view direction v = +z for
// every pixel). A pixel at offset (u, w) from the disk centre, in units of the disk radius, sees
// the sphere point with normal n = (u, w, sqrt(1 - u^2 - w^2)). The local frame of the BRDF at n
// has z = n, x = the tangent t = normalize(e_y x n) (horizontal on the picture; e_x at the two
// poles of the silhouette, where e_y x n vanishes) and y = n x t, so an anisotropic BRDF's alpha_x
// runs along the sphere's latitude lines. Pixel (i, j) (column, row) samples its centre (i + 0.5, j
// + 0.5).

#include <cstdint>
#include <string>

#include "gonio/brdf/brdf.h"
#include "gonio/report/image.h"

namespace gonio::report {

struct PreviewOptions {
    int size_px =
        256;  ///< width and height of one sphere picture (the disk fills it minus a margin)
    /// Direction toward the directional light, world frame (normalised internally).
    brdf::Vec3d light_dir = brdf::Vec3d(-0.45, 0.55, 0.70);
    /// Irradiance of the directional light at normal incidence; pi makes a white Lambertian surface
    /// facing the light have radiance 1.
    double light_irradiance = brdf::kPi;
    int env_samples = 192;   ///< directions per pixel for the environment (multiple importance)
    std::uint64_t seed = 1;  ///< seed of the per-pixel sample rotations
    /// Multiplies radiance before tone mapping; 0 = automatic: 0.18 / (median luminance of the
    /// sphere pixels of every picture of the sheet), clamped to [0.25, 100], shared by all.
    double exposure = 0.0;
};

/// Where the sphere lies in a picture of PreviewOptions::size_px: centre and radius in pixels.
struct SphereLayout {
    double cx = 0, cy = 0, radius = 0;
};
SphereLayout sphere_layout(int size_px);

/// Radiance of the sphere under the directional light: L = f(wi, wo) E cos(theta_i) with wi the
/// light direction and wo = v in each pixel's local frame (zero where the light is below the local
/// horizon).
RadianceImage render_directional(const brdf::Brdf& brdf, const PreviewOptions& options);

/// Radiance of the sphere under the environment L_env(w): a sky from the horizon colour (0.9, 0.95,
/// 1.0) to the zenith colour (0.25, 0.45, 0.9) for w_y >= 0 (linear in w_y) and a ground of (0.22,
/// 0.18, 0.14) below, in world directions. L = integral of f L_env cos over the hemisphere,
/// estimated with env_samples directions drawn from a mixture of a cosine-weighted hemisphere and
/// five cosine-power lobes (exponents 8 to 32768) about the mirror direction of v, combined with
/// the balance heuristic (E. Veach, L. Guibas, "Optimally Combining Sampling Techniques for Monte
/// Carlo Rendering", SIGGRAPH 1995, eq. 8), so both diffuse and near-mirror BRDFs converge.
RadianceImage render_environment(const brdf::Brdf& brdf, const PreviewOptions& options);

/// The environment radiance in world direction w (unit).
brdf::Rgbd environment_radiance(const brdf::Vec3d& w);

/// A labelled sheet: one row per BRDF (a, and b when not null), columns "directional light" and
/// "sky/ground environment"; tone mapped (filmic) and sRGB encoded, one exposure for every cell
/// (stated on the sheet).
Expected<Image> preview_sheet(const brdf::Brdf& a,
                              const std::string& label_a,
                              const brdf::Brdf* b,
                              const std::string& label_b,
                              const PreviewOptions& options);

}  // namespace gonio::report
