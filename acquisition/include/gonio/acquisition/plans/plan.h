#pragma once

// Sampling plans: which (wi, wo) configurations a campaign measures. Isotropic plans live in the
// canonical space (theta_i, theta_r, delta_phi) with theta_i <= theta_r (reciprocity) and
// delta_phi in [0, pi] (isotropy); every configuration in a plan is distinct in that space.

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/acquisition/shared/kinematics.h"
#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::acquisition {

struct PlannedConfig {
    std::uint32_t index = 0;  ///< Position in its pass, stable across resumes.
    brdf::Vec3d wi;           ///< Target directions, sample frame.
    brdf::Vec3d wo;
    bool isotropic = true;
    std::uint32_t flags = 0;  ///< brdf::SampleFlag bits the measurement will carry (kFlagRoi).
    double weight = 1.0;      ///< Fit weight the measurement will carry.
};

struct UnreachableConfig {
    brdf::Vec3d wi;
    brdf::Vec3d wo;
    std::string reason;
};

struct Plan {
    std::string kind;  ///< "uniform", "half-diff", "refine", "vndf-retro", "vndf" (plan_vndf.h)
    std::vector<PlannedConfig> configs;
    std::vector<UnreachableConfig>
        unreachable;                ///< Listed with their reason, never dropped silently.
    std::uint64_t naive_count = 0;  ///< Size of the naive 4D grid of the same angular resolution.
    std::uint64_t outside_roi = 0;  ///< Configurations the scene did not need (not measured).
};

/// Canonical key of a configuration (isotropic + reciprocal folding), for redundancy checks.
brdf::Canonical<double> canonical_of(const PlannedConfig& c);

/// Uniform grid: theta_i, theta_r on n_theta values over [0, theta_max], delta_phi on n_dphi values
/// over [0, pi]; only theta_i <= theta_r; where theta_i = 0 the azimuth is meaningless and only
/// delta_phi = 0 is kept. The naive grid it replaces samples (theta_i, phi_i, theta_o, phi_o) with
/// phi over [0, 2 pi) at the same step: n_theta^2 (2 (n_dphi - 1))^2.
/// Limits of a sampling plan (docs/file-formats.md, "Limits"): counts per axis, and the most
/// configurations one pass may hold (checked before the plan is built).
constexpr int kMaxPlanAxis = 1000;
constexpr int kMaxPlanConfigs = 1000000;
/// Longest sample or operator name, and longest path, in a campaign description.
constexpr std::size_t kMaxNameLength = 256;
constexpr std::size_t kMaxPathLength = 1024;
/// Most light/view pairs in a scene.
constexpr std::size_t kMaxScenePairs = 10000;

struct UniformGridSpec {
    int n_theta = 10;
    double theta_max = 1.3963;  ///< rad (80 deg)
    int n_dphi = 7;
};
Expected<Plan> plan_uniform(const UniformGridSpec& spec);

/// Half/difference grid after the MERL layout (Matusik et al. 2003, "A Data-Driven Reflectance
/// Model"): theta_h = (i / n_theta_h)^2 pi/2 (dense near the specular peak), theta_d uniform on
/// [0, pi/2), phi_d uniform on [0, pi) (reciprocity), phi_h = 0 (isotropy). Pairs with a direction
/// beyond theta_max are skipped; duplicates after canonical folding are removed.
struct HalfDiffSpec {
    int n_theta_h = 8;
    int n_theta_d = 8;
    int n_phi_d = 6;
    double theta_max = 1.3963;
};
Expected<Plan> plan_half_diff(const HalfDiffSpec& spec);

/// The symmetry of a sample's BRDF about its normal that an operator declares, by which an
/// anisotropic plan folds its domain (docs/operator-guide.md, "Anisotropic samples").
enum class SampleSymmetry {
    kNone,     ///< No symmetry: every (phi_i, phi_o) is measured (up to reciprocity).
    kMirror,   ///< Mirror across the sample's x axis: f at (phi_i, phi_o) = f at (-phi_i, -phi_o).
               ///< The sample must be mounted with its symmetry axis along x.
    kTwoFold,  ///< A half turn about the normal: f at (phi_i, phi_o) = f at (phi_i + pi, phi_o +
               ///< pi), as every brushed metal or centrally symmetric microfacet lobe, whatever
               ///< its orientation on the sample.
};
const char* to_string(SampleSymmetry s);
/// Parses "none", "mirror", "2-fold".
Expected<SampleSymmetry> parse_symmetry(const std::string& name);

/// Anisotropic grid (plan_aniso.cpp): the directions are the normal and n_theta - 1 rings of
/// polar angle theta_max a / (n_theta - 1), each of 2 (n_dphi - 1) azimuths over [0, 2 pi) (the
/// step of the uniform plan's azimuth differences); every pair (wi, wo) of them in the sample's
/// frame, one per orbit of reciprocity (wi <-> wo) and of the declared symmetry. The
/// configurations are not isotropic: the kinematics use the spin axis to turn the sample so that
/// both directions land where asked. naive_count is that of the uniform plan of the same step.
struct AnisotropicGridSpec {
    int n_theta = 7;
    double theta_max = 1.309;  ///< rad (75 deg)
    int n_dphi = 5;
    SampleSymmetry symmetry = SampleSymmetry::kNone;
};
Expected<Plan> plan_anisotropic(const AnisotropicGridSpec& spec);

/// A region of interest read from a scene description (docs/operator-guide.md):
/// {"name": "...", "margin_deg": 5,
///  "pairs": [{"light": {"theta_deg": 30, "phi_deg": 0}, "view": {"theta_deg": 45, "phi_deg":
///  180}}], "theta_i_deg": [0, 40], "theta_r_deg": [0, 60]}
/// A configuration is inside when both its directions lie within the margin of a listed pair
/// (either way round, after aligning phi_i), or when its theta_i and theta_r lie within the given
/// ranges widened by the margin.
struct Scene {
    std::string name;
    double margin = 0.0873;
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> pairs;
    bool has_ranges = false;
    double theta_i_min = 0, theta_i_max = 0, theta_r_min = 0, theta_r_max = 0;
};
Expected<Scene> read_scene(const std::string& path);
bool in_roi(const Scene& scene, const PlannedConfig& c);
/// Fit weight of the margin's far edge; the region the scene names exactly has weight 1.
constexpr double kRoiMarginEdgeWeight = 0.25;
/// The fit weight a configuration gets from the scene: 0 outside the ROI; 1 in the region the scene
/// names exactly (a listed pair, or inside the theta ranges); falling linearly with the canonical
/// distance to kRoiMarginEdgeWeight at the margin's edge, so the fit is driven by what the target
/// rendering uses while the margin keeps the model continuous around it.
double roi_weight(const Scene& scene, const PlannedConfig& c);
/// Keeps only the configurations inside the scene's ROI, flagged kFlagRoi and weighted by
/// roi_weight(); counts the rest (they cost no move and no exposure).
void apply_roi(const Scene& scene, Plan* plan);

/// Moves the configurations that the rig cannot reach into plan->unreachable with the reason.
void remove_unreachable(const RigLimits& lim, Plan* plan);

/// A measured point for adaptive refinement: canonical coordinates and a scalar value (luminance).
struct MeasuredPoint {
    brdf::Canonical<double> c;
    double value = 0;
};

/// Adaptive refinement: each measured point is linked to its nearest neighbours in canonical space;
/// each link scores |log(v_a + eps) - log(v_b + eps)| (the change of the value in decades, so the
/// specular peak, retro-reflection and grazing rise all score high); the midpoints of the
/// highest-scoring links are proposed, at most `budget`, skipping links that score below
/// `threshold` (the error estimate met) or whose midpoint is closer than `min_spacing` (rad) to an
/// existing point. Deterministic for a given input order.
struct RefineSpec {
    int budget = 60;
    double threshold = 0.05;
    double min_spacing = 0.02;
    int neighbours = 6;
};
Plan plan_refine(const std::vector<MeasuredPoint>& measured, const RefineSpec& spec);

}  // namespace gonio::acquisition
