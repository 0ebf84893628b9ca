#pragma once

// The adaptive plan of J. Dupuy and W. Jakob, "An Adaptive Parameterization for Efficient Material
// Acquisition and Rendering", ACM TOG 37(6), SIGGRAPH Asia 2018 (sections 4 and 5): a campaign in
// two passes that measures where the material reflects and stores the result as an RGL material
// file (brdf/rgl_bsdf.h) without any resampling.
//
// Pass 0, retro-reflection. For an isotropic microfacet surface with Smith masking,
//   f(w, w) = F D(w) / (4 cos(theta) sigma(w)),   sigma(w) = int D(m) <w, m>+ dm,
// so D is the fixed point of D <- f(w, w) cos(theta) sigma_D(w), normalised so that the projected
// area of the microfacets onto the surface is that of the surface, int D(m) cos(theta_m) dm = 1
// (Dupuy, Heitz, Iehl, Poulin, Ostromoukhov, EGSR 2015; rgl_ndf_from_retro() iterates it). The
// light and the detector cannot share a direction: the rig's arms stay at least its blind angle
// apart. Each retro-reflection node w is therefore measured as the pair
//   wi = cos(delta/2) w + sin(delta/2) e,   wo = cos(delta/2) w - sin(delta/2) e,
// e the horizontal unit vector orthogonal to w's plane of incidence and delta the blind angle plus
// kVndfRetroMargin: the half vector is exactly w and both elevations are equal, so that
//   f(w, w) cos(theta) = f(wi, wo) cos(theta_i) cos(theta_o) / cos(theta)
// up to the change of the masking term between w and wi, wo (second order in delta). Nodes sit at u
// = j / (n - 1) of the file's NDF grid, u = sqrt(theta / (pi/2)), dense near the normal where a
// glossy NDF varies fastest.
//
// Pass 1, the VNDF-warped domain. The measured NDF gives, for each incident elevation theta_i of
// the file, the visible NDF D(m) <wi, m>+ and its marginal-conditional warp (brdf/warp2d.h); a
// uniform grid of N x N points of the unit square is warped onto half vectors m and wo is the
// reflection of wi about m. Every node is a configuration: equal areas of the square hold equal
// visible microfacet area, so the measurements crowd where the material reflects. The stored value
// is f_r cos(theta_o) 4 sigma(wi) / D(m), which for a microfacet surface is Fresnel times masking:
// smooth, so that bilinear interpolation between nodes reproduces the peak.
//
// Redundancy removed before measuring: column 0 of the square is the normal half vector in every
// row, the last row repeats the first one's azimuth, and for an isotropic material row r and row
// N - 1 - r are mirror images (phi_m -> -phi_m), so one configuration serves them all.
// Anisotropic materials (phi_i_count >= 2; section 4.3 of the paper). The microfacet distribution
// depends on the azimuth, so pass 0 measures retro-reflection on a grid of retro_count elevations
// times retro_phi_count azimuths (the pole once), the rig turning the sample with its spin axis;
// the NDF grid is the whole unit square (rows over the azimuth) and the power iteration integrates
// over it (brdf::rgl_ndf_from_retro). Pass 1 measures the warped nodes of every (phi_i, theta_i)
// node, phi_i_count azimuths over the full turn, with the half vector's azimuth measured from the
// sample's x axis. No mirror symmetry is assumed between rows; the last phi_i node is the first a
// full turn on, and at theta_i = 0 every azimuth has the same nodes, so each is measured once.
//
// Unreachable nodes (blind zone, beyond the largest polar angle, arm limits) are listed with why;
// the file stores there the value of the nearest measured node of the same theta_i slice in the
// sample square (the warped value is smooth, see above), with the node's "valid" bit clear. Nodes
// whose wo lies below the horizon store 0, as the format prescribes.

#include <cstddef>
#include <string>
#include <vector>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/base/error.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/tensor_file.h"

namespace gonio::acquisition {

/// Extra separation of the arms beyond the rig's blind angle in retro-reflection, radians (1 deg).
constexpr double kVndfRetroMargin = 0.0174533;

/// How far the elevations of a measured retro-reflection pair may differ (the axes' read-back
/// positions, not the targets, are journaled), radians (0.5 deg).
constexpr double kVndfRetroElevationTolerance = 0.00872665;

/// Resolution of a vndf plan (campaign.json "plan": {"kind": "vndf", ...}).
struct VndfSpec {
    int retro_count = 32;       ///< Retro-reflection nodes over u = sqrt(theta / (pi/2)) in [0, 1].
    int theta_i_count = 8;      ///< theta_i nodes of the file, uniform over [0, pi/2].
    int resolution = 16;        ///< N: nodes per axis of the sample square.
    int ndf_resolution = 128;   ///< Nodes of the file's NDF grid and of its VNDF tables per axis.
    double theta_max = 1.4835;  ///< Largest polar angle measured, rad (also the rig's limit).
    /// 0: an isotropic material and file. P >= 2: an anisotropic file with P incident azimuths
    /// (P + 1 phi_i nodes over the full turn) and an NDF over the whole square.
    int phi_i_count = 0;
    /// Anisotropic: azimuths of the retro-reflection grid (the NDF of a lobe with axes 1 : 3 has
    /// a narrow azimuthal peak at 60 deg: 16 azimuths miss it by up to 25 %, 32 by 9 %).
    int retro_phi_count = 32;
};

/// Incident azimuths of an anisotropic vndf plan when none is given, and its NDF grid (the 2-D
/// power iteration costs ndf_resolution^4 per step).
constexpr int kVndfAnisotropicPhiCount = 8;
constexpr int kVndfAnisotropicNdfResolution = 64;

/// Checks the counts (retro 4..512, theta_i 2..64, resolution 4..128, ndf 16..512, anisotropic:
/// phi_i 0 or 2..64, retro azimuths 4..128, ndf at most 128) and theta_max in (10, 89] deg; the
/// error names the field.
Expected<void> check_vndf_spec(const VndfSpec& spec);

/// The separation of light and detector in retro-reflection: blind angle + kVndfRetroMargin.
double vndf_retro_separation(const RigLimits& limits);

/// Pass 0: the retro-reflection pairs (see the file comment), index j = the node's position on the
/// u grid. Nodes beyond min(theta_max, limits.max_theta) or that the arms cannot reach are listed
/// as unreachable with why; the horizon node (u = 1) has no value and is not planned.
Expected<Plan> plan_vndf_retro(const VndfSpec& spec, const RigLimits& limits);

/// One retro-reflection measurement: the pair as measured and the luminance of f_r (1/sr).
struct RetroMeasurement {
    brdf::Vec3d wi;
    brdf::Vec3d wo;
    double value = 0;
};

/// What the NDF recovery did.
struct VndfNdf {
    brdf::RglNdf ndf;          ///< D and sigma on the file's NDF grid.
    std::size_t measured = 0;  ///< Retro-reflection measurements used.
    double theta_last = 0;     ///< Elevation of the last measured node, rad.
};

/// The NDF from retro-reflection: each measurement gives f(w, w) cos(theta) at w = normalize(wi +
/// wo) (equal elevations required within
/// kVndfRetroElevationTolerance); the values are interpolated linearly in u onto
/// the NDF grid, held constant below the first node and continued above the last measured node as
/// f constant (f cos falls to 0 at the horizon), then iterated to the fixed point
/// (brdf::rgl_ndf_from_retro, floor 1e-4 of the peak). Anisotropic: the same along each measured
/// azimuth (the pole belongs to every one), then the logarithm interpolated linearly in the
/// azimuth, periodically, between the measured azimuths around each row of the grid. Errors: no
/// measurement, a non-finite or negative value, a pair whose elevations differ, nothing reflected
/// back.
Expected<VndfNdf> vndf_ndf_from_retro(const std::vector<RetroMeasurement>& retro,
                                      const VndfSpec& spec);

/// The RGL file options of a spec: its theta_i, ndf and rgb resolutions; nodes above the rig's
/// largest polar angle are measured at it (RglWriteOptions::max_theta_i).
brdf::RglWriteOptions vndf_file_options(const VndfSpec& spec, const RigLimits& limits);

/// Pass 1: the file's parameterisation and the configurations that measure it.
struct VndfLayout {
    brdf::RglLayout layout;
    Plan plan;  ///< kind "vndf": one configuration per distinct node above the horizon, reachable.
    /// Per layout node (file order): index into plan.configs, or -1 (below the horizon, or
    /// unreachable: see plan.unreachable).
    std::vector<int> node_config;
    std::size_t below_horizon = 0;  ///< Distinct nodes whose wo is at or below the horizon.
};
Expected<VndfLayout> plan_vndf_layout(const brdf::RglNdf& ndf,
                                      const VndfSpec& spec,
                                      const RigLimits& limits);

/// What vndf_tensor() stored.
struct VndfFileReport {
    std::size_t nodes = 0;          ///< rgb nodes in the file.
    std::size_t measured = 0;       ///< Of which hold their own measurement (valid bit set).
    std::size_t filled = 0;         ///< Of which hold the nearest measured node's value.
    std::size_t below_horizon = 0;  ///< Of which store 0 (wo at or below the horizon).
};

/// The RGL tensor file of a measured layout: f_r[k] (1/sr) is the measurement of
/// layout.plan.configs[k] (a non-finite value: not measured). Unmeasured nodes above the horizon
/// take the value of the nearest measured node of their theta_i slice in the sample square, with
/// their valid bit clear. Error: a theta_i slice without any measurement.
Expected<brdf::TensorFile> vndf_tensor(const VndfLayout& layout,
                                       const std::vector<brdf::Rgbd>& f_r,
                                       VndfFileReport* report = nullptr);

}  // namespace gonio::acquisition
