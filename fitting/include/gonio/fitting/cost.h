#pragma once

// The least-squares problem of a fit: the map between the vector of free scalars and the model,
// and the Ceres cost function of a batch of samples under a residual form.
//
// Residuals. For a channel with model value m, measured value d (1/sr), cos_i = wi.z:
//   r = s * (g(m) - g(d)),
// with (g, s) per form:
//   absolute   g(x) = x,                      s = 1;
//   relative   g(x) = x,                      s = 1 / (d + relative_floor);
//   log        g(x) = log(1 + x cos_i),       s = 1   (Low, Pellacini, Akenine-Moeller,
//   Ramamoorthi,
//              "BRDF Models for Accurate and Efficient Rendering of Glossy Surfaces", ACM TOG 2012,
//              error metric E2);
//   cosine     g(x) = x,                      s = cos_i (Ngan, Durand, Matusik, "Experimental
//              Analysis of BRDF Models", EGSR 2005: cosine-weighted L2 of the reflectance);
//   cube root  g(x) = cbrt(x + 1e-6),         s = 1   (the offset keeps dg/dx finite at m = 0).
// When the sample has a one-sigma uncertainty sigma > 0 and sigma weighting is on, s is replaced
// by 1 / (g'(d) sigma): the residual becomes the first-order normalised deviation, so that the sum
// of squares is a chi-square for every form. Every residual is finally multiplied by sqrt(weight).

#include <ceres/ceres.h>

#include <memory>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model.h"
#include "gonio/fitting/spec.h"

namespace gonio::fitting {

/// One scalar of the parameter vector and the model fields it drives.
struct ScalarParam {
    Field field = Field::kDiffuse;
    int lobe = -1;
    int channel =
        -1;  ///< 0..2 for one channel of an RGB field; -1 for all three (shared) or a scalar.
    bool free = true;
    double lower = 0;
    double upper = 1;
    std::string name;  ///< "diffuse[0]", "lobes[0].alpha_x", "lobes[0].fresnel.f0" (shared).
};

/// The model as a function of the vector of its free scalars.
class ParameterMap {
  public:
    /// Checks the spec (lobe indices, fields that the structure uses, bounds, start values within
    /// bounds) and lays out the scalars: free ones first in `free()`, fixed ones stay in the model.
    static Expected<ParameterMap> make(const FitSpec& spec);

    /// Every scalar (free and fixed) in report order.
    const std::vector<ScalarParam>& scalars() const { return scalars_; }
    /// Indices into scalars() of the free ones; position k is x[k].
    const std::vector<int>& free() const { return free_; }
    int size() const { return static_cast<int>(free_.size()); }

    /// The free scalars' values in `model`.
    std::vector<double> values_of(const brdf::ModelD& model) const;
    /// The value of scalar `s` in `model`.
    double value_of(const brdf::ModelD& model, const ScalarParam& s) const;

    /// The template model with the free scalars set from x (x has size()).
    template <class T>
    brdf::Model<T> model(const T* x) const {
        brdf::Model<T> m = brdf::cast_model<T>(base_, [](double v) { return T(v); });
        for (int k = 0; k < size(); ++k) {
            set(m, scalars_[free_[k]], x[k]);
        }
        return m;
    }
    const brdf::ModelD& base() const { return base_; }
    void set_base(const brdf::ModelD& m) { base_ = m; }

    /// Sets one scalar in a model (an isotropic lobe's alpha_x also sets alpha_y; the green
    /// channel of alpha_rgb also sets alpha_x and alpha_y).
    template <class T>
    static void set(brdf::Model<T>& m, const ScalarParam& s, const T& v) {
        auto rgb = [&](brdf::Rgb<T>& a) {
            if (s.channel < 0) {
                a = brdf::Rgb<T>::Constant(v);
            } else {
                a[s.channel] = v;
            }
        };
        if (s.field == Field::kDiffuse) {
            rgb(m.diffuse);
            return;
        }
        brdf::Lobe<T>& l = m.lobes[s.lobe];
        switch (s.field) {
            case Field::kDiffuse:
                break;
            case Field::kAlphaX:
                l.alpha_x = v;
                if (!l.anisotropic) {
                    l.alpha_y = v;
                }
                break;
            case Field::kAlphaY:
                l.alpha_y = v;
                break;
            case Field::kOrientation:
                l.orientation_deg = v;
                break;
            case Field::kAlphaRgb:
                rgb(l.alpha_rgb);
                if (s.channel < 0 || s.channel == 1) {
                    // alpha_x of an RGB-roughness lobe mirrors the green channel (model.h).
                    l.alpha_x = l.alpha_y = v;
                }
                break;
            case Field::kExponent:
                l.exponent = v;
                break;
            case Field::kGamma:
                l.gamma = v;
                break;
            case Field::kScale:
                rgb(l.scale);
                break;
            case Field::kF0:
                rgb(l.fresnel.f0);
                break;
            case Field::kEta:
                l.fresnel.eta = v;
                break;
            case Field::kEtaRgb:
                rgb(l.fresnel.eta_rgb);
                break;
            case Field::kK:
                rgb(l.fresnel.k);
                break;
        }
    }

  private:
    brdf::ModelD base_;
    std::vector<ScalarParam> scalars_;
    std::vector<int> free_;
};

/// Options of the cost of a batch.
struct CostOptions {
    ResidualForm residual = ResidualForm::kLog;
    double relative_floor = 1e-3;
    bool use_sigma = true;
};

/// Cost function of a batch of samples: 3 residuals per sample, one parameter block (the free
/// scalars of `map`). Derivatives by forward-mode automatic differentiation (ceres::Jet) of the
/// parameter-dependent part only, the geometry being precomputed (prepared_samples.h). The samples
/// must lie above the horizon (fit() validates them). Returns false (Ceres then rejects the step)
/// on a non-finite residual or derivative.
std::unique_ptr<ceres::CostFunction> make_batch_cost(std::shared_ptr<const ParameterMap> map,
                                                     const std::vector<brdf::Sample>& samples,
                                                     const CostOptions& options);

/// Residual of one channel for a model value in double (the formula above); used for metrics and
/// tests.
double channel_residual(ResidualForm form, double m, double d, double cos_i, double relative_floor);

}  // namespace gonio::fitting
