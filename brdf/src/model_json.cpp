// Model JSON reading and writing (schema: docs/model-schema.md).

#include "gonio/brdf/model_json.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/ior.h"
#include "gonio/brdf/student_t.h"
#include "gonio/brdf/tabulated_ndf.h"

namespace gonio::brdf {

namespace {

using Json = nlohmann::json;
using OrderedJson = nlohmann::ordered_json;

/// Short form for summaries (six significant digits).
std::string show(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

enum class Rule { kPositive, kNonNegative, kUnit };

// Upper bounds of model parameters (docs/model-schema.md, "Limits"): far beyond any physical
// material, low enough that every evaluation and every table scale stays finite.
constexpr double kMaxAlbedo = 100;
constexpr double kMaxScale = 1e6;
constexpr double kMaxAlpha = 100;
// Smallest slope parameter: D at its peak is 1 / (pi alpha^2) = 3.2e7 here, still finite in every
// product a lobe forms (a smaller alpha is a mirror, which no table or fit resolves).
constexpr double kMinAlpha = 1e-4;
constexpr double kMaxExponent = 1e7;
constexpr double kMaxEta = 100;
// Largest value of a tabulated D (1/sr): above the peak of the sharpest analytic lobe
// (1 / (pi kMinAlpha^2) = 3.2e7).
constexpr double kMaxTableD = 1e8;
// Largest |orientation_deg| of an anisotropic lobe: a turn either way (the lobe has period 180).
constexpr double kMaxOrientationDeg = 360;

/// `shown` is the value as written in the document; `max` an upper bound (inclusive).
void check_rule(
    double v, const std::string& path, const std::string& shown, Rule rule, double max) {
    switch (rule) {
        case Rule::kPositive:
            if (!(v > 0)) {
                json_fail(path + " = " + shown + ": must be > 0");
            }
            break;
        case Rule::kNonNegative:
            if (!(v >= 0)) {
                json_fail(path + " = " + shown + ": must be >= 0");
            }
            break;
        case Rule::kUnit:
            if (!(v >= 0 && v <= 1)) {
                json_fail(path + " = " + shown + ": must be in [0, 1]");
            }
            break;
    }
    if (v > max) {
        json_fail(path + " = " + shown + ": must be <= " + show_number(max));
    }
}

double get_scalar(const Json& j, const std::string& path, Rule rule, double max) {
    const double v = json_number_at(j, path);
    check_rule(v, path, show_number(v), rule, max);
    return v;
}

/// A slope parameter in [kMinAlpha, kMaxAlpha].
double get_alpha(const Json& j, const std::string& path) {
    const double v = get_scalar(j, path, Rule::kPositive, kMaxAlpha);
    if (v < kMinAlpha) {
        json_fail(path + " = " + show_number(v) + ": must be in [" + show_number(kMinAlpha) + ", " +
                  show_number(kMaxAlpha) + "]");
    }
    return v;
}

/// A number (same value in the three channels) or an array of three numbers.
Rgbd get_rgb(const Json& j, const std::string& path, Rule rule, double max) {
    if (j.is_number()) {
        return Rgbd::Constant(get_scalar(j, path, rule, max));
    }
    if (!j.is_array() || j.size() != 3) {
        json_fail(path + ": expected a number or an array of 3 numbers, got " +
                  (j.is_array() ? "an array of " + std::to_string(j.size()) : json_type(j)));
    }
    Rgbd out;
    for (int c = 0; c < 3; ++c) {
        out[c] = get_scalar(j[c], path + "[" + std::to_string(c) + "]", rule, max);
    }
    return out;
}

const IorEntry& get_material(const Json& j, const std::string& path) {
    const std::string name = json_string_at(j, path);
    const IorEntry* e = find_ior(name);
    if (e == nullptr) {
        json_fail(path + " = \"" + excerpt(name) + "\": unknown material (known: " + ior_names() +
                  ")");
    }
    return *e;
}

Fresnel<double> parse_fresnel(const Json& j, const std::string& path) {
    require_json_object(j, path);
    Fresnel<double> f;
    const std::string type = json_string_at(json_member(j, path, "type"), path + ".type");
    if (type == "none") {
        check_json_keys(j, path, {"type"});
        f.type = FresnelType::kNone;
    } else if (type == "schlick") {
        check_json_keys(j, path, {"type", "f0"});
        f.type = FresnelType::kSchlick;
        f.f0 = get_rgb(json_member(j, path, "f0"), path + ".f0", Rule::kUnit, 1);
    } else if (type == "dielectric") {
        check_json_keys(j, path, {"type", "eta", "material"});
        f.type = FresnelType::kDielectric;
        const bool has_eta = j.contains("eta");
        const bool has_material = j.contains("material");
        if (has_eta == has_material) {
            json_fail(path + ": give exactly one of \"eta\" and \"material\"");
        }
        if (has_eta) {
            f.eta = get_scalar(j["eta"], path + ".eta", Rule::kPositive, kMaxEta);
        } else {
            const IorEntry& e = get_material(j["material"], path + ".material");
            if (e.conductor) {
                json_fail(path + ".material = \"" + excerpt(e.name) +
                          "\": is a conductor, use \"type\": \"conductor\"");
            }
            f.eta = e.eta[0];
        }
    } else if (type == "conductor") {
        check_json_keys(j, path, {"type", "eta", "k", "material"});
        f.type = FresnelType::kConductor;
        const bool has_material = j.contains("material");
        if (has_material) {
            if (j.contains("eta") || j.contains("k")) {
                json_fail(path + ": give either \"material\" or \"eta\" and \"k\", not both");
            }
            const IorEntry& e = get_material(j["material"], path + ".material");
            f.eta_rgb = e.eta;
            f.k = e.k;
        } else {
            f.eta_rgb =
                get_rgb(json_member(j, path, "eta"), path + ".eta", Rule::kPositive, kMaxEta);
            f.k = get_rgb(json_member(j, path, "k"), path + ".k", Rule::kNonNegative, kMaxEta);
        }
    } else {
        json_fail(path + ".type = \"" + excerpt(type) +
                  "\": must be one of schlick, dielectric, conductor, none");
    }
    return f;
}

Distribution parse_distribution(const Json& j, const std::string& path) {
    const std::string dist =
        json_string_at(json_member(j, path, "distribution"), path + ".distribution");
    if (dist == "ggx") {
        return Distribution::kGgx;
    }
    if (dist == "beckmann") {
        return Distribution::kBeckmann;
    }
    if (dist == "blinn-phong") {
        return Distribution::kBlinnPhong;
    }
    if (dist == "student-t") {
        return Distribution::kStudentT;
    }
    if (dist == "tabulated") {
        return Distribution::kTabulated;
    }
    json_fail(path + ".distribution = \"" + excerpt(dist) +
              "\": must be one of ggx, beckmann, blinn-phong, student-t, tabulated");
}

/// The tail parameter of a Student-t lobe: Smith's Lambda is finite above 3/2 only (student_t.h).
void parse_student_t_gamma(const Json& j, const std::string& path, Lobe<double>* lobe) {
    if (lobe->distribution == Distribution::kStudentT) {
        lobe->gamma = get_scalar(
            json_member(j, path, "gamma"), path + ".gamma", Rule::kPositive, kStudentTGammaMax);
        if (!(lobe->gamma >= kStudentTGammaMin)) {
            json_fail(path + ".gamma = " + show_number(lobe->gamma) + ": must be in [" +
                      show_number(kStudentTGammaMin) + ", " + show_number(kStudentTGammaMax) +
                      "] (Smith masking is infinite below 3/2)");
        }
    } else if (j.contains("gamma")) {
        json_fail(path + ".gamma: only for student-t lobes");
    }
}

/// A tabulated lobe's D: "ndf", and none of the analytic shape keys.
void parse_tabulated_ndf(const Json& j, const std::string& path, Lobe<double>* lobe) {
    for (const char* key : {"alpha", "alpha_x", "alpha_y", "exponent"}) {
        if (j.contains(key)) {
            json_fail(json_key_path(path, key) +
                      ": not used by tabulated lobes (their D is \"ndf\")");
        }
    }
    const Json& nd = json_member(j, path, "ndf");
    const std::string at = path + ".ndf";
    if (!nd.is_array()) {
        json_fail(at + ": expected an array of D values at theta_h = (pi/2) (k / (n - 1))^2, got " +
                  json_type(nd));
    }
    std::vector<double> d;
    for (std::size_t k = 0; k < nd.size() && k <= kTabulatedNdfMaxNodes; ++k) {
        d.push_back(
            get_scalar(nd[k], at + "[" + std::to_string(k) + "]", Rule::kNonNegative, kMaxTableD));
    }
    Expected<TabulatedNdf> table = make_tabulated_ndf(std::move(d), at);
    if (!table) {
        json_fail(table.error().message);
    }
    lobe->table = std::make_shared<const TabulatedNdf>(std::move(*table));
}

/// RGB-varying roughness: one alpha per channel (model.h, Lobe::rgb_roughness).
void parse_rgb_alpha(const Json& alpha, const std::string& at, Lobe<double>* lobe) {
    if (alpha.size() != 3) {
        json_fail(at + ": expected a number or an array of 3 numbers (one per channel), " +
                  "got an array of " + std::to_string(alpha.size()));
    }
    lobe->anisotropic = false;
    lobe->rgb_roughness = true;
    for (int c = 0; c < 3; ++c) {
        lobe->alpha_rgb[c] = get_alpha(alpha[c], at + "[" + std::to_string(c) + "]");
    }
    lobe->alpha_x = lobe->alpha_y = lobe->alpha_rgb[1];
}

/// The angle of the lobe's x axis from the sample's x axis (model.h), degrees.
double parse_orientation_deg(const Json& j, const std::string& at) {
    const double deg = json_number_at(j, at);
    if (!(std::abs(deg) <= kMaxOrientationDeg)) {
        json_fail(at + " = " + show_number(deg) + ": must be in [-" +
                  show_number(kMaxOrientationDeg) + ", " + show_number(kMaxOrientationDeg) +
                  "] degrees");
    }
    return deg;
}

/// A microfacet lobe's slope: "alpha" (one number or one per channel) or "alpha_x" and
/// "alpha_y" (anisotropic, with an optional orientation).
void parse_microfacet_alpha(const Json& j,
                            const std::string& path,
                            const std::string& dist,
                            Lobe<double>* lobe) {
    if (j.contains("exponent")) {
        json_fail(path + ".exponent: only for blinn-phong lobes (" + dist + " uses alpha)");
    }
    const bool has_alpha = j.contains("alpha");
    const bool has_x = j.contains("alpha_x");
    const bool has_y = j.contains("alpha_y");
    if (has_alpha && (has_x || has_y)) {
        json_fail(path + ": give either \"alpha\" or \"alpha_x\" and \"alpha_y\", not both");
    }
    if (has_alpha && j["alpha"].is_array()) {
        parse_rgb_alpha(j["alpha"], path + ".alpha", lobe);
    } else if (has_alpha) {
        lobe->anisotropic = false;
        lobe->alpha_x = get_alpha(j["alpha"], path + ".alpha");
        lobe->alpha_y = lobe->alpha_x;
        lobe->alpha_rgb = Rgbd::Constant(lobe->alpha_x);
    } else if (has_x || has_y) {
        lobe->anisotropic = true;
        lobe->alpha_x = get_alpha(json_member(j, path, "alpha_x"), path + ".alpha_x");
        lobe->alpha_y = get_alpha(json_member(j, path, "alpha_y"), path + ".alpha_y");
        if (j.contains("orientation_deg")) {
            lobe->orientation_deg =
                parse_orientation_deg(j["orientation_deg"], path + ".orientation_deg");
        }
    } else {
        json_fail(path + ": missing key \"alpha\" (or \"alpha_x\" and \"alpha_y\")");
    }
}

/// A Blinn-Phong lobe's shape: "exponent", and none of the alpha keys.
void parse_blinn_phong_exponent(const Json& j, const std::string& path, Lobe<double>* lobe) {
    for (const char* key : {"alpha", "alpha_x", "alpha_y"}) {
        if (j.contains(key)) {
            json_fail(json_key_path(path, key) +
                      ": not used by blinn-phong lobes (they take \"exponent\")");
        }
    }
    lobe->exponent = get_scalar(
        json_member(j, path, "exponent"), path + ".exponent", Rule::kPositive, kMaxExponent);
}

Shadowing parse_shadowing(const Json& j, const std::string& path) {
    const std::string s = json_string_at(json_member(j, path, "shadowing"), path + ".shadowing");
    if (s == "smith-correlated") {
        return Shadowing::kSmithCorrelated;
    }
    if (s == "smith-separable") {
        return Shadowing::kSmithSeparable;
    }
    if (s == "v-groove") {
        return Shadowing::kVGroove;
    }
    if (s == "none") {
        return Shadowing::kNone;
    }
    json_fail(path + ".shadowing = \"" + excerpt(s) +
              "\": must be one of smith-correlated, smith-separable, v-groove, none");
}

Lobe<double> parse_lobe(const Json& j, const std::string& path) {
    require_json_object(j, path);
    check_json_keys(j,
                    path,
                    {"distribution",
                     "alpha",
                     "alpha_x",
                     "alpha_y",
                     "orientation_deg",
                     "exponent",
                     "gamma",
                     "ndf",
                     "shadowing",
                     "fresnel",
                     "scale"});
    Lobe<double> lobe;
    lobe.distribution = parse_distribution(j, path);
    parse_student_t_gamma(j, path, &lobe);
    const bool microfacet = lobe.distribution != Distribution::kBlinnPhong;
    if (lobe.distribution == Distribution::kTabulated) {
        parse_tabulated_ndf(j, path, &lobe);
    } else if (j.contains("ndf")) {
        json_fail(path + ".ndf: only for tabulated lobes");
    } else if (microfacet) {
        parse_microfacet_alpha(j, path, j["distribution"].get<std::string>(), &lobe);
    } else {
        parse_blinn_phong_exponent(j, path, &lobe);
    }
    if (j.contains("orientation_deg") && !lobe.anisotropic) {
        json_fail(path +
                  ".orientation_deg: only for anisotropic lobes (\"alpha_x\" and \"alpha_y\"); "
                  "an isotropic lobe does not depend on it");
    }
    // Shadowing and Fresnel: required for microfacet lobes; a Blinn-Phong lobe has neither unless
    // it asks for them.
    lobe.shadowing =
        microfacet || j.contains("shadowing") ? parse_shadowing(j, path) : Shadowing::kNone;
    if (microfacet || j.contains("fresnel")) {
        lobe.fresnel = parse_fresnel(json_member(j, path, "fresnel"), path + ".fresnel");
    } else {
        lobe.fresnel.type = FresnelType::kNone;
    }
    if (j.contains("scale")) {
        lobe.scale = get_rgb(j["scale"], path + ".scale", Rule::kNonNegative, kMaxScale);
    } else {
        lobe.scale = Rgbd::Ones();
    }
    return lobe;
}

ModelD parse_model(const Json& j, const std::string& path) {
    require_json_object(j, path);
    check_json_keys(j, path, {"diffuse", "lobes", "fit"});
    if (j.contains("fit") && !j["fit"].is_object()) {
        // The verdict of the fit that produced the model (written by `gonio fit`): informative,
        // not part of the model.
        json_fail(json_key_path(path, "fit") + ": must be an object (the fit's verdict)");
    }
    ModelD m;
    if (j.contains("diffuse")) {
        m.has_diffuse = true;
        m.diffuse =
            get_rgb(j["diffuse"], json_key_path(path, "diffuse"), Rule::kNonNegative, kMaxAlbedo);
    } else {
        m.has_diffuse = false;
        m.diffuse = Rgbd::Zero();
    }
    const std::string lobes_path = json_key_path(path, "lobes");
    const Json& lobes = json_member(j, path, "lobes");
    if (!lobes.is_array()) {
        json_fail(lobes_path + ": expected an array, got " + json_type(lobes));
    }
    if (lobes.size() > kMaxModelLobes) {
        json_fail(lobes_path + ": " + std::to_string(lobes.size()) + " lobes, at most " +
                  std::to_string(kMaxModelLobes) + " allowed");
    }
    for (std::size_t i = 0; i < lobes.size(); ++i) {
        m.lobes.push_back(parse_lobe(lobes[i], lobes_path + "[" + std::to_string(i) + "]"));
    }
    return m;
}

OrderedJson rgb_json(const Rgbd& v) {
    return OrderedJson::array({v[0], v[1], v[2]});
}

std::string fmt_rgb(const Rgbd& v) {
    if (v[0] == v[1] && v[1] == v[2]) {
        return show(v[0]);
    }
    return "[" + show(v[0]) + " " + show(v[1]) + " " + show(v[2]) + "]";
}

/// Puts arrays of numbers on one line ("[0.1, 0.2, 0.3]") in nlohmann's indented output; arrays of
/// objects keep their layout. The model's arrays hold numbers only, never strings.
std::string compact_number_arrays(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    std::size_t i = 0;
    while (i < s.size()) {
        if (s[i] == '[') {
            const std::size_t j = s.find(']', i);
            const std::string inner = s.substr(i + 1, j - i - 1);
            if (j != std::string::npos && inner.find_first_of("{[") == std::string::npos) {
                out += '[';
                std::string item;
                bool first = true;
                for (std::size_t k = 0; k <= inner.size(); ++k) {
                    if (k == inner.size() || inner[k] == ',') {
                        const auto b = item.find_first_not_of(" \n");
                        if (b != std::string::npos) {
                            out += first ? "" : ", ";
                            out += item.substr(b, item.find_last_not_of(" \n") - b + 1);
                            first = false;
                        }
                        item.clear();
                    } else {
                        item += inner[k];
                    }
                }
                out += ']';
                i = j + 1;
                continue;
            }
        }
        out += s[i++];
    }
    return out;
}

}  // namespace

Expected<ModelD> parse_model_json(const std::string& text, const std::string& source_name) {
    // Size and depth first, then syntax (line, column, a cut quote of the input), then the schema.
    return read_strict_json(source_name,
                            [&] { return parse_model(parse_json_checked(text, source_name), ""); });
}

ModelD read_model_json(const nlohmann::json& j, const std::string& path) {
    return parse_model(j, path);
}

Expected<ModelD> load_model_json(const std::string& path) {
    Expected<std::string> text = read_input_file(path, kMaxJsonBytes);
    if (!text) {
        return make_error(text.error().message + " (model file)");
    }
    return parse_model_json(*text, path);
}

std::string model_to_json(const ModelD& m, const std::string& fit_verdict) {
    OrderedJson j = OrderedJson::object();
    if (m.has_diffuse) {
        j["diffuse"] = rgb_json(m.diffuse);
    }
    OrderedJson lobes = OrderedJson::array();
    for (const Lobe<double>& l : m.lobes) {
        OrderedJson o = OrderedJson::object();
        o["distribution"] = to_string(l.distribution);
        if (l.distribution == Distribution::kBlinnPhong) {
            o["exponent"] = l.exponent;
        } else if (l.distribution == Distribution::kTabulated) {
            if (l.table != nullptr) {
                o["ndf"] = l.table->d;
            }
        } else if (l.anisotropic) {
            o["alpha_x"] = l.alpha_x;
            o["alpha_y"] = l.alpha_y;
            if (l.orientation_deg != 0) {
                o["orientation_deg"] = l.orientation_deg;
            }
        } else if (l.rgb_roughness) {
            o["alpha"] = rgb_json(l.alpha_rgb);
        } else {
            o["alpha"] = l.alpha_x;
        }
        if (l.distribution == Distribution::kStudentT) {
            o["gamma"] = l.gamma;
        }
        o["shadowing"] = to_string(l.shadowing);
        OrderedJson f = OrderedJson::object();
        f["type"] = to_string(l.fresnel.type);
        switch (l.fresnel.type) {
            case FresnelType::kSchlick:
                f["f0"] = rgb_json(l.fresnel.f0);
                break;
            case FresnelType::kDielectric:
                f["eta"] = l.fresnel.eta;
                break;
            case FresnelType::kConductor:
                f["eta"] = rgb_json(l.fresnel.eta_rgb);
                f["k"] = rgb_json(l.fresnel.k);
                break;
            case FresnelType::kNone:
                break;
        }
        o["fresnel"] = f;
        o["scale"] = rgb_json(l.scale);
        lobes.push_back(o);
    }
    j["lobes"] = lobes;
    if (!fit_verdict.empty()) {
        j["fit"] = OrderedJson::parse(fit_verdict);
    }
    return compact_number_arrays(j.dump(4)) + "\n";
}

std::string describe_model(const ModelD& m) {
    std::string out;
    if (m.has_diffuse) {
        out = "diffuse " + fmt_rgb(m.diffuse);
    }
    for (const Lobe<double>& l : m.lobes) {
        out += out.empty() ? "" : " + ";
        out += std::string(to_string(l.distribution)) + "(";
        if (l.distribution == Distribution::kBlinnPhong) {
            out += "exponent " + show(l.exponent);
        } else if (l.distribution == Distribution::kTabulated) {
            out += l.table != nullptr ? std::to_string(l.table->d.size()) + " nodes"
                                      : std::string("table to extract");
        } else if (l.anisotropic) {
            out += "alpha_x " + show(l.alpha_x) + " alpha_y " + show(l.alpha_y);
            if (l.orientation_deg != 0) {
                out += " orientation " + show(l.orientation_deg) + " deg";
            }
        } else if (l.rgb_roughness) {
            out += "alpha " + fmt_rgb(l.alpha_rgb);
        } else {
            out += "alpha " + show(l.alpha_x);
        }
        if (l.distribution == Distribution::kStudentT) {
            out += " gamma " + show(l.gamma);
        }
        out += ", " + std::string(to_string(l.shadowing)) + ", " + to_string(l.fresnel.type);
        if (!(l.scale == Rgbd::Ones()).all()) {
            out += ", scale " + fmt_rgb(l.scale);
        }
        out += ")";
    }
    return out.empty() ? std::string("zero BRDF (no diffuse, no lobes)") : out;
}

}  // namespace gonio::brdf
