#pragma once

// Blender renders an exported material, and the render is compared with gonio's own evaluation of
// the model at every pixel (docs/blender.md).
//
// The scene (a Python script run after the material's script, `blender -b --factory-startup
// --python material.py --python scene.py`): a UV sphere of radius 1 (128 segments, 64 rings,
// smooth shading) with its poles along the world y axis (up in the picture) and the exported
// material; an orthographic camera looking down -z (x to the right, y up, the same frame as
// preview.h); one sun (per picture) of strength 1 (irradiance 1 W/m^2 at normal incidence, angle 0)
// toward `light_dir`; a black world. Cycles on the CPU, no denoising, direct light only (max
// bounces 0: the sphere is convex and the world black, so nothing else reaches the camera), a pixel
// filter of 0.01 px so every sample sees the pixel centre, the Standard view transform. The output
// is a linear multilayer OpenEXR holding the render (Combined), the shading normal (Normal pass)
// and the UV tangent that Blender's anisotropic closures use (a colour AOV "tangent" fed by a
// Tangent node on the active UV map, added by the scene script to the material).
//
// In pixel p, with n the shading normal, t the tangent made orthogonal to n, the local frame (t, n
// x t, n), wi the sun direction and wo = +z, the render must equal f(wi, wo) cos(theta_i) (the
// sun's irradiance 1 times the cosine). Compared pixels: covered (alpha 1), cos(theta_o) >= 0.1 and
// cos(theta_i) >= 0.05 (the silhouette and the terminator, where the mesh's facets and the shading
// normal disagree, are left out), and a tangent at least 0.5 long after removing its normal part
// (the two poles). Per compared pixel and channel whose expected value is at least 1e-3 of that
// channel's largest expected value, the relative difference |render - expected| / expected; the
// median and the 90th percentile of those are the figures of the comparison.

#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/brdf.h"
#include "gonio/report/image.h"

namespace gonio::report {

/// The blender executable on PATH (or the GONIO_BLENDER environment variable when set); empty
/// when there is none.
std::string find_blender();

struct BlenderRenderOptions {
    std::string blender;   ///< executable; empty = find_blender()
    int size_px = 160;     ///< width and height of each picture
    int samples = 4;       ///< Cycles samples per pixel
    std::string work_dir;  ///< folder for the scripts, the EXRs and Blender's log; must exist
    /// Directions toward the sun, world frame (normalised internally), one picture each: 38
    /// degrees from the view (theta_d = 19 deg at every pixel) and 120 degrees from it, behind
    /// the sphere (theta_d = 60 deg), where the Fresnel terms differ most.
    std::vector<brdf::Vec3d> light_dirs = {brdf::Vec3d(0.5, 0.35, 0.79),
                                           brdf::Vec3d(0.709, 0.497, -0.5)};
};

/// One picture (one sun direction) compared.
struct BlenderView {
    brdf::Vec3d light_dir;
    RadianceImage render;    ///< Blender's picture (radiance, covered = compared pixels)
    RadianceImage expected;  ///< gonio's f cos(theta_i) in the same pixels
    /// Per pixel the largest relative difference of its compared channels; -1 where none.
    std::vector<double> pixel_rel;
    std::vector<double> rel;  ///< every compared pixel channel's relative difference
    std::size_t pixels = 0;   ///< compared pixels
    double median_rel = 0;    ///< median relative difference (fraction, not percent)
    double p90_rel = 0;       ///< 90th percentile of the relative difference
};

struct BlenderComparison {
    std::vector<BlenderView> views;  ///< one per sun direction
    std::size_t pixels = 0;          ///< compared pixels of all views
    double median_rel = 0;           ///< median over every compared value of all views
    double p90_rel = 0;              ///< 90th percentile over the same
    double seconds = 0;              ///< wall time of Blender's run
};

/// Runs Blender on `material_script` (which must create the material `material_name`), renders the
/// scene above once per sun direction, reads the EXRs and compares them with `truth`. Errors name
/// the step (Blender's exit status with the end of its log, a missing EXR channel, no compared
/// pixel).
Expected<BlenderComparison> render_and_compare(const std::string& material_script,
                                               const std::string& material_name,
                                               const brdf::Brdf& truth,
                                               const BlenderRenderOptions& options);

/// A render (RGB), its alpha, normal and tangent pictures as read from the EXR (rows top first).
struct BlenderPasses {
    int width = 0, height = 0;
    std::vector<float> rgb, alpha, normal, tangent;  ///< 3, 1, 3, 3 floats per pixel
};

/// The comparison of one picture with `truth` lit from `light_dir` (the stage of
/// render_and_compare after reading an EXR).
Expected<BlenderView> compare_passes(const BlenderPasses& passes,
                                     const brdf::Brdf& truth,
                                     const brdf::Vec3d& light_dir);

/// The scene script of render_and_compare (for docs and for running by hand):
/// `blender -b --factory-startup --python material.py --python scene.py -- NAME OUT SIZE SAMPLES
/// LX LY LZ [LX LY LZ ...]`, writing OUT_0.exr, OUT_1.exr, ... (one per sun direction).
const std::string& blender_scene_script();

}  // namespace gonio::report
