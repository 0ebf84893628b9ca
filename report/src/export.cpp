#include "gonio/report/export.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "gonio/brdf/blinn_phong.h"
#include "gonio/report/html_report.h"

namespace gonio::report {

namespace {

/// A Schlick f0 from which on no dielectric index reproduces F(0) (eta = (1 + sqrt f0) / (1 -
/// sqrt f0) passes 4e8): the lobe is exported as a conductor instead.
constexpr double kMirrorF0 = 1.0 - 1e-8;

using brdf::Distribution;
using brdf::FresnelType;
using brdf::Lobe;
using brdf::ModelD;
using brdf::Rgbd;
using brdf::Shadowing;

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

bool finite(const Rgbd& v) {
    return v.allFinite();
}

/// A material name or id embedded in a renderer file: 1 to 128 letters, digits, '_', '-', '.'.
/// Anything else (quotes, newlines, '<', '#') is refused rather than escaped, so that the name
/// reads the same in every renderer and can never end a string or start a statement.
Expected<void> check_name(const std::string& name, const char* what) {
    constexpr std::size_t kMaxName = 128;
    if (name.empty() || name.size() > kMaxName) {
        return make_error(std::string(what) + ": " + std::to_string(name.size()) +
                          " characters, must be 1 to " + std::to_string(kMaxName));
    }
    for (std::size_t i = 0; i < name.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(name[i]);
        if (!(std::isalnum(c) || c == '_' || c == '-' || c == '.')) {
            char code[8];
            std::snprintf(code, sizeof code, "0x%02x", c);
            return make_error(std::string(what) + ": character " + std::to_string(i + 1) + " (" +
                              code + ") is not allowed; use letters, digits, '_', '-' or '.'");
        }
    }
    return {};
}

/// Checks the values an export relies on; names the key path.
Expected<void> validate(const ModelD& m) {
    if (m.has_diffuse && (!finite(m.diffuse) || (m.diffuse < 0).any())) {
        return make_error("diffuse: must be finite and >= 0");
    }
    for (std::size_t i = 0; i < m.lobes.size(); ++i) {
        const Lobe<double>& l = m.lobes[i];
        const std::string p = "lobes[" + std::to_string(i) + "].";
        if (l.distribution == Distribution::kBlinnPhong) {
            if (!(l.exponent > 0) || !std::isfinite(l.exponent)) {
                return make_error(p + "exponent = " + num(l.exponent) + ": must be finite and > 0");
            }
        } else {
            if (!(l.alpha_x > 0) || !std::isfinite(l.alpha_x)) {
                return make_error(p + "alpha_x = " + num(l.alpha_x) + ": must be finite and > 0");
            }
            if (l.anisotropic && (!(l.alpha_y > 0) || !std::isfinite(l.alpha_y))) {
                return make_error(p + "alpha_y = " + num(l.alpha_y) + ": must be finite and > 0");
            }
            if (!std::isfinite(l.orientation_deg)) {
                return make_error(p + "orientation_deg: must be finite");
            }
        }
        if (!finite(l.scale) || (l.scale < 0).any()) {
            return make_error(p + "scale: must be finite and >= 0");
        }
        switch (l.fresnel.type) {
            case FresnelType::kSchlick:
                if (!finite(l.fresnel.f0) || (l.fresnel.f0 < 0).any() || (l.fresnel.f0 > 1).any()) {
                    return make_error(p + "fresnel.f0: must lie in [0, 1]");
                }
                break;
            case FresnelType::kDielectric:
                if (!(l.fresnel.eta > 0) || !std::isfinite(l.fresnel.eta)) {
                    return make_error(p + "fresnel.eta = " + num(l.fresnel.eta) + ": must be > 0");
                }
                break;
            case FresnelType::kConductor:
                if (!finite(l.fresnel.eta_rgb) || (l.fresnel.eta_rgb <= 0).any() ||
                    !finite(l.fresnel.k) || (l.fresnel.k < 0).any()) {
                    return make_error(p + "fresnel: eta must be > 0 and k >= 0, finite");
                }
                break;
            case FresnelType::kNone:
                break;
        }
    }
    return {};
}

/// The model as the renderers' distributions hold it: a Student-t lobe at gamma = 2 is GGX exactly
/// and is written as one; any other Student-t lobe has no counterpart in the renderer (Mitsuba 3
/// and pbrt-v4 take GGX and Beckmann only) and the export is refused, naming the lobe; so is a
/// tabulated lobe, which an RGL material file holds instead, and so is a lobe whose roughness
/// differs between the channels (one with equal channels is written as the grey lobe).
Expected<ModelD> representable(const ModelD& m, const char* renderer) {
    ModelD out = m;
    for (std::size_t i = 0; i < out.lobes.size(); ++i) {
        Lobe<double>& l = out.lobes[i];
        if (l.distribution == Distribution::kTabulated) {
            return make_error("lobes[" + std::to_string(i) +
                              "]: a tabulated NDF (extracted by power iteration) cannot be "
                              "represented by " +
                              renderer +
                              ", which takes ggx and beckmann only; write it as an RGL material "
                              "file, which Mitsuba 3's measured plugin renders (`gonio convert "
                              "fit.json out.bsdf`), or refit with `--model ggx`");
        }
        if (l.rgb_roughness) {
            // One roughness per channel: the renderers' roughness is a scalar texture. Equal
            // channels are the grey lobe itself.
            const double mx = l.alpha_rgb.maxCoeff();
            if (!((mx - l.alpha_rgb.minCoeff()) <= 1e-9 * mx)) {
                return make_error("lobes[" + std::to_string(i) + "]: an RGB-varying roughness " +
                                  "(alpha " + num(l.alpha_rgb[0]) + ", " + num(l.alpha_rgb[1]) +
                                  ", " + num(l.alpha_rgb[2]) + ") cannot be represented by " +
                                  renderer +
                                  ", whose roughness is one number for every wavelength; write "
                                  "it as an RGL material file, which Mitsuba 3's measured plugin "
                                  "renders (`gonio convert fit.json out.bsdf`), or refit without "
                                  "`--roughness rgb`");
            }
            l.rgb_roughness = false;
            l.alpha_x = l.alpha_y = l.alpha_rgb[1];
        }
        if (l.anisotropic && l.distribution != Distribution::kBlinnPhong) {
            // The renderers' anisotropic lobes run along the shape's tangents, with no turn of
            // their own about the normal. A lobe turned by 0 or 180 degrees is written as it is,
            // one turned by 90 or 270 with its slopes exchanged (the same lobe,
            // lobe_orientation.h); equal slopes do not depend on the turn.
            const double deg = l.orientation_deg;
            const double mod = deg - 180 * std::floor(deg / 180);
            constexpr double kTolDeg = 1e-6;
            if (l.alpha_x == l.alpha_y || mod <= kTolDeg || mod >= 180 - kTolDeg) {
                l.orientation_deg = 0;
            } else if (std::abs(mod - 90) <= kTolDeg) {
                std::swap(l.alpha_x, l.alpha_y);
                l.orientation_deg = 0;
            } else {
                return make_error("lobes[" + std::to_string(i) + "].orientation_deg = " + num(deg) +
                                  ": " + renderer +
                                  " runs an anisotropic lobe along the shape's tangents and has "
                                  "no turn of its own about the normal; turn the shape's tangent "
                                  "(u, dp/du) by " +
                                  num(mod) +
                                  " degrees in the scene and export the model with "
                                  "orientation_deg 0");
            }
        }
        if (l.distribution != Distribution::kStudentT) {
            continue;
        }
        if (std::abs(l.gamma - 2) <= 1e-9) {
            l.distribution = Distribution::kGgx;
            continue;
        }
        return make_error("lobes[" + std::to_string(i) + "]: a student-t lobe (gamma " +
                          num(l.gamma) + ") cannot be represented by " + renderer +
                          ", which takes ggx and beckmann only; refit with `--model ggx` or "
                          "`--model beckmann`, or tabulate the model (`gonio convert`)");
    }
    return out;
}

/// Slope parameters of a lobe as the renderers take them (Blinn-Phong through its Beckmann
/// equivalent).
std::pair<double, double> lobe_alphas(const Lobe<double>& l) {
    if (l.distribution == Distribution::kBlinnPhong) {
        const double a = brdf::blinn_phong_equivalent_alpha(l.exponent);
        return {a, a};
    }
    return {l.alpha_x, l.anisotropic ? l.alpha_y : l.alpha_x};
}

bool is_grey(const Rgbd& v) {
    const double mx = v.maxCoeff();
    return mx <= 0 || (mx - v.minCoeff()) <= 1e-9 * mx;
}

/// Normal-incidence reflectance of a lobe's Fresnel term per channel.
Rgbd normal_reflectance(const brdf::Fresnel<double>& f) {
    switch (f.type) {
        case FresnelType::kNone:
            return Rgbd::Ones();
        case FresnelType::kSchlick:
            return f.f0;
        case FresnelType::kDielectric: {
            const double r = (f.eta - 1) / (f.eta + 1);
            return Rgbd::Constant(r * r);
        }
        case FresnelType::kConductor: {
            Rgbd out;
            for (int c = 0; c < 3; ++c) {
                const double n = f.eta_rgb[c];
                const double k = f.k[c];
                out[c] = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
            }
            return out;
        }
    }
    return Rgbd::Ones();
}

std::string rgb_list(const Rgbd& v, const char* sep) {
    return num(v[0]) + sep + num(v[1]) + sep + num(v[2]);
}

/// Comment text may not contain "--" in XML.
std::string xml_comment_safe(std::string s) {
    std::size_t p;
    while ((p = s.find("--")) != std::string::npos) {
        s.replace(p, 2, "- ");
    }
    return s;
}

void shadowing_notes(const ModelD& m,
                     Shadowing renderer,
                     const char* renderer_name,
                     std::vector<std::string>& notes) {
    for (std::size_t i = 0; i < m.lobes.size(); ++i) {
        const Shadowing s = m.lobes[i].shadowing;
        if (s == renderer) {
            continue;
        }
        notes.push_back("lobes[" + std::to_string(i) + "]: shadowing " + brdf::to_string(s) +
                        " replaced by " + renderer_name + "'s " + brdf::to_string(renderer) +
                        " Smith G (differs mostly at grazing angles)");
    }
}

}  // namespace

Expected<std::optional<ModelFileVerdict>> read_model_verdict(const std::string& model_path) {
    std::ifstream in(model_path, std::ios::binary);
    if (!in) {
        return make_error(model_path + ": cannot open for reading");
    }
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
        return make_error(model_path + ": not a model file (JSON object)");
    }
    const auto fit = j.find("fit");
    if (fit == j.end() || !fit->is_object()) {
        return std::optional<ModelFileVerdict>();
    }
    auto text = [&](const char* key) {
        const auto v = fit->find(key);
        return v != fit->end() && v->is_string() ? v->get<std::string>() : std::string();
    };
    ModelFileVerdict v;
    v.verdict = text("verdict");
    v.headline = text("headline");
    v.report = text("report");
    if (v.verdict.empty()) {
        // Written before the three-state verdict: its represents flag.
        const auto r = fit->find("represents");
        const bool represents = r == fit->end() || !r->is_boolean() || r->get<bool>();
        v.verdict = represents ? "represents" : "does-not-represent";
        if (v.headline.empty() && !represents) {
            v.headline = "MISFIT: does not represent these data";
        }
    }
    return std::optional<ModelFileVerdict>(v);
}

std::string with_verdict(const std::string& text, const ModelFileVerdict& v, bool xml) {
    if (v.verdict == "represents") {
        return text;
    }
    const std::string line = "gonio fit verdict: " + v.headline +
                             (v.report.empty() ? "" : " (report " + v.report + ")") +
                             ": this material reproduces that fit, not the measurement";
    if (!xml) {
        return "# " + line + "\n" + text;
    }
    const std::string decl_end = "?>\n";
    const std::size_t at = text.rfind("<?xml", 0) == 0 ? text.find(decl_end) : std::string::npos;
    const std::string comment = "<!-- " + xml_comment_safe(line) + " -->\n";
    if (at == std::string::npos) {
        return comment + text;
    }
    return text.substr(0, at + decl_end.size()) + comment + text.substr(at + decl_end.size());
}

double eta_from_f0(double f0) {
    if (!(f0 > 0)) {
        // No reflection at normal incidence: index matched.
        return 1.0;
    }
    const double s = std::sqrt(std::min(f0, 1.0 - 1e-12));
    return (1 + s) / (1 - s);
}

double k_from_f0(double f0) {
    if (!(f0 > 0)) {
        // No reflection: k = 0 with eta = 1.
        return 0.0;
    }
    if (f0 >= 1.0 - 1e-8) {
        // A perfect mirror needs k -> infinity; 1e4 gives F(0) = 1 - 4e-8.
        return 1e4;
    }
    return 2 * std::sqrt(f0) / std::sqrt(1 - f0);
}

namespace {

/// A Mitsuba 3 BSDF: its type and its parameters (XML elements).
struct MitsubaComponent {
    std::string xml_open;  // without the closing tag, indented by the caller
    std::vector<std::string> params;
};

/// The Fresnel term of a lobe as a roughconductor's eta and k ("material" none for F = 1).
void mitsuba_fresnel(const Lobe<double>& l,
                     const std::string& p,
                     MitsubaComponent& c,
                     std::vector<std::string>& notes) {
    switch (l.fresnel.type) {
        case FresnelType::kNone:
            c.params.push_back("<string name=\"material\" value=\"none\"/>");
            break;
        case FresnelType::kConductor:
            c.params.push_back("<rgb name=\"eta\" value=\"" + rgb_list(l.fresnel.eta_rgb, ", ") +
                               "\"/>");
            c.params.push_back("<rgb name=\"k\" value=\"" + rgb_list(l.fresnel.k, ", ") + "\"/>");
            break;
        case FresnelType::kDielectric:
            c.params.push_back("<rgb name=\"eta\" value=\"" +
                               rgb_list(Rgbd::Constant(l.fresnel.eta), ", ") + "\"/>");
            c.params.push_back("<rgb name=\"k\" value=\"0, 0, 0\"/>");
            if (l.fresnel.eta < 1) {
                notes.push_back(p +
                                ": dielectric eta < 1 (total internal reflection) "
                                "written as a conductor with k = 0");
            }
            break;
        case FresnelType::kSchlick: {
            if ((l.fresnel.f0 >= kMirrorF0).any()) {
                // No dielectric reflects everything at normal incidence (eta would run to
                // infinity): a conductor of eta = 1 with k from f0 matches F(0) instead.
                Rgbd k;
                for (int ch = 0; ch < 3; ++ch) {
                    k[ch] = k_from_f0(l.fresnel.f0[ch]);
                }
                c.params.push_back("<rgb name=\"eta\" value=\"1, 1, 1\"/>");
                c.params.push_back("<rgb name=\"k\" value=\"" + rgb_list(k, ", ") + "\"/>");
                notes.push_back(p + ": Schlick f0 " + rgb_list(l.fresnel.f0, " ") +
                                " reaches 1, which no dielectric index gives (eta would be "
                                "infinite): written as a conductor with eta = 1, k = 2 "
                                "sqrt(f0) / sqrt(1 - f0) (k = 1e4 where f0 = 1), equal at "
                                "normal incidence");
                break;
            }
            Rgbd eta;
            for (int ch = 0; ch < 3; ++ch) {
                eta[ch] = eta_from_f0(l.fresnel.f0[ch]);
            }
            c.params.push_back("<rgb name=\"eta\" value=\"" + rgb_list(eta, ", ") + "\"/>");
            c.params.push_back("<rgb name=\"k\" value=\"0, 0, 0\"/>");
            notes.push_back(p + ": Schlick Fresnel (f0 " + rgb_list(l.fresnel.f0, " ") +
                            ") replaced by the exact dielectric Fresnel with eta = (1 + "
                            "sqrt f0) / (1 - sqrt f0): equal at normal incidence, differs "
                            "toward grazing angles");
            break;
        }
    }
}

/// Lobe i as a roughconductor whose reflectance is multiplied by `factor` (the blend's share).
MitsubaComponent mitsuba_lobe(const Lobe<double>& l,
                              std::size_t i,
                              double factor,
                              std::vector<std::string>& notes) {
    const std::string p = "lobes[" + std::to_string(i) + "]";
    MitsubaComponent c{"roughconductor", {}};
    const char* dist = l.distribution == Distribution::kGgx ? "ggx" : "beckmann";
    if (l.distribution == Distribution::kBlinnPhong) {
        notes.push_back(p + ": Blinn-Phong exponent " + num(l.exponent) +
                        " mapped to Beckmann alpha = sqrt(2 / (e + 2)) = " +
                        num(lobe_alphas(l).first) + " (Walter et al. 2007, sec. 5.2)");
    }
    c.params.push_back(std::string("<string name=\"distribution\" value=\"") + dist + "\"/>");
    const auto [ax, ay] = lobe_alphas(l);
    if (l.anisotropic && l.distribution != Distribution::kBlinnPhong) {
        c.params.push_back("<float name=\"alpha_u\" value=\"" + num(ax) + "\"/>");
        c.params.push_back("<float name=\"alpha_v\" value=\"" + num(ay) + "\"/>");
        notes.push_back(p +
                        ": alpha_u runs along the shape's u tangent, which must follow "
                        "the sample's x reference direction");
    } else {
        c.params.push_back("<float name=\"alpha\" value=\"" + num(ax) + "\"/>");
    }
    mitsuba_fresnel(l, p, c, notes);
    c.params.push_back("<rgb name=\"specular_reflectance\" value=\"" +
                       rgb_list(l.scale * factor, ", ") + "\"/>");
    return c;
}

/// The scene file: a comment with the notes, the components in nested blends (blend(weight
/// (r-1)/r, c_j, rest) gives c_j the share 1/r of what reaches it), the outermost named `id`.
std::string mitsuba_xml(const std::string& id,
                        const std::vector<std::string>& notes,
                        const std::vector<MitsubaComponent>& comps) {
    std::ostringstream os;
    os << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n";
    os << "<!--\n  gonio model exported for Mitsuba 3. Reference it with <ref id=\""
       << xml_comment_safe(id) << "\"/>.\n"
       << "  Mapping: docs/file-formats.md (renderer exports).\n";
    if (notes.empty()) {
        os << "  Every term is mapped exactly.\n";
    } else {
        os << "  Not mapped exactly:\n";
        for (const std::string& n : notes) {
            os << "  - " << xml_comment_safe(n) << "\n";
        }
    }
    os << "-->\n<scene version=\"3.0.0\">\n";
    std::string indent = "    ";
    const std::size_t n = comps.size();
    for (std::size_t j = 0; j < n; ++j) {
        const bool last = j + 1 == n;
        const std::string id_attr = j == 0 ? " id=\"" + html_escape(id) + "\"" : "";
        if (!last) {
            const double r = static_cast<double>(n - j);
            os << indent << "<bsdf type=\"blendbsdf\"" << id_attr << ">\n";
            indent += "    ";
            os << indent << "<float name=\"weight\" value=\"" << num((r - 1) / r) << "\"/>\n";
        }
        os << indent << "<bsdf type=\"" << comps[j].xml_open << "\"" << (last ? id_attr : "")
           << ">\n";
        for (const std::string& p : comps[j].params) {
            os << indent << "    " << p << "\n";
        }
        os << indent << "</bsdf>\n";
    }
    for (std::size_t j = 0; j + 1 < n; ++j) {
        indent.resize(indent.size() - 4);
        os << indent << "</bsdf>\n";
    }
    os << "</scene>\n";
    return os.str();
}

/// A pbrt-v4 material: its name, its share of the mix, its type and its parameters.
struct PbrtComponent {
    std::string name;
    double weight;
    std::vector<std::string> params;  // after the type
    std::string type;
};

/// The conductor's eta and k of a lobe whose scale, divided by its largest channel, is `ratio`:
/// a coloured scale is folded into the reflectance at normal incidence.
void pbrt_fresnel(const Lobe<double>& l,
                  const std::string& p,
                  const Rgbd& ratio,
                  Rgbd* eta,
                  Rgbd* k,
                  std::vector<std::string>& notes) {
    *eta = Rgbd::Ones();
    *k = Rgbd::Zero();
    if (!is_grey(l.scale)) {
        const Rgbd f0 = ratio * normal_reflectance(l.fresnel);
        for (int ch = 0; ch < 3; ++ch) {
            (*k)[ch] = k_from_f0(f0[ch]);
        }
        notes.push_back(p + ": the colour of scale (" + rgb_list(l.scale, " ") +
                        ") is folded into the Fresnel reflectance at normal incidence "
                        "(eta = 1, k from f0 = " +
                        rgb_list(f0, " ") +
                        "); exact at normal incidence, the colour fades toward grazing");
        return;
    }
    switch (l.fresnel.type) {
        case FresnelType::kNone:
            *k = Rgbd::Constant(k_from_f0(1.0));
            notes.push_back(p + ": F = 1 written as eta = 1, k = 1e4 (F >= 1 - 4e-8)");
            break;
        case FresnelType::kConductor:
            *eta = l.fresnel.eta_rgb;
            *k = l.fresnel.k;
            break;
        case FresnelType::kDielectric:
            *eta = Rgbd::Constant(l.fresnel.eta);
            if (l.fresnel.eta < 1) {
                notes.push_back(p +
                                ": dielectric eta < 1 written as a conductor with "
                                "k = 0");
            }
            break;
        case FresnelType::kSchlick:
            for (int ch = 0; ch < 3; ++ch) {
                (*k)[ch] = k_from_f0(l.fresnel.f0[ch]);
            }
            notes.push_back(p + ": Schlick Fresnel (f0 " + rgb_list(l.fresnel.f0, " ") +
                            ") replaced by the conductor Fresnel with eta = 1, k = 2 "
                            "sqrt(f0) / sqrt(1 - f0): equal at normal incidence, differs "
                            "toward grazing angles");
            break;
    }
}

/// Lobe i as a conductor weighted by its scale's largest channel; nothing for a zero scale.
std::optional<PbrtComponent> pbrt_lobe(const Lobe<double>& l,
                                       std::size_t i,
                                       const std::string& name,
                                       std::vector<std::string>& notes) {
    const std::string p = "lobes[" + std::to_string(i) + "]";
    PbrtComponent c{name + ".lobe" + std::to_string(i), l.scale.maxCoeff(), {}, "conductor"};
    if (!(c.weight > 0)) {
        notes.push_back(p + ": scale is zero; the lobe is left out");
        return std::nullopt;
    }
    if (l.distribution == Distribution::kBeckmann) {
        notes.push_back(p +
                        ": Beckmann distribution replaced by Trowbridge-Reitz (GGX) with "
                        "the same alpha (pbrt-v4 has only Trowbridge-Reitz)");
    } else if (l.distribution == Distribution::kBlinnPhong) {
        notes.push_back(p + ": Blinn-Phong exponent " + num(l.exponent) +
                        " replaced by Trowbridge-Reitz (GGX) with alpha = sqrt(2 / (e + 2)) = " +
                        num(lobe_alphas(l).first));
    }
    const auto [ax, ay] = lobe_alphas(l);
    if (l.anisotropic && l.distribution != Distribution::kBlinnPhong) {
        c.params.push_back("\"float uroughness\" [ " + num(ax) + " ]");
        c.params.push_back("\"float vroughness\" [ " + num(ay) + " ]");
        notes.push_back(p +
                        ": uroughness runs along dp/du, which must follow the sample's x "
                        "reference direction");
    } else {
        c.params.push_back("\"float roughness\" [ " + num(ax) + " ]");
    }
    c.params.push_back("\"bool remaproughness\" [ false ]");
    Rgbd eta, k;
    pbrt_fresnel(l, p, l.scale / c.weight, &eta, &k, notes);
    c.params.push_back("\"rgb eta\" [ " + rgb_list(eta, " ") + " ]");
    c.params.push_back("\"rgb k\" [ " + rgb_list(k, " ") + " ]");
    return c;
}

/// The mix weights: the lobes' and the diffuse albedo's, divided by their total when it exceeds
/// 1; the diffuse term (first) takes what the lobes leave.
void pbrt_mix_weights(const ModelD& model,
                      const std::string& name,
                      double lobe_weights,
                      std::vector<PbrtComponent>& comps,
                      std::vector<std::string>& notes) {
    const double rho_max = model.has_diffuse ? model.diffuse.maxCoeff() : 0.0;
    const double total = lobe_weights + rho_max;
    double divide = 1.0;
    if (total > 1.0) {
        divide = total;
        notes.push_back("the terms need a total mix weight of " + num(total) +
                        " > 1: every weight is divided by " + num(total) +
                        ", so the material reflects the model / " + num(total) +
                        " (multiply the light by " + num(total) + " to compensate)");
    }
    for (PbrtComponent& c : comps) {
        c.weight /= divide;
    }
    const double w_d = 1.0 - lobe_weights / divide;
    if (w_d > 1e-12) {
        PbrtComponent d{name + ".diffuse", w_d, {}, "diffuse"};
        const Rgbd refl = model.has_diffuse ? Rgbd(model.diffuse / divide / w_d) : Rgbd::Zero();
        d.params.push_back("\"rgb reflectance\" [ " + rgb_list(refl, " ") + " ]");
        comps.insert(comps.begin(), d);
    }
    if (comps.size() > 1) {
        notes.push_back(
            "terms combined with nested \"mix\" materials: pbrt-v4 picks one per "
            "shading point, equal to the sum in expectation (more noise per sample; "
            "pbrt's GPU renderer does not take mixes of mixes)");
    }
}

/// The scene fragment: a comment with the notes, each component as a named material and (for
/// several) the chain of mixes, the outermost called `name`.
std::string pbrt_text(const std::string& name,
                      const std::vector<std::string>& notes,
                      const std::vector<PbrtComponent>& comps) {
    std::ostringstream os;
    os << "# gonio model exported for pbrt-v4. Use with: NamedMaterial \"" << name << "\"\n";
    os << "# Mapping: docs/file-formats.md (renderer exports).\n";
    if (notes.empty()) {
        os << "# Every term is mapped exactly.\n";
    } else {
        os << "# Not mapped exactly:\n";
        for (const std::string& n : notes) {
            os << "#  - " << n << "\n";
        }
    }
    auto emit = [&](const std::string& nm,
                    const std::string& type,
                    const std::vector<std::string>& params) {
        os << "MakeNamedMaterial \"" << nm << "\"\n    \"string type\" [ \"" << type << "\" ]\n";
        for (const std::string& p : params) {
            os << "    " << p << "\n";
        }
    };
    if (comps.size() == 1) {
        emit(name, comps[0].type, comps[0].params);
        return os.str();
    }
    for (const PbrtComponent& c : comps) {
        emit(c.name, c.type, c.params);
    }
    // Mix chain from the innermost: mix_j = mix(c_j, mix_{j+1}), amount = P(second) = 1 -
    // w_j / (w_j + ... + w_last).
    std::string inner = comps.back().name;
    double remaining = comps.back().weight;
    for (std::size_t j = comps.size() - 1; j-- > 0;) {
        remaining += comps[j].weight;
        const std::string nm = j == 0 ? name : name + ".mix" + std::to_string(j);
        const double amount = 1.0 - comps[j].weight / remaining;
        emit(nm,
             "mix",
             {"\"string materials\" [ \"" + comps[j].name + "\" \"" + inner + "\" ]",
              "\"float amount\" [ " + num(amount) + " ]"});
        inner = nm;
    }
    return os.str();
}

/// The model as a renderer can take it: its name checked, its terms mapped to what the renderer
/// represents, the result valid.
Expected<ModelD> exportable(const ModelD& model_in,
                            const std::string& name,
                            const char* name_kind,
                            const char* renderer) {
    if (auto v = check_name(name, name_kind); !v) {
        return make_error(v.error().message);
    }
    Expected<ModelD> model = representable(model_in, renderer);
    if (!model) {
        return make_error(model.error().message);
    }
    if (auto v = validate(*model); !v) {
        return make_error(v.error().message);
    }
    return model;
}

}  // namespace

Expected<RendererExport> export_mitsuba(const ModelD& model_in, const std::string& id) {
    const Expected<ModelD> model_or = exportable(model_in, id, "material id", "Mitsuba 3");
    if (!model_or) {
        return make_error(model_or.error().message);
    }
    const ModelD& model = *model_or;
    RendererExport out;
    std::vector<std::string>& notes = out.approximations;
    shadowing_notes(model, Shadowing::kSmithSeparable, "Mitsuba 3", notes);
    // Components: the diffuse term (when present and non-zero) and every lobe.
    std::vector<MitsubaComponent> comps;
    const bool diffuse = model.has_diffuse && model.diffuse.maxCoeff() > 0;
    const int m = static_cast<int>(model.lobes.size()) + (diffuse ? 1 : 0);
    const double factor = std::max(1, m);
    if (m > 1) {
        notes.push_back("the " + std::to_string(m) +
                        " terms are combined with blendbsdf (each weighted 1/" + std::to_string(m) +
                        ") and each term's reflectance multiplied by " + std::to_string(m) +
                        "; reflectances above 1 need an RGB variant of Mitsuba (scalar_rgb, "
                        "llvm_ad_rgb)");
    }
    if (diffuse) {
        comps.push_back({"diffuse",
                         {"<rgb name=\"reflectance\" value=\"" +
                          rgb_list(model.diffuse * factor, ", ") + "\"/>"}});
    }
    if (m == 0) {
        notes.push_back("the model has no term: exported as a black diffuse");
        comps.push_back({"diffuse", {"<rgb name=\"reflectance\" value=\"0, 0, 0\"/>"}});
    }
    for (std::size_t i = 0; i < model.lobes.size(); ++i) {
        comps.push_back(mitsuba_lobe(model.lobes[i], i, factor, notes));
    }
    out.text = mitsuba_xml(id, notes, comps);
    return out;
}

Expected<RendererExport> export_pbrt(const ModelD& model_in, const std::string& name) {
    const Expected<ModelD> model_or = exportable(model_in, name, "material name", "pbrt-v4");
    if (!model_or) {
        return make_error(model_or.error().message);
    }
    const ModelD& model = *model_or;
    RendererExport out;
    std::vector<std::string>& notes = out.approximations;
    shadowing_notes(model, Shadowing::kSmithCorrelated, "pbrt-v4", notes);
    std::vector<PbrtComponent> comps;
    double lobe_weights = 0;
    for (std::size_t i = 0; i < model.lobes.size(); ++i) {
        if (std::optional<PbrtComponent> c = pbrt_lobe(model.lobes[i], i, name, notes)) {
            lobe_weights += c->weight;
            comps.push_back(std::move(*c));
        }
    }
    pbrt_mix_weights(model, name, lobe_weights, comps, notes);
    out.text = pbrt_text(name, notes, comps);
    return out;
}

}  // namespace gonio::report
