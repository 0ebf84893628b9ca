#include "gonio/fitting/exposure_paths.h"

namespace gonio::fitting {

namespace {

std::array<brdf::Vec3d, 2> directions(const std::array<double, 4>& a) {
    return {brdf::spherical_to_cartesian(a[0], a[1]), brdf::spherical_to_cartesian(a[2], a[3])};
}

}  // namespace

std::vector<brdf::PathNode> fit_path_nodes(const brdf::Sample& s) {
    const auto start = directions(s.path_start);
    const auto end = directions(s.path_end);
    return brdf::exposure_path_nodes(
        start[0], start[1], end[0], end[1], kFitPathPieceRad, kFitPathNodes);
}

std::unique_ptr<ExposurePaths> ExposurePaths::of(const std::vector<brdf::Sample>& samples) {
    bool any = false;
    for (const brdf::Sample& s : samples) {
        any = any || s.has_path;
    }
    if (!any) {
        return nullptr;
    }
    auto p = std::make_unique<ExposurePaths>();
    p->nodes_.resize(samples.size());
    p->cos_mid_.resize(samples.size(), 1.0);
    for (std::size_t i = 0; i < samples.size(); ++i) {
        if (samples[i].has_path) {
            p->nodes_[i] = fit_path_nodes(samples[i]);
            p->cos_mid_[i] = samples[i].wi().z();
        }
    }
    return p;
}

brdf::Rgbd sample_model_value(const brdf::ModelD& m, const brdf::Sample& s) {
    if (!s.has_path) {
        return brdf::eval_model(m, s.wi(), s.wo());
    }
    return brdf::exposure_path_mean<double>(
        fit_path_nodes(s), s.wi().z(), [&m](const brdf::Vec3d& wi, const brdf::Vec3d& wo) {
            return brdf::eval_model(m, wi, wo);
        });
}

}  // namespace gonio::fitting
