#include "gonio/report/blender_export.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "gonio/base/check.h"
#include "gonio/brdf/blinn_phong.h"
#include "gonio/brdf/fresnel.h"

namespace gonio::report {

namespace {

using brdf::Distribution;
using brdf::FresnelType;
using brdf::Lobe;
using brdf::ModelD;
using brdf::Rgbd;
using brdf::Shadowing;
using Unexpected = tl::unexpected<BlenderExportError>;

/// Largest normal-incidence reflectance of the Principled BSDF's dielectric Fresnel (Specular 1).
constexpr double kMaxPrincipledF0 = 0.08;
/// Largest lobe weight written (doublings of the closure with Add Shaders).
constexpr double kMaxWeight = 64.0;
/// The Anisotropic BSDF clamps its anisotropy to [-0.99, 0.99]: alpha ratios up to 1 / 0.01^2.
constexpr double kMaxAnisotropy = 0.99;
/// The Principled BSDF's aspect sqrt(1 - 0.9 anisotropic): alpha ratios up to 1 / 0.1.
constexpr double kMinPrincipledAspect2 = 0.1;

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

std::string pct(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.2g %%", v);
    return buf;
}

std::string rgb(const Rgbd& v) {
    return "(" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + ")";
}

Unexpected refuse(std::string message) {
    return Unexpected(BlenderExportError{std::move(message), true});
}

Unexpected invalid(std::string message) {
    return Unexpected(BlenderExportError{std::move(message), false});
}

/// A Python string literal holds the name: 1 to 128 letters, digits, '_', '-', '.'.
tl::expected<void, BlenderExportError> check_name(const std::string& name) {
    if (name.empty() || name.size() > 128) {
        return refuse("--name: " + std::to_string(name.size()) + " characters, must be 1 to 128");
    }
    for (std::size_t i = 0; i < name.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(name[i]);
        if (!(std::isalnum(c) || c == '_' || c == '-' || c == '.')) {
            return refuse("--name: character " + std::to_string(i + 1) +
                          " is not allowed; use letters, digits, '_', '-' or '.'");
        }
    }
    return {};
}

bool finite_non_negative(const Rgbd& v) {
    return v.allFinite() && (v.array() >= 0).all();
}

/// Values out of their domain (the key path named).
tl::expected<void, BlenderExportError> validate(const ModelD& m) {
    if (m.has_diffuse && !finite_non_negative(m.diffuse)) {
        return invalid("diffuse: must be finite and >= 0");
    }
    for (std::size_t i = 0; i < m.lobes.size(); ++i) {
        const Lobe<double>& l = m.lobes[i];
        const std::string p = "lobes[" + std::to_string(i) + "].";
        if (!finite_non_negative(l.scale)) {
            return invalid(p + "scale: must be finite and >= 0");
        }
        const bool alphas_ok =
            l.alpha_x > 0 && std::isfinite(l.alpha_x) &&
            (!l.anisotropic || (l.alpha_y > 0 && std::isfinite(l.alpha_y))) &&
            (!l.rgb_roughness || (l.alpha_rgb.allFinite() && (l.alpha_rgb.array() > 0).all()));
        if (l.distribution == Distribution::kBlinnPhong) {
            if (!(l.exponent > 0) || !std::isfinite(l.exponent)) {
                return invalid(p + "exponent = " + num(l.exponent) + ": must be finite and > 0");
            }
        } else if (!alphas_ok || !std::isfinite(l.orientation_deg)) {
            return invalid(p + "alpha: must be finite and > 0 (orientation_deg finite)");
        }
        const brdf::Fresnel<double>& f = l.fresnel;
        if (f.type == FresnelType::kSchlick &&
            (!finite_non_negative(f.f0) || (f.f0.array() > 1).any())) {
            return invalid(p + "fresnel.f0: must lie in [0, 1]");
        }
        if (f.type == FresnelType::kDielectric && (!(f.eta > 0) || !std::isfinite(f.eta))) {
            return invalid(p + "fresnel.eta = " + num(f.eta) + ": must be finite and > 0");
        }
        if (f.type == FresnelType::kConductor &&
            (!f.eta_rgb.allFinite() || (f.eta_rgb.array() <= 0).any() ||
             !finite_non_negative(f.k))) {
            return invalid(p + "fresnel: eta must be > 0 and k >= 0, finite");
        }
    }
    return {};
}

/// One closure expression of the script, what it stands for, and how close it is.
struct Term {
    std::string python;   ///< an expression giving a shader socket
    std::string summary;  ///< "lobes[0]: GGX alpha 0.2 as a Glossy BSDF: exact"
    bool approximated_only = false;
};

/// The lobe as the script writes it, decided before any Python is written.
struct LobePlan {
    std::string distribution;  ///< "GGX" or "BECKMANN"
    double alpha_x = 0, alpha_y = 0;
    bool anisotropic = false;
    double orientation_deg = 0;
    std::vector<std::string> approximations;     ///< measured keys (blender_measured)
    std::vector<std::string> needs_approximate;  ///< what --approximate must allow, named
};

std::string measured_text(const std::string& key) {
    const BlenderMeasured& m = blender_measured(key);
    return "measured at most " + pct(m.front_median_pct) + " median, " + pct(m.front_p90_pct) +
           " 90th percentile relative difference lit 38 deg from the view, " +
           pct(m.back_median_pct) + " and " + pct(m.back_p90_pct) + " back-lit at 120 deg (" +
           m.test_case + ")";
}

/// The parts of a lobe that do not depend on its Fresnel: distribution, alphas, shadowing.
tl::expected<LobePlan, BlenderExportError> plan_shape(const Lobe<double>& l, const std::string& p) {
    LobePlan plan;
    plan.alpha_x = l.alpha_x;
    plan.alpha_y = l.anisotropic ? l.alpha_y : l.alpha_x;
    plan.anisotropic = l.anisotropic && l.alpha_x != l.alpha_y;
    plan.orientation_deg = l.orientation_deg;
    switch (l.distribution) {
        case Distribution::kGgx:
            plan.distribution = "GGX";
            break;
        case Distribution::kBeckmann:
            plan.distribution = "BECKMANN";
            break;
        case Distribution::kStudentT:
            if (std::abs(l.gamma - 2) > 1e-9) {
                return refuse(p + ": a student-t lobe (gamma " + num(l.gamma) +
                              ") cannot be represented by Blender, which takes GGX and Beckmann "
                              "only; refit with `--model ggx` or `--model beckmann`");
            }
            plan.distribution = "GGX";
            break;
        case Distribution::kTabulated:
            return refuse(p +
                          ": a tabulated NDF cannot be represented by Blender, which takes "
                          "GGX and Beckmann only; refit with `--model ggx`");
        case Distribution::kBlinnPhong: {
            const double a = brdf::blinn_phong_equivalent_alpha(l.exponent);
            plan.distribution = "BECKMANN";
            plan.alpha_x = plan.alpha_y = a;
            plan.anisotropic = false;
            plan.needs_approximate.push_back(
                p +
                ": a Blinn-Phong lobe (Blender has no Blinn-Phong distribution; "
                "--approximate writes Beckmann with alpha = sqrt(2 / (e + 2)) = " +
                num(a) + ")");
            plan.approximations.push_back("blinn-phong");
            return plan;
        }
    }
    if (plan.anisotropic && l.fresnel.type == FresnelType::kNone &&
        1 - std::sqrt(std::min(plan.alpha_x, plan.alpha_y) / std::max(plan.alpha_x, plan.alpha_y)) >
            kMaxAnisotropy) {
        return refuse(p +
                      ": an anisotropic lobe with alpha ratio above 10^4 cannot be "
                      "represented by Blender's Anisotropic BSDF (anisotropy up to 0.99)");
    }
    switch (l.shadowing) {
        case Shadowing::kSmithSeparable:
            break;
        case Shadowing::kSmithCorrelated:
            plan.approximations.push_back("smith-correlated");
            break;
        case Shadowing::kVGroove:
        case Shadowing::kNone:
            return refuse(p + ": shadowing " + std::string(brdf::to_string(l.shadowing)) +
                          " cannot be represented by Blender, whose microfacet closures use "
                          "Smith's G only; refit with `--shadowing smith-separable`");
    }
    return plan;
}

/// Glossy BSDFs: a lobe without Fresnel.
std::string glossy_python(const Lobe<double>& l, const LobePlan& plan) {
    if (l.rgb_roughness && l.distribution != Distribution::kBlinnPhong) {
        std::string g[3];
        for (int c = 0; c < 3; ++c) {
            Rgbd mask = Rgbd::Zero();
            mask[c] = l.scale[c];
            g[c] = "glossy(\"" + plan.distribution + "\", " + num(std::sqrt(l.alpha_rgb[c])) +
                   ", " + rgb(mask) + ")";
        }
        return "add(add(" + g[0] + ", " + g[1] + "), " + g[2] + ")";
    }
    if (!plan.anisotropic) {
        return "glossy(\"" + plan.distribution + "\", " + num(std::sqrt(plan.alpha_x)) + ", " +
               rgb(l.scale) + ")";
    }
    const double r2 = std::sqrt(plan.alpha_x * plan.alpha_y);
    const double anisotropy = plan.alpha_x <= plan.alpha_y
                                  ? 1 - std::sqrt(plan.alpha_x / plan.alpha_y)
                                  : std::sqrt(plan.alpha_y / plan.alpha_x) - 1;
    return "anisotropic(\"" + plan.distribution + "\", " + num(std::sqrt(r2)) + ", " +
           num(anisotropy) + ", " + num(plan.orientation_deg / 360) + ", " + rgb(l.scale) + ")";
}

/// The Principled BSDF's arguments for the lobe's alphas: roughness, anisotropic, rotation.
std::string principled_shape(const LobePlan& plan) {
    if (!plan.anisotropic) {
        return num(std::sqrt(plan.alpha_x));
    }
    double ax = plan.alpha_x;
    double ay = plan.alpha_y;
    double turns = plan.orientation_deg / 360;
    if (ax < ay) {
        // The Principled BSDF's alpha along the tangent is the larger one: turn a quarter.
        std::swap(ax, ay);
        turns += 0.25;
    }
    const double anisotropic = (1 - ay / ax) / 0.9;
    return num(std::sqrt(std::sqrt(ax * ay))) + ", anisotropic=" + num(anisotropic) +
           ", rotation=" + num(turns - std::floor(turns));
}

/// Normal-incidence reflectance of a Fresnel term per channel.
Rgbd normal_reflectance(const brdf::Fresnel<double>& f) {
    switch (f.type) {
        case FresnelType::kSchlick:
            return f.f0;
        case FresnelType::kDielectric: {
            const double r = (f.eta - 1) / (f.eta + 1);
            return Rgbd::Constant(r * r);
        }
        case FresnelType::kConductor: {
            Rgbd out;
            for (int c = 0; c < 3; ++c) {
                const double n = f.eta_rgb[c], k = f.k[c];
                out[c] = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
            }
            return out;
        }
        case FresnelType::kNone:
            break;
    }
    return Rgbd::Ones();
}

}  // namespace

double principled_specular_for_schlick(double f0) {
    // F_P(s) = f0 + (1 - f0) (F_d(c, eta(s)) - F_d0) / (1 - F_d0) against Schlick's f0 + (1 - f0)
    // x5: the largest relative difference over theta_d in [0, 75] deg, on a grid of s.
    constexpr int kAngles = 300;
    constexpr double kMaxThetaD = 75 * brdf::kPi / 180;
    double best_s = 0.5, best = std::numeric_limits<double>::infinity();
    for (int k = 1; k <= 1000; ++k) {
        const double s = 0.001 * k;
        const double eta = principled_eta(s);
        const double fd0 = brdf::fresnel_dielectric(1.0, eta);
        double worst = 0;
        for (int a = 0; a <= kAngles; ++a) {
            const double c = std::cos(kMaxThetaD * a / kAngles);
            const double fh = (brdf::fresnel_dielectric(c, eta) - fd0) / (1 - fd0);
            const double schlick = brdf::fresnel_schlick(c, f0);
            const double principled = f0 + (1 - f0) * fh;
            worst = std::max(worst, std::abs(principled - schlick) / std::max(schlick, 1e-12));
        }
        if (worst < best) {
            best = worst;
            best_s = s;
        }
    }
    return best_s;
}

double principled_eta(double specular) {
    return 2 / (1 - std::sqrt(kMaxPrincipledF0 * specular)) - 1;
}

namespace {

/// A Beckmann lobe with a Fresnel term (approximation): a Beckmann Glossy BSDF coloured by the
/// lobe's scale times the Fresnel reflectance at normal incidence.
std::string beckmann_fresnel_python(const Lobe<double>& l, LobePlan& plan, const std::string& p) {
    plan.needs_approximate.push_back(
        p +
        ": a Beckmann lobe with a Fresnel term (Blender applies a Fresnel on the half vector "
        "only in the Principled BSDF, which is GGX; --approximate writes a Beckmann Glossy "
        "BSDF coloured by the Fresnel reflectance at normal incidence)");
    plan.approximations.push_back("fresnel-at-normal-incidence");
    Lobe<double> coloured = l;
    coloured.scale = l.scale.cwiseProduct(normal_reflectance(l.fresnel));
    coloured.fresnel.type = FresnelType::kNone;
    return glossy_python(coloured, plan);
}

/// The Principled BSDF's Fresnel for a lobe's: normal-incidence reflectance and Specular input.
struct PrincipledFresnel {
    Rgbd f0;
    double specular = 0.5;
};

tl::expected<PrincipledFresnel, BlenderExportError> principled_fresnel(
    const brdf::Fresnel<double>& f, LobePlan& plan, const std::string& p) {
    PrincipledFresnel out;
    out.f0 = normal_reflectance(f);
    switch (f.type) {
        case FresnelType::kDielectric:
            if (!(f.eta > 1) || out.f0[0] > kMaxPrincipledF0) {
                return refuse(p + ": a dielectric Fresnel of eta " + num(f.eta) +
                              " cannot be represented by Blender's Principled BSDF, whose "
                              "dielectric Fresnel takes 1 < eta <= 1.788 (f0 <= 0.08)");
            }
            // The Principled BSDF's Fresnel of this Specular is F_d(eta) itself.
            out.specular = out.f0[0] / kMaxPrincipledF0;
            break;
        case FresnelType::kSchlick:
            plan.approximations.push_back("schlick");
            out.specular = principled_specular_for_schlick(f.f0.mean());
            break;
        case FresnelType::kConductor:
            plan.needs_approximate.push_back(
                p +
                ": a conductor Fresnel (Blender 3 has no conductor Fresnel; --approximate "
                "writes the Principled BSDF's metallic Fresnel with the normal-incidence "
                "reflectance " +
                rgb(out.f0) + ")");
            plan.approximations.push_back("conductor");
            out.specular = 1.0;
            break;
        case FresnelType::kNone:
            GONIO_CHECK(false);
            break;
    }
    return out;
}

/// scale_c F_c = scale_c f0_c + scale_c (1 - f0_c) F_H with F_H the Principled BSDF's normalised
/// Fresnel, written as g_c + w (b_c + (1 - b_c) F_H): a Principled BSDF of Base Color b weighted
/// by w = min_c scale_c, plus a Glossy BSDF of colour g_c = scale_c - w, with b_c = 1 - scale_c (1
/// - f0_c) / w. Possible (b_c >= 0) when max_c scale_c (1 - f0_c) <= min_c scale_c, which holds for
/// a grey scale and for one whose channels differ by less than f0; otherwise the colour of the
/// scale is folded into the Base Color (an approximation, exact at normal incidence).
tl::expected<std::string, BlenderExportError> principled_python(const Lobe<double>& l,
                                                                LobePlan& plan,
                                                                const std::string& p,
                                                                const PrincipledFresnel& f) {
    const Rgbd& s = l.scale;
    if (!(s.maxCoeff() > 0)) {
        return "glossy(\"GGX\", " + num(std::sqrt(plan.alpha_x)) + ", (0.0, 0.0, 0.0))";
    }
    if (s.maxCoeff() > kMaxWeight) {
        return refuse(p + ": scale " + num(s.maxCoeff()) + " above " + num(kMaxWeight) +
                      " on a lobe with a Fresnel term cannot be represented by Blender");
    }
    const Rgbd grazing_part = s.cwiseProduct(Rgbd::Ones() - f.f0);
    double w = s.minCoeff();
    Rgbd base, glossy = Rgbd::Zero();
    if (w > 0 && grazing_part.maxCoeff() <= w * (1 + 1e-12)) {
        base = (Rgbd::Ones() - grazing_part / w).cwiseMax(0.0);
        glossy = s - Rgbd::Constant(w);
    } else {
        plan.needs_approximate.push_back(
            p + ": a coloured scale " + rgb(s) +
            " on a lobe with a Fresnel term, whose channels differ by more than f0 (the "
            "Principled BSDF's colour is its normal-incidence reflectance; --approximate folds "
            "the colour into it, exact at normal incidence)");
        plan.approximations.push_back("scale-colour-fresnel");
        w = s.maxCoeff();
        base = (s / w).cwiseProduct(f.f0);
    }
    std::string py = "weighted(principled(" + principled_shape(plan) +
                     ", metallic=1.0, base=" + rgb(base) + ", specular=" + num(f.specular) + "), " +
                     num(w) + ")";
    if (glossy.maxCoeff() > 1e-12 * w) {
        Lobe<double> g = l;
        g.scale = glossy;
        g.fresnel.type = FresnelType::kNone;
        py = "add(" + glossy_python(g, plan) + ", " + py + ")";
    }
    return py;
}

/// A lobe with a Fresnel term: the Principled BSDF, weighted by the lobe's grey scale.
tl::expected<std::string, BlenderExportError> fresnel_python(const Lobe<double>& l,
                                                             LobePlan& plan,
                                                             const std::string& p) {
    if (plan.distribution != "GGX") {
        return beckmann_fresnel_python(l, plan, p);
    }
    if (l.rgb_roughness) {
        return refuse(p +
                      ": an RGB roughness with a Fresnel term cannot be represented by "
                      "Blender (the Principled BSDF's colour cannot be split per channel); "
                      "refit without `--roughness rgb` or without Fresnel");
    }
    if (plan.anisotropic &&
        std::min(plan.alpha_x, plan.alpha_y) / std::max(plan.alpha_x, plan.alpha_y) <
            kMinPrincipledAspect2) {
        return refuse(p +
                      ": an anisotropic lobe with a Fresnel term and alpha ratio above 10 "
                      "cannot be represented by Blender's Principled BSDF");
    }
    auto fresnel = principled_fresnel(l.fresnel, plan, p);
    if (!fresnel) {
        return tl::unexpected(fresnel.error());
    }
    return principled_python(l, plan, p, *fresnel);
}

std::string describe_lobe(const Lobe<double>& l, const LobePlan& plan, bool principled) {
    std::string s = std::string(brdf::to_string(l.distribution)) + " ";
    if (l.distribution == Distribution::kBlinnPhong) {
        s += "exponent " + num(l.exponent);
    } else if (l.rgb_roughness) {
        s += "alpha " + rgb(l.alpha_rgb);
    } else if (plan.anisotropic) {
        s += "alpha_x " + num(plan.alpha_x) + ", alpha_y " + num(plan.alpha_y) + " at " +
             num(plan.orientation_deg) + " deg";
    } else {
        s += "alpha " + num(plan.alpha_x);
    }
    s += ", shadowing " + std::string(brdf::to_string(l.shadowing)) + ", fresnel " +
         brdf::to_string(l.fresnel.type) + ": ";
    if (principled) {
        s += plan.anisotropic ? "Principled BSDF (anisotropic along the UV tangent)"
                              : "Principled BSDF";
    } else if (l.rgb_roughness) {
        s += "one Glossy BSDF per channel";
    } else {
        s += plan.anisotropic ? "Anisotropic BSDF along the UV tangent" : "Glossy BSDF";
    }
    return s;
}

tl::expected<Term, BlenderExportError> lobe_term(const Lobe<double>& l,
                                                 std::size_t i,
                                                 const BlenderExportOptions& o) {
    const std::string p = "lobes[" + std::to_string(i) + "]";
    auto plan = plan_shape(l, p);
    if (!plan) {
        return tl::unexpected(plan.error());
    }
    Term t;
    const bool principled = l.fresnel.type != FresnelType::kNone;
    if (principled) {
        auto py = fresnel_python(l, *plan, p);
        if (!py) {
            return tl::unexpected(py.error());
        }
        t.python = *py;
    } else {
        t.python = glossy_python(l, *plan);
    }
    if (!plan->needs_approximate.empty() && !o.approximate) {
        return refuse(plan->needs_approximate.front() +
                      " cannot be represented by Blender; give --approximate to write the "
                      "approximation");
    }
    t.approximated_only = !plan->needs_approximate.empty();
    t.summary = p + ": " + describe_lobe(l, *plan, principled);
    if (plan->approximations.empty()) {
        t.summary += ": exact";
    }
    for (const std::string& key : plan->approximations) {
        t.summary += "; approximated (" + key + "): " + measured_text(key);
    }
    return t;
}

void write_header(std::ostringstream& os,
                  const BlenderExportOptions& o,
                  const std::vector<std::string>& summaries) {
    os << "# gonio model exported for Blender 3 (Cycles; tested with 3.4). Creates the material \""
       << o.name << "\" and nothing else:\n"
       << "#   blender -b --python THIS.py (or run it from Blender's text editor).\n"
       << "# Mapping and measurements: docs/blender.md. Each term, with the relative difference\n"
       << "# between Blender's render and gonio's evaluation measured on a lit sphere:\n";
    for (const std::string& s : summaries) {
        os << "#  - " << s << "\n";
    }
    os << "# Anisotropic lobes run along the tangent of the object's active UV map.\n";
}

const char* const kPrologue = R"PY(
import bpy


def gonio_material(name):
    material = bpy.data.materials.get(name)
    if material is None:
        material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    links = material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    tangents = []

    def uv_tangent():
        if not tangents:
            node = nodes.new("ShaderNodeTangent")
            node.direction_type = "UV_MAP"
            tangents.append(node)
        return tangents[0].outputs["Tangent"]

    def add(a, b):
        node = nodes.new("ShaderNodeAddShader")
        links.new(a, node.inputs[0])
        links.new(b, node.inputs[1])
        return node.outputs["Shader"]

    def weighted(closure, weight):
        doublings = 0
        while weight > 1.0:
            weight *= 0.5
            doublings += 1
        if weight < 1.0:
            node = nodes.new("ShaderNodeMixShader")
            node.inputs["Fac"].default_value = weight
            links.new(closure, node.inputs[2])
            closure = node.outputs["Shader"]
        for _ in range(doublings):
            closure = add(closure, closure)
        return closure

    def diffuse(color):
        node = nodes.new("ShaderNodeBsdfDiffuse")
        node.inputs["Color"].default_value = color + (1.0,)
        node.inputs["Roughness"].default_value = 0.0
        return node.outputs["BSDF"]

    def glossy(distribution, roughness, color):
        node = nodes.new("ShaderNodeBsdfGlossy")
        node.distribution = distribution
        node.inputs["Color"].default_value = color + (1.0,)
        node.inputs["Roughness"].default_value = roughness
        return node.outputs["BSDF"]

    def anisotropic(distribution, roughness, anisotropy, rotation, color):
        node = nodes.new("ShaderNodeBsdfAnisotropic")
        node.distribution = distribution
        node.inputs["Color"].default_value = color + (1.0,)
        node.inputs["Roughness"].default_value = roughness
        node.inputs["Anisotropy"].default_value = anisotropy
        node.inputs["Rotation"].default_value = rotation
        links.new(uv_tangent(), node.inputs["Tangent"])
        return node.outputs["BSDF"]

    def principled(roughness, metallic, base, specular, anisotropic=0.0, rotation=0.0):
        node = nodes.new("ShaderNodeBsdfPrincipled")
        node.distribution = "GGX"
        inputs = node.inputs
        inputs["Base Color"].default_value = base + (1.0,)
        inputs["Metallic"].default_value = metallic
        inputs["Specular"].default_value = specular
        inputs["Specular Tint"].default_value = 0.0
        inputs["Roughness"].default_value = roughness
        inputs["Anisotropic"].default_value = anisotropic
        inputs["Anisotropic Rotation"].default_value = rotation
        for off in ("Subsurface", "Sheen", "Clearcoat", "Transmission"):
            inputs[off].default_value = 0.0
        if anisotropic > 0.0:
            links.new(uv_tangent(), inputs["Tangent"])
        return node.outputs["BSDF"]

    terms = []
)PY";

const char* const kEpilogue = R"PY(    surface = terms[0]
    for term in terms[1:]:
        surface = add(surface, term)
    links.new(surface, output.inputs["Surface"])
    return material


)PY";

}  // namespace

tl::expected<BlenderExport, BlenderExportError> export_blender(const ModelD& model,
                                                               const BlenderExportOptions& o) {
    if (auto ok = check_name(o.name); !ok) {
        return tl::unexpected(ok.error());
    }
    if (auto ok = validate(model); !ok) {
        return tl::unexpected(ok.error());
    }
    std::vector<Term> terms;
    if (model.has_diffuse && model.diffuse.maxCoeff() > 0) {
        terms.push_back(
            {"diffuse(" + rgb(model.diffuse) + ")",
             "diffuse " + rgb(model.diffuse) + ": Diffuse BSDF of roughness 0 (Lambert): exact",
             false});
    }
    for (std::size_t i = 0; i < model.lobes.size(); ++i) {
        auto t = lobe_term(model.lobes[i], i, o);
        if (!t) {
            return tl::unexpected(t.error());
        }
        terms.push_back(*t);
    }
    if (terms.empty()) {
        terms.push_back({"diffuse((0.0, 0.0, 0.0))", "no term: a black Diffuse BSDF", false});
    }
    BlenderExport out;
    for (const Term& t : terms) {
        out.terms.push_back(t.summary);
        if (t.summary.find("approximated") != std::string::npos) {
            out.approximations.push_back(t.summary);
        }
    }
    std::ostringstream os;
    write_header(os, o, out.terms);
    os << kPrologue;
    for (const Term& t : terms) {
        os << "    terms.append(" << t.python << ")\n";
    }
    os << kEpilogue << "gonio_material(\"" << o.name << "\")\n";
    out.text = os.str();
    return out;
}

const std::vector<BlenderMeasured>& blender_measured_differences() {
    // Measured by tests/report/integration_blender_test.cpp (which checks that each render stays
    // within these bounds); docs/blender.md lists the commands.
    static const std::vector<BlenderMeasured> table = {
        {"smith-correlated", "GGX alpha 0.3, F = 1, no diffuse", 0.1, 1.5, 1.0, 3.5},
        {"schlick",
         "plastic-ggx: GGX alpha 0.2, correlated, Schlick 0.04, Lambert",
         0.05,
         0.1,
         2.5,
         6.0},
        {"blinn-phong", "blinn-phong: exponent 80, Schlick 0.04, Lambert 0.5", 0.01, 0.2, 0.1, 25},
        {"fresnel-at-normal-incidence",
         "copper-beckmann: Beckmann alpha 0.15, conductor",
         0.01,
         0.02,
         1.0,
         2.5},
        {"conductor",
         "brushed-aluminium: anisotropic GGX 0.05 x 0.3, correlated, conductor",
         0.05,
         0.2,
         2.5,
         3.0},
        {"scale-colour-fresnel",
         "GGX alpha 0.2, Schlick 0.04, scale (1, 0.6, 0.3), Lambert 0.1",
         0.05,
         0.1,
         8.5,
         40},
    };
    return table;
}

const BlenderMeasured& blender_measured(const std::string& key) {
    for (const BlenderMeasured& m : blender_measured_differences()) {
        if (key == m.key) {
            return m;
        }
    }
    GONIO_CHECK(false);
    std::abort();
}

}  // namespace gonio::report
