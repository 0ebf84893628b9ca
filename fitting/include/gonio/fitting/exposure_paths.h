#pragma once

// The fit of samples measured while the arms moved (fly scans). A sample with an exposure path
// (brdf::Sample::has_path) measured the mean of f cos(theta_i) over its exposure divided by
// cos(theta_i) at mid-exposure (brdf/exposure_path.h); its model value is the same mean of the
// model, taken by composite Gauss-Legendre quadrature along the path (pieces of at most
// kFitPathPieceRad, kFitPathNodes nodes each) with the one body of the model's evaluation
// (brdf/model_eval.h) for every numeric type (double, Ceres Jets). Samples without a path keep the
// fit's prepared geometry: a dataset without paths costs what it always did.

#include <memory>
#include <vector>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/exposure_path.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::fitting {

/// Longest arc of one quadrature piece of a swept sample's path in a fit: 1 deg. With 4 nodes a
/// piece, the mean over a GGX alpha 0.05 peak swept by 0.2 rad is within 1e-6 of its integral.
inline constexpr double kFitPathPieceRad = 1.0 * brdf::kPi / 180;
inline constexpr int kFitPathNodes = 4;

/// The quadrature nodes of a swept sample's exposure mean.
std::vector<brdf::PathNode> fit_path_nodes(const brdf::Sample& s);

class ExposurePaths {
  public:
    /// The paths of `samples`; null when none has one.
    static std::unique_ptr<ExposurePaths> of(const std::vector<brdf::Sample>& samples);

    /// Whether sample i has a path.
    bool swept(std::size_t i) const { return !nodes_[i].empty(); }
    /// The model's value of swept sample i: its exposure mean.
    template <class T>
    brdf::Rgb<T> mean(const brdf::Model<T>& m, std::size_t i) const {
        return brdf::exposure_path_mean<T>(
            nodes_[i], cos_mid_[i], [&m](const brdf::Vec3d& wi, const brdf::Vec3d& wo) {
                return brdf::eval_model(
                    m, brdf::Vec3<T>(wi.cast<T>()), brdf::Vec3<T>(wo.cast<T>()));
            });
    }

  private:
    std::vector<std::vector<brdf::PathNode>> nodes_;
    std::vector<double> cos_mid_;
};

/// The model's value of one sample: the exposure mean of a swept sample, else the model at the
/// sample's directions.
brdf::Rgbd sample_model_value(const brdf::ModelD& m, const brdf::Sample& s);

}  // namespace gonio::fitting
