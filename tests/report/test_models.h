#pragma once

// Models of every kind the plots, previews and exports must handle, built in code.

#include <string>
#include <utility>
#include <vector>

#include "gonio/brdf/model.h"

namespace gonio::report::testing {

inline brdf::Lobe<double> lobe(brdf::Distribution d, double alpha) {
    brdf::Lobe<double> l;
    l.distribution = d;
    l.alpha_x = alpha;
    l.alpha_y = alpha;
    l.exponent = 2.0 / (alpha * alpha) - 2.0;
    l.shadowing = brdf::Shadowing::kSmithCorrelated;
    l.fresnel.type = brdf::FresnelType::kSchlick;
    l.fresnel.f0 = brdf::Rgbd(0.9, 0.8, 0.6);
    l.scale = brdf::Rgbd::Ones();
    return l;
}

/// A glossy model of each distribution, shadowing and Fresnel type, plus a Lambertian one.
inline std::vector<std::pair<std::string, brdf::ModelD>> every_model_type() {
    using brdf::Distribution;
    std::vector<std::pair<std::string, brdf::ModelD>> out;
    auto glossy = [](brdf::Lobe<double> l) {
        brdf::ModelD m;
        m.has_diffuse = true;
        m.diffuse = brdf::Rgbd(0.05, 0.04, 0.03);
        m.lobes.push_back(l);
        return m;
    };
    out.push_back({"ggx_schlick", glossy(lobe(Distribution::kGgx, 0.08))});
    {
        auto l = lobe(Distribution::kBeckmann, 0.1);
        l.shadowing = brdf::Shadowing::kSmithSeparable;
        l.fresnel.type = brdf::FresnelType::kDielectric;
        l.fresnel.eta = 1.5;
        out.push_back({"beckmann_dielectric", glossy(l)});
    }
    {
        auto l = lobe(Distribution::kBlinnPhong, 0.1);
        l.shadowing = brdf::Shadowing::kVGroove;
        l.fresnel.type = brdf::FresnelType::kNone;
        out.push_back({"blinn_phong_vgroove", glossy(l)});
    }
    {
        auto l = lobe(Distribution::kGgx, 0.06);
        l.anisotropic = true;
        l.alpha_y = 0.15;
        l.fresnel.type = brdf::FresnelType::kConductor;
        l.fresnel.eta_rgb = brdf::Rgbd(0.2, 0.9, 1.1);
        l.fresnel.k = brdf::Rgbd(3.9, 2.4, 2.2);
        l.shadowing = brdf::Shadowing::kNone;
        out.push_back({"ggx_anisotropic_conductor", glossy(l)});
    }
    {
        brdf::ModelD m;
        m.has_diffuse = true;
        m.diffuse = brdf::Rgbd(0.6, 0.5, 0.4);
        out.push_back({"lambert", m});
    }
    return out;
}

}  // namespace gonio::report::testing
