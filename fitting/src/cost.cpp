// Parameter layout and the batched cost function (forward-mode automatic differentiation).

#include "gonio/fitting/cost.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/fitting/prepared_samples.h"

namespace gonio::fitting {

namespace {

const char* const kChannel[3] = {"[0]", "[1]", "[2]"};

/// Whether the structure of `m` uses `f` of lobe `lobe` (a fit may only move what is evaluated).
bool field_used(const brdf::ModelD& m, Field f, int lobe, std::string* why) {
    if (f == Field::kDiffuse) {
        if (!m.has_diffuse) {
            *why = "the model has no diffuse term";
            return false;
        }
        return true;
    }
    if (lobe < 0 || lobe >= static_cast<int>(m.lobes.size())) {
        *why = "the model has " + std::to_string(m.lobes.size()) + " lobe(s)";
        return false;
    }
    const brdf::Lobe<double>& l = m.lobes[lobe];
    const bool bp = l.distribution == brdf::Distribution::kBlinnPhong;
    const bool tab = l.distribution == brdf::Distribution::kTabulated;
    switch (f) {
        case Field::kAlphaX:
            *why = bp    ? "a Blinn-Phong lobe has an exponent, not alpha"
                   : tab ? "a tabulated lobe has a table, not alpha"
                         : "a lobe with RGB-varying roughness has alpha_rgb, not alpha_x";
            return !bp && !tab && !l.rgb_roughness;
        case Field::kAlphaY:
            *why = "alpha_y is used by anisotropic ggx/beckmann lobes only";
            return !bp && !tab && l.anisotropic;
        case Field::kOrientation:
            *why = "orientation_deg is used by anisotropic ggx/beckmann/student-t lobes only";
            return !bp && !tab && l.anisotropic;
        case Field::kAlphaRgb:
            *why = "alpha_rgb is used by lobes with RGB-varying roughness only";
            return !bp && !tab && !l.anisotropic && l.rgb_roughness;
        case Field::kExponent:
            *why = "the exponent belongs to Blinn-Phong lobes";
            return bp;
        case Field::kGamma:
            *why = "gamma belongs to Student-t lobes";
            return l.distribution == brdf::Distribution::kStudentT;
        case Field::kF0:
            *why = "f0 belongs to the Schlick Fresnel term";
            return l.fresnel.type == brdf::FresnelType::kSchlick;
        case Field::kEta:
            *why = "eta belongs to the dielectric Fresnel term";
            return l.fresnel.type == brdf::FresnelType::kDielectric;
        case Field::kEtaRgb:
        case Field::kK:
            *why = "eta_rgb and k belong to the conductor Fresnel term";
            return l.fresnel.type == brdf::FresnelType::kConductor;
        default:
            return true;
    }
}

}  // namespace

Expected<ParameterMap> ParameterMap::make(const FitSpec& spec) {
    ParameterMap map;
    map.base_ = spec.model;
    for (std::size_t i = 0; i < spec.model.lobes.size(); ++i) {
        const brdf::Lobe<double>& l = spec.model.lobes[i];
        if (l.rgb_roughness &&
            (l.anisotropic || l.distribution == brdf::Distribution::kBlinnPhong ||
             l.distribution == brdf::Distribution::kTabulated)) {
            return make_error("lobes[" + std::to_string(i) +
                              "]: RGB-varying roughness needs an isotropic ggx, beckmann or "
                              "student-t lobe");
        }
        if (l.distribution == brdf::Distribution::kTabulated && l.table == nullptr) {
            return make_error("lobes[" + std::to_string(i) +
                              "]: a tabulated lobe without its table (fit_power_iteration "
                              "extracts it from the data)");
        }
    }
    for (const ParamSpec& p : spec.params) {
        const std::string path = field_path(p.field, p.lobe);
        std::string why;
        if (!field_used(spec.model, p.field, p.lobe, &why)) {
            return make_error("parameter " + path + ": " + why);
        }
        if (!(p.lower <= p.upper) || !std::isfinite(p.lower) || !std::isfinite(p.upper)) {
            return make_error("parameter " + path + ": bounds [" + std::to_string(p.lower) + ", " +
                              std::to_string(p.upper) + "] are not an interval");
        }
        for (const ScalarParam& s : map.scalars_) {
            if (s.field == p.field && s.lobe == p.lobe) {
                return make_error("parameter " + path + " given twice");
            }
        }
        const int channels = is_rgb(p.field) && !p.shared ? 3 : 1;
        for (int c = 0; c < channels; ++c) {
            ScalarParam s;
            s.field = p.field;
            s.lobe = p.lobe;
            s.channel = channels == 3 ? c : -1;
            s.free = p.free;
            s.lower = p.lower;
            s.upper = p.upper;
            s.name = path + (channels == 3 ? kChannel[c] : "");
            if (s.free) {
                map.free_.push_back(static_cast<int>(map.scalars_.size()));
            }
            map.scalars_.push_back(s);
        }
    }
    if (map.free_.empty()) {
        return make_error("the spec leaves no parameter free: nothing to fit");
    }
    return map;
}

double ParameterMap::value_of(const brdf::ModelD& m, const ScalarParam& s) const {
    const int c = s.channel < 0 ? 0 : s.channel;
    if (s.field == Field::kDiffuse) {
        return m.diffuse[c];
    }
    const brdf::Lobe<double>& l = m.lobes[s.lobe];
    switch (s.field) {
        case Field::kDiffuse:
            break;
        case Field::kAlphaX:
            return l.alpha_x;
        case Field::kAlphaY:
            return l.alpha_y;
        case Field::kOrientation:
            return l.orientation_deg;
        case Field::kAlphaRgb:
            return l.alpha_rgb[c];
        case Field::kExponent:
            return l.exponent;
        case Field::kGamma:
            return l.gamma;
        case Field::kScale:
            return l.scale[c];
        case Field::kF0:
            return l.fresnel.f0[c];
        case Field::kEta:
            return l.fresnel.eta;
        case Field::kEtaRgb:
            return l.fresnel.eta_rgb[c];
        case Field::kK:
            return l.fresnel.k[c];
    }
    return 0;
}

std::vector<double> ParameterMap::values_of(const brdf::ModelD& m) const {
    std::vector<double> x;
    for (int k : free_) {
        x.push_back(value_of(m, scalars_[k]));
    }
    return x;
}

double channel_residual(ResidualForm form, double m, double d, double cos_i, double floor) {
    switch (form) {
        case ResidualForm::kAbsolute:
            return m - d;
        case ResidualForm::kRelative:
            // A value below zero within its noise counts as zero in the denominator.
            return (m - d) / (std::max(d, 0.0) + floor);
        case ResidualForm::kLog:
            return std::log1p(m * cos_i) - std::log1p(d * cos_i);
        case ResidualForm::kCosine:
            return (m - d) * cos_i;
        case ResidualForm::kCubeRoot:
            return std::cbrt(m + 1e-6) - std::cbrt(d + 1e-6);
    }
    return 0;
}

namespace {

/// A batch of samples as a Ceres cost function: the residuals of PreparedSamples and their
/// Jacobian (Jets over the derivative slots, prepared_samples.h).
class BatchCost final : public ceres::CostFunction {
  public:
    BatchCost(std::shared_ptr<const ParameterMap> map,
              const std::vector<brdf::Sample>& samples,
              const CostOptions& o)
        : prepared_(std::move(map), samples, o) {
        set_num_residuals(3 * static_cast<int>(samples.size()));
        mutable_parameter_block_sizes()->push_back(prepared_.map().size());
    }

    bool Evaluate(double const* const* parameters,
                  double* residuals,
                  double** jacobians) const override {
        double* jac = jacobians == nullptr ? nullptr : jacobians[0];
        return prepared_.evaluate(parameters[0], 0, prepared_.size(), residuals, jac);
    }

  private:
    PreparedSamples prepared_;
};

}  // namespace

std::unique_ptr<ceres::CostFunction> make_batch_cost(std::shared_ptr<const ParameterMap> map,
                                                     const std::vector<brdf::Sample>& samples,
                                                     const CostOptions& options) {
    return std::make_unique<BatchCost>(std::move(map), samples, options);
}

}  // namespace gonio::fitting
