// Parameter layout and the batched cost function (forward-mode automatic differentiation).

#include "gonio/fitting/cost.h"

#include <cmath>

#include "gonio/brdf/check.h"
#include "gonio/brdf/model_eval.h"

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
    switch (f) {
        case Field::kAlphaX:
            *why = "a Blinn-Phong lobe has an exponent, not alpha";
            return !bp;
        case Field::kAlphaY:
            *why = "alpha_y is used by anisotropic ggx/beckmann lobes only";
            return !bp && l.anisotropic;
        case Field::kExponent:
            *why = "the exponent belongs to Blinn-Phong lobes";
            return bp;
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
        case Field::kExponent:
            return l.exponent;
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
            return (m - d) / (d + floor);
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

constexpr double kCbrtOffset = 1e-6;

/// A sample prepared for the residual: directions, g(d) and the factor s of each channel.
struct Prepared {
    brdf::Vec3d wi, wo;
    double cos_i = 0;
    brdf::Rgbd g_d = brdf::Rgbd::Zero();
    brdf::Rgbd s = brdf::Rgbd::Zero();
};

class BatchCost final : public ceres::CostFunction {
  public:
    BatchCost(std::shared_ptr<const ParameterMap> map,
              const std::vector<brdf::Sample>& samples,
              const CostOptions& o)
        : map_(std::move(map)), form_(o.residual) {
        set_num_residuals(3 * static_cast<int>(samples.size()));
        mutable_parameter_block_sizes()->push_back(map_->size());
        // Derivative slots: a scalar or shared parameter has its own slot; the three channels of
        // a per-channel field (diffuse, scale, f0, eta_rgb, k) share one, since channel c of the
        // model depends on such a field through its component c alone (every RGB field enters
        // the model element-wise: brdf/model_eval.h, brdf/fresnel.h).
        const int n = map_->size();
        slot_.assign(n, -1);
        channel_.assign(n, -1);
        slots_ = 0;
        for (int k = 0; k < n; ++k) {
            const ScalarParam& s = map_->scalars()[map_->free()[k]];
            channel_[k] = s.channel;
            if (s.channel >= 0) {
                for (int j = 0; j < k; ++j) {
                    const ScalarParam& o = map_->scalars()[map_->free()[j]];
                    if (o.channel >= 0 && o.field == s.field && o.lobe == s.lobe) {
                        slot_[k] = slot_[j];
                        break;
                    }
                }
            }
            if (slot_[k] < 0) {
                slot_[k] = slots_++;
            }
        }
        prepared_.reserve(samples.size());
        for (const brdf::Sample& smp : samples) {
            Prepared p;
            p.wi = smp.wi();
            p.wo = smp.wo();
            p.cos_i = p.wi.z();
            const double sqrt_w = std::sqrt(smp.weight);
            for (int c = 0; c < 3; ++c) {
                const double d = smp.value[c];
                double g_d = d;
                double dg = 1;  // g'(d)
                double s = 1;
                switch (form_) {
                    case ResidualForm::kAbsolute:
                        break;
                    case ResidualForm::kRelative:
                        s = 1 / (d + o.relative_floor);
                        break;
                    case ResidualForm::kLog:
                        g_d = std::log1p(d * p.cos_i);
                        dg = p.cos_i / (1 + d * p.cos_i);
                        break;
                    case ResidualForm::kCosine:
                        s = p.cos_i;
                        break;
                    case ResidualForm::kCubeRoot:
                        g_d = std::cbrt(d + kCbrtOffset);
                        dg = 1 / (3 * g_d * g_d);
                        break;
                }
                if (o.use_sigma && smp.sigma[c] > 0) {
                    // Normalised deviation: the residual's first-order standard deviation is
                    // g'(d) sigma (times s, which cancels).
                    s = 1 / (dg * smp.sigma[c]);
                }
                p.g_d[c] = g_d;
                p.s[c] = s * sqrt_w;
            }
            prepared_.push_back(p);
        }
    }

    bool Evaluate(double const* const* parameters,
                  double* residuals,
                  double** jacobians) const override {
        const int n = map_->size();
        if (jacobians == nullptr || jacobians[0] == nullptr) {
            const brdf::ModelD m = map_->model<double>(parameters[0]);
            return evaluate_values(m, residuals);
        }
        if (slots_ <= 4) {
            return evaluate_slots<4>(parameters[0], residuals, jacobians[0]);
        }
        if (slots_ <= 8) {
            return evaluate_slots<8>(parameters[0], residuals, jacobians[0]);
        }
        if (n <= 4) {
            return evaluate_jets<4>(parameters[0], residuals, jacobians[0]);
        }
        if (n <= 8) {
            return evaluate_jets<8>(parameters[0], residuals, jacobians[0]);
        }
        return evaluate_jets<16>(parameters[0], residuals, jacobians[0]);
    }

  private:
    template <class T>
    T g(const T& m, double cos_i) const {
        using std::cbrt;
        using std::log;
        switch (form_) {
            case ResidualForm::kLog:
                // log(1 + m cos_i); m >= 0 and cos_i > 0 keep the argument >= 1.
                return log(T(1) + m * cos_i);
            case ResidualForm::kCubeRoot:
                return cbrt(m + kCbrtOffset);
            default:
                return m;
        }
    }

    bool evaluate_values(const brdf::ModelD& m, double* residuals) const {
        for (std::size_t i = 0; i < prepared_.size(); ++i) {
            const Prepared& p = prepared_[i];
            const brdf::Rgbd f = brdf::eval_model(m, p.wi, p.wo);
            for (int c = 0; c < 3; ++c) {
                const double r = p.s[c] * (g(f[c], p.cos_i) - p.g_d[c]);
                if (!std::isfinite(r)) {
                    return false;
                }
                residuals[3 * i + c] = r;
            }
        }
        return true;
    }

    /// Derivatives in one pass with K >= slots_ derivative slots (see the constructor): a Jet of
    /// the number of distinct slots instead of the number of free scalars (an RGB model with a
    /// shared width has 2 to 4 slots for 7 to 10 scalars).
    template <int K>
    bool evaluate_slots(const double* x, double* residuals, double* jacobian) const {
        using J = ceres::Jet<double, K>;
        const int n = map_->size();
        J xj[64];
        GONIO_CHECK(n <= 64);
        for (int k = 0; k < n; ++k) {
            xj[k] = J(x[k], slot_[k]);
        }
        const brdf::Model<J> m = map_->model<J>(xj);
        for (std::size_t i = 0; i < prepared_.size(); ++i) {
            const Prepared& p = prepared_[i];
            const brdf::Vec3<J> wi = p.wi.cast<J>();
            const brdf::Vec3<J> wo = p.wo.cast<J>();
            const brdf::Rgb<J> f = brdf::eval_model(m, wi, wo);
            for (int c = 0; c < 3; ++c) {
                const J r = J(p.s[c]) * (g(f[c], p.cos_i) - J(p.g_d[c]));
                const std::size_t row = 3 * i + c;
                if (!std::isfinite(r.a)) {
                    return false;
                }
                residuals[row] = r.a;
                double* out = jacobian + row * n;
                for (int k = 0; k < n; ++k) {
                    const double v = channel_[k] < 0 || channel_[k] == c ? r.v[slot_[k]] : 0.0;
                    if (!std::isfinite(v)) {
                        return false;
                    }
                    out[k] = v;
                }
            }
        }
        return true;
    }

    /// Derivatives in chunks of K parameters: each pass seeds K of the n free scalars.
    template <int K>
    bool evaluate_jets(const double* x, double* residuals, double* jacobian) const {
        using J = ceres::Jet<double, K>;
        const int n = map_->size();
        std::vector<J> xj(n);
        for (int k0 = 0; k0 < n; k0 += K) {
            for (int k = 0; k < n; ++k) {
                xj[k] = J(x[k]);
                if (k >= k0 && k < k0 + K) {
                    xj[k].v[k - k0] = 1.0;
                }
            }
            const brdf::Model<J> m = map_->model<J>(xj.data());
            const int width = std::min(K, n - k0);
            for (std::size_t i = 0; i < prepared_.size(); ++i) {
                const Prepared& p = prepared_[i];
                const brdf::Vec3<J> wi = p.wi.cast<J>();
                const brdf::Vec3<J> wo = p.wo.cast<J>();
                const brdf::Rgb<J> f = brdf::eval_model(m, wi, wo);
                for (int c = 0; c < 3; ++c) {
                    const J r = J(p.s[c]) * (g(f[c], p.cos_i) - J(p.g_d[c]));
                    const std::size_t row = 3 * i + c;
                    if (!std::isfinite(r.a)) {
                        return false;
                    }
                    if (k0 == 0) {
                        residuals[row] = r.a;
                    }
                    for (int k = 0; k < width; ++k) {
                        if (!std::isfinite(r.v[k])) {
                            return false;
                        }
                        jacobian[row * n + k0 + k] = r.v[k];
                    }
                }
            }
        }
        return true;
    }

    std::shared_ptr<const ParameterMap> map_;
    ResidualForm form_;
    std::vector<Prepared> prepared_;
    std::vector<int> slot_;     ///< derivative slot of each free scalar
    std::vector<int> channel_;  ///< its channel (0..2) or -1 (scalar or shared)
    int slots_ = 0;
};

}  // namespace

std::unique_ptr<ceres::CostFunction> make_batch_cost(std::shared_ptr<const ParameterMap> map,
                                                     const std::vector<brdf::Sample>& samples,
                                                     const CostOptions& options) {
    return std::make_unique<BatchCost>(std::move(map), samples, options);
}

}  // namespace gonio::fitting
