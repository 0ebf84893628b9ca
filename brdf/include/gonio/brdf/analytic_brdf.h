#pragma once

// An analytic model behind the Brdf interface (for gonio eval/check, the simulator, previews).

#include <memory>
#include <string>

#include "gonio/brdf/brdf.h"
#include "gonio/brdf/model.h"

namespace gonio::brdf {

class AnalyticBrdf : public Brdf {
  public:
    explicit AnalyticBrdf(ModelD model, std::string source = {});
    /// eval_model() of the wrapped model.
    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override;
    /// eval_model_packets() of the wrapped model.
    void eval_many(std::size_t n, const DirectionPairs& dirs, double* const out[3]) const override;
    bool evaluates_packets() const override { return true; }
    /// True when no lobe is anisotropic with alpha_x != alpha_y.
    bool isotropic() const override;
    std::string describe() const override;
    const ModelD& model() const { return model_; }

  private:
    ModelD model_;
    std::string source_;
};

std::unique_ptr<Brdf> make_analytic_brdf(ModelD model);

}  // namespace gonio::brdf
