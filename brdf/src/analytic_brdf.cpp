// An analytic model behind the Brdf interface.

#include "gonio/brdf/analytic_brdf.h"

#include <utility>

#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"
#include "gonio/brdf/model_json.h"

namespace gonio::brdf {

AnalyticBrdf::AnalyticBrdf(ModelD model, std::string source)
    : model_(std::move(model)), source_(std::move(source)) {}

Rgbd AnalyticBrdf::eval(const Vec3d& wi, const Vec3d& wo) const {
    return eval_model(model_, wi, wo);
}

void AnalyticBrdf::eval_many(std::size_t n,
                             const DirectionPairs& dirs,
                             double* const out[3]) const {
    eval_model_packets(model_, n, dirs, out);
}

bool AnalyticBrdf::isotropic() const {
    for (const Lobe<double>& l : model_.lobes) {
        if (l.anisotropic && l.alpha_x != l.alpha_y &&
            l.distribution != Distribution::kBlinnPhong) {
            return false;
        }
    }
    return true;
}

std::string AnalyticBrdf::describe() const {
    const std::string d = "analytic model: " + describe_model(model_);
    return source_.empty() ? d : source_ + ": " + d;
}

std::unique_ptr<Brdf> make_analytic_brdf(ModelD model) {
    return std::make_unique<AnalyticBrdf>(std::move(model));
}

}  // namespace gonio::brdf
