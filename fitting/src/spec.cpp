// Fit specifications: parsing of names, default parameter rules and JSON fit templates.

#include "gonio/fitting/spec.h"

#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/student_t.h"

namespace gonio::fitting {

namespace {

using brdf::Distribution;
using brdf::FresnelType;

/// Bounds of each field. They hold the model in its domain of definition (alpha > 0, f0 in [0, 1],
/// eta > 1 so that the dielectric reflects), with room far beyond real materials. Alpha stops at
/// 1.5: measured glossy lobes lie well below 1, and a wider GGX/Beckmann lobe is nearly flat over
/// the hemisphere, so that above 1.5 it only competes with the diffuse term (a fit that ends there
/// reports the parameter as sitting on its bound).
std::pair<double, double> default_bounds(Field f) {
    switch (f) {
        case Field::kDiffuse:
            return {0.0, 10.0};
        case Field::kAlphaX:
        case Field::kAlphaY:
        case Field::kAlphaRgb:
            return {1e-4, 1.5};
        case Field::kOrientation:
            // Degrees. The lobe has period 180 and the quarter-turn symmetry with alpha_x and
            // alpha_y exchanged; the solve may cross 0 or 180 freely, and the result is brought
            // to its canonical form afterwards (fit.cpp, canonical_orientations).
            return {-360.0, 360.0};
        case Field::kExponent:
            return {1e-1, 1e7};
        case Field::kGamma:
            // Smith's Lambda of the Student-t is finite above 3/2; 100 is within a few per cent
            // of Beckmann (brdf/student_t.h).
            return {brdf::kStudentTGammaMin, brdf::kStudentTGammaMax};
        case Field::kScale:
            return {0.0, 1e4};
        case Field::kF0:
            return {0.0, 1.0};
        case Field::kEta:
            return {1.01, 5.0};
        case Field::kEtaRgb:
            return {0.01, 10.0};
        case Field::kK:
            return {0.0, 20.0};
    }
    return {0.0, 1.0};
}

ParamSpec make_param(Field f, int lobe, bool free, bool shared) {
    ParamSpec p;
    p.field = f;
    p.lobe = lobe;
    p.free = free;
    p.shared = shared;
    std::tie(p.lower, p.upper) = default_bounds(f);
    return p;
}

}  // namespace

bool is_rgb(Field f) {
    return f == Field::kDiffuse || f == Field::kScale || f == Field::kF0 || f == Field::kEtaRgb ||
           f == Field::kK || f == Field::kAlphaRgb;
}

std::string field_path(Field f, int lobe) {
    const std::string prefix = "lobes[" + std::to_string(lobe) + "].";
    switch (f) {
        case Field::kDiffuse:
            return "diffuse";
        case Field::kAlphaX:
            return prefix + "alpha_x";
        case Field::kAlphaY:
            return prefix + "alpha_y";
        case Field::kAlphaRgb:
            return prefix + "alpha_rgb";
        case Field::kOrientation:
            return prefix + "orientation_deg";
        case Field::kExponent:
            return prefix + "exponent";
        case Field::kGamma:
            return prefix + "gamma";
        case Field::kScale:
            return prefix + "scale";
        case Field::kF0:
            return prefix + "fresnel.f0";
        case Field::kEta:
            return prefix + "fresnel.eta";
        case Field::kEtaRgb:
            return prefix + "fresnel.eta_rgb";
        case Field::kK:
            return prefix + "fresnel.k";
    }
    return "?";
}

Expected<Distribution> parse_distribution(const std::string& name) {
    if (name == "ggx") {
        return Distribution::kGgx;
    }
    if (name == "beckmann") {
        return Distribution::kBeckmann;
    }
    if (name == "blinn-phong") {
        return Distribution::kBlinnPhong;
    }
    if (name == "student-t") {
        return Distribution::kStudentT;
    }
    if (name == "tabulated") {
        return Distribution::kTabulated;
    }
    return make_error("model \"" + excerpt(name) +
                      "\": expected ggx, beckmann, blinn-phong, student-t or tabulated");
}

Expected<std::pair<FresnelType, bool>> parse_fresnel(const std::string& name) {
    if (name == "schlick") {
        return std::make_pair(FresnelType::kSchlick, false);
    }
    if (name == "schlick-rgb") {
        return std::make_pair(FresnelType::kSchlick, true);
    }
    if (name == "dielectric") {
        return std::make_pair(FresnelType::kDielectric, false);
    }
    if (name == "conductor") {
        return std::make_pair(FresnelType::kConductor, true);
    }
    if (name == "none") {
        return std::make_pair(FresnelType::kNone, false);
    }
    return make_error("fresnel \"" + name +
                      "\": expected schlick, schlick-rgb, dielectric, conductor or none");
}

Expected<bool> parse_roughness(const std::string& name) {
    if (name == "shared") {
        return false;
    }
    if (name == "rgb") {
        return true;
    }
    return make_error("roughness \"" + excerpt(name) + "\": expected shared or rgb");
}

Expected<brdf::Shadowing> parse_shadowing(const std::string& name) {
    if (name == "smith-correlated" || name == "smith") {
        return brdf::Shadowing::kSmithCorrelated;
    }
    if (name == "smith-separable") {
        return brdf::Shadowing::kSmithSeparable;
    }
    if (name == "v-groove") {
        return brdf::Shadowing::kVGroove;
    }
    if (name == "none") {
        return brdf::Shadowing::kNone;
    }
    return make_error("shadowing \"" + name +
                      "\": expected smith-correlated, smith-separable, v-groove or none");
}

Expected<ResidualForm> parse_residual(const std::string& name) {
    if (name == "absolute") {
        return ResidualForm::kAbsolute;
    }
    if (name == "relative") {
        return ResidualForm::kRelative;
    }
    if (name == "log") {
        return ResidualForm::kLog;
    }
    if (name == "cosine") {
        return ResidualForm::kCosine;
    }
    if (name == "cbrt") {
        return ResidualForm::kCubeRoot;
    }
    return make_error("residual \"" + name +
                      "\": expected absolute, relative, log, cosine or cbrt");
}

Expected<LossKind> parse_loss(const std::string& name) {
    if (name == "none") {
        return LossKind::kNone;
    }
    if (name == "huber") {
        return LossKind::kHuber;
    }
    if (name == "cauchy") {
        return LossKind::kCauchy;
    }
    return make_error("loss \"" + excerpt(name) + "\": expected none, huber or cauchy");
}

const char* to_string(ResidualForm r) {
    switch (r) {
        case ResidualForm::kAbsolute:
            return "absolute";
        case ResidualForm::kRelative:
            return "relative";
        case ResidualForm::kLog:
            return "log";
        case ResidualForm::kCosine:
            return "cosine";
        case ResidualForm::kCubeRoot:
            return "cbrt";
    }
    return "?";
}

const char* to_string(LossKind l) {
    switch (l) {
        case LossKind::kNone:
            return "none";
        case LossKind::kHuber:
            return "huber";
        case LossKind::kCauchy:
            return "cauchy";
    }
    return "?";
}

std::vector<ParamSpec> default_params(const brdf::ModelD& model, bool fresnel_rgb) {
    std::vector<ParamSpec> out;
    if (model.has_diffuse) {
        out.push_back(make_param(Field::kDiffuse, -1, true, false));
    }
    for (int i = 0; i < static_cast<int>(model.lobes.size()); ++i) {
        const brdf::Lobe<double>& l = model.lobes[i];
        if (l.distribution == Distribution::kBlinnPhong) {
            out.push_back(make_param(Field::kExponent, i, true, false));
        } else if (l.distribution == Distribution::kTabulated) {
            // The shape is the table (extracted by power iteration, power_iteration.h): no slope
            // parameter.
        } else if (l.rgb_roughness) {
            // One slope parameter per channel (model.h, Lobe::rgb_roughness).
            out.push_back(make_param(Field::kAlphaRgb, i, true, false));
            if (l.distribution == Distribution::kStudentT) {
                out.push_back(make_param(Field::kGamma, i, true, false));
            }
        } else {
            out.push_back(make_param(Field::kAlphaX, i, true, false));
            if (l.anisotropic) {
                out.push_back(make_param(Field::kAlphaY, i, true, false));
                out.push_back(make_param(Field::kOrientation, i, true, false));
            }
            if (l.distribution == Distribution::kStudentT) {
                out.push_back(make_param(Field::kGamma, i, true, false));
            }
        }
        // The colour of the lobe comes either from its Fresnel term (Schlick RGB, conductor) or
        // from its scale; letting both carry it makes scale and F trade off freely.
        bool colour_in_fresnel = false;
        switch (l.fresnel.type) {
            case FresnelType::kNone:
                break;
            case FresnelType::kSchlick:
                out.push_back(make_param(Field::kF0, i, true, !fresnel_rgb));
                colour_in_fresnel = fresnel_rgb;
                break;
            case FresnelType::kDielectric:
                out.push_back(make_param(Field::kEta, i, true, false));
                break;
            case FresnelType::kConductor:
                out.push_back(make_param(Field::kEtaRgb, i, true, false));
                out.push_back(make_param(Field::kK, i, true, false));
                colour_in_fresnel = true;
                break;
        }
        out.push_back(make_param(Field::kScale, i, !colour_in_fresnel, false));
    }
    return out;
}

Expected<FitSpec> make_fit_spec(const ModelOptions& o) {
    if (o.lobes < 0 || o.lobes > 4) {
        return make_error("--lobes " + std::to_string(o.lobes) + ": expected 0 to 4");
    }
    if (o.lobes == 0 && !o.diffuse) {
        return make_error("model has neither a diffuse term nor a lobe: nothing to fit");
    }
    if (o.distribution == Distribution::kTabulated && (o.lobes != 1 || o.anisotropic)) {
        return make_error(std::string("model tabulated: one isotropic lobe (") +
                          (o.anisotropic ? "--anisotropic" : "--lobes " + std::to_string(o.lobes)) +
                          " given); its D is extracted from the backscattering of the data");
    }
    if (o.rgb_roughness && (o.anisotropic || o.distribution == Distribution::kBlinnPhong ||
                            o.distribution == Distribution::kTabulated)) {
        return make_error(std::string("--roughness rgb: isotropic ggx, beckmann or student-t "
                                      "lobes only (") +
                          (o.anisotropic ? "--anisotropic" : to_string(o.distribution)) +
                          " given)");
    }
    FitSpec spec;
    spec.model.has_diffuse = o.diffuse;
    spec.model.diffuse = brdf::Rgbd::Constant(o.diffuse ? 0.2 : 0.0);
    for (int i = 0; i < o.lobes; ++i) {
        brdf::Lobe<double> l;
        l.distribution = o.distribution;
        l.anisotropic = o.anisotropic && o.distribution != Distribution::kBlinnPhong;
        l.alpha_x = l.alpha_y = 0.1 * (i + 1);
        l.rgb_roughness = o.rgb_roughness;
        l.alpha_rgb = brdf::Rgbd::Constant(l.alpha_x);
        l.exponent = 2.0 / (l.alpha_x * l.alpha_x) - 2.0;
        l.shadowing = o.shadowing;
        l.fresnel.type = o.fresnel;
        l.fresnel.f0 = brdf::Rgbd::Constant(0.04);
        l.fresnel.eta = 1.5;
        // A generic metal start: F(0) = ((n-1)^2 + k^2) / ((n+1)^2 + k^2) = 0.61 for n = 1.5, k
        // = 3.
        l.fresnel.eta_rgb = brdf::Rgbd::Constant(1.5);
        l.fresnel.k = brdf::Rgbd::Constant(3.0);
        l.scale = brdf::Rgbd::Ones();
        spec.model.lobes.push_back(l);
    }
    spec.params = default_params(spec.model, o.fresnel_rgb);
    return spec;
}

namespace {

/// Finds the rule for a path ("lobes[0].alpha_x", "diffuse"); nullptr when the path is unknown.
ParamSpec* find_param(std::vector<ParamSpec>& params, const std::string& path) {
    for (ParamSpec& p : params) {
        if (field_path(p.field, p.lobe) == path) {
            return &p;
        }
    }
    return nullptr;
}

std::string known_paths(const std::vector<ParamSpec>& params) {
    std::string s;
    for (const ParamSpec& p : params) {
        s += (s.empty() ? "" : ", ") + field_path(p.field, p.lobe);
    }
    return s;
}

}  // namespace

Expected<FitSpec> parse_fit_template(const std::string& json_text, const std::string& source) {
    // The same reader as every other JSON file (base/strict_json.h): size and depth first, then
    // syntax, then the schema; every message names the key path and the rule.
    return read_strict_json(source, [&] {
        const nlohmann::json j = parse_json_checked(json_text, source);
        JsonObject top(j, "");
        top.allow({"model", "free", "fixed", "shared", "bounds"});
        top.finish();
        FitSpec spec;
        spec.model = brdf::read_model_json(top.raw("model"), "model");
        // Schlick f0 per channel unless "shared" says otherwise below.
        spec.params = default_params(spec.model, true);
        // "free", "fixed" and "shared": arrays of parameter paths, applied in that order.
        auto path_list = [&](const char* key, auto apply) {
            const nlohmann::json* list = top.find(key);
            if (list == nullptr) {
                return;
            }
            if (!list->is_array()) {
                json_fail(std::string(key) + ": expected an array of parameter paths, got " +
                          json_type(*list));
            }
            for (std::size_t i = 0; i < list->size(); ++i) {
                const std::string at = std::string(key) + "[" + std::to_string(i) + "]";
                const std::string name = json_string_at((*list)[i], at);
                ParamSpec* p = find_param(spec.params, name);
                if (p == nullptr) {
                    json_fail(at + " = \"" + excerpt(name) + "\": not a parameter of this model (" +
                              known_paths(spec.params) + ")");
                }
                apply(*p, at);
            }
        };
        path_list("free", [](ParamSpec& p, const std::string&) { p.free = true; });
        path_list("fixed", [](ParamSpec& p, const std::string&) { p.free = false; });
        path_list("shared", [](ParamSpec& p, const std::string& at) {
            if (!is_rgb(p.field)) {
                json_fail(at + ": " + field_path(p.field, p.lobe) +
                          " is a scalar; only RGB parameters can be shared");
            }
            p.shared = true;
        });
        // "bounds": {path: [lower, upper]}.
        if (const nlohmann::json* bounds = top.find("bounds")) {
            require_json_object(*bounds, "bounds");
            for (auto it = bounds->begin(); it != bounds->end(); ++it) {
                const std::string at = json_key_path("bounds", it.key());
                ParamSpec* p = find_param(spec.params, it.key());
                if (p == nullptr) {
                    json_fail(at + ": not a parameter of this model (" + known_paths(spec.params) +
                              ")");
                }
                const nlohmann::json& b = it.value();
                if (!b.is_array() || b.size() != 2) {
                    json_fail(
                        at + ": expected [lower, upper], got " +
                        (b.is_array() ? "an array of " + std::to_string(b.size()) : json_type(b)));
                }
                const double lower = json_number_at(b[0], at + "[0]");
                const double upper = json_number_at(b[1], at + "[1]");
                if (!(lower < upper)) {
                    json_fail(at + " = [" + show_number(lower) + ", " + show_number(upper) +
                              "]: the lower bound must be below the upper bound");
                }
                p->lower = lower;
                p->upper = upper;
            }
        }
        return spec;
    });
}

Expected<FitSpec> load_fit_template(const std::string& path) {
    Expected<std::string> text = read_input_file(path, kMaxJsonBytes);
    if (!text) {
        return make_error(text.error().message + " (fit template)");
    }
    return parse_fit_template(*text, path);
}

}  // namespace gonio::fitting
