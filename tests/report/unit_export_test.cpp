// Renderer exports: the Mitsuba XML is well formed and the pbrt text follows pbrt's grammar, and
// the numbers in both give back the model's parameters through the documented mapping.

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/report/export.h"
#include "test_models.h"

namespace gonio::report {
namespace {

// ---- A minimal XML reader: prolog, comments, elements, attributes; checks nesting. ----

struct XmlNode {
    std::string name;
    std::map<std::string, std::string> attrs;
    std::vector<std::unique_ptr<XmlNode>> children;
};

class XmlReader {
  public:
    explicit XmlReader(const std::string& s) : s_(s) {}

    /// Parses the whole document; empty error string when well formed.
    std::unique_ptr<XmlNode> parse(std::string* error) {
        skip_misc();
        if (s_.compare(i_, 5, "<?xml") == 0) {
            const auto end = s_.find("?>", i_);
            if (end == std::string::npos) {
                *error = "unterminated prolog";
                return nullptr;
            }
            i_ = end + 2;
        }
        skip_misc();
        auto root = element(error);
        if (!root) {
            return nullptr;
        }
        skip_misc();
        if (i_ != s_.size()) {
            *error = "content after the root element at offset " + std::to_string(i_);
            return nullptr;
        }
        return root;
    }

  private:
    void skip_ws() {
        while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) {
            ++i_;
        }
    }
    /// Whitespace and comments; a comment may not contain "--".
    bool skip_misc() {
        for (;;) {
            skip_ws();
            if (s_.compare(i_, 4, "<!--") != 0) {
                return true;
            }
            const auto end = s_.find("--", i_ + 4);
            if (end == std::string::npos || s_.compare(end, 3, "-->") != 0) {
                bad_comment_ = true;
                return false;
            }
            i_ = end + 3;
        }
    }
    static bool name_char(char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' ||
               c == ':';
    }
    std::string name() {
        const std::size_t b = i_;
        while (i_ < s_.size() && name_char(s_[i_])) {
            ++i_;
        }
        return s_.substr(b, i_ - b);
    }
    std::unique_ptr<XmlNode> element(std::string* error) {
        if (bad_comment_) {
            *error = "comment with \"--\" inside";
            return nullptr;
        }
        if (i_ >= s_.size() || s_[i_] != '<') {
            *error = "expected '<' at offset " + std::to_string(i_);
            return nullptr;
        }
        ++i_;
        auto node = std::make_unique<XmlNode>();
        node->name = name();
        if (node->name.empty()) {
            *error = "empty element name at offset " + std::to_string(i_);
            return nullptr;
        }
        for (;;) {
            skip_ws();
            if (s_.compare(i_, 2, "/>") == 0) {
                i_ += 2;
                return node;
            }
            if (i_ < s_.size() && s_[i_] == '>') {
                ++i_;
                break;
            }
            const std::string key = name();
            if (key.empty() || i_ + 1 >= s_.size() || s_[i_] != '=' || s_[i_ + 1] != '"') {
                *error = "bad attribute in <" + node->name + "> at offset " + std::to_string(i_);
                return nullptr;
            }
            i_ += 2;
            const auto end = s_.find('"', i_);
            if (end == std::string::npos) {
                *error = "unterminated attribute value";
                return nullptr;
            }
            const std::string value = s_.substr(i_, end - i_);
            if (value.find('<') != std::string::npos) {
                *error = "'<' inside an attribute value";
                return nullptr;
            }
            if (node->attrs.count(key)) {
                *error = "duplicate attribute " + key;
                return nullptr;
            }
            node->attrs[key] = value;
            i_ = end + 1;
        }
        for (;;) {
            if (!skip_misc()) {
                *error = "comment with \"--\" inside";
                return nullptr;
            }
            if (s_.compare(i_, 2, "</") == 0) {
                i_ += 2;
                const std::string close = name();
                skip_ws();
                if (close != node->name || i_ >= s_.size() || s_[i_] != '>') {
                    *error = "</" + close + "> closes <" + node->name + ">";
                    return nullptr;
                }
                ++i_;
                return node;
            }
            if (i_ >= s_.size()) {
                *error = "<" + node->name + "> not closed";
                return nullptr;
            }
            if (s_[i_] != '<') {
                *error = "text content where none is expected at offset " + std::to_string(i_);
                return nullptr;
            }
            auto child = element(error);
            if (!child) {
                return nullptr;
            }
            node->children.push_back(std::move(child));
        }
    }

    const std::string& s_;
    std::size_t i_ = 0;
    bool bad_comment_ = false;
};

TEST(XmlReader, RejectsMalformedDocuments) {
    std::string err;
    for (const char* bad : {"<a><b></a></b>",
                            "<a x=\"1\" x=\"2\"/>",
                            "<a>",
                            "<a/><b/>",
                            "<!-- a -- b --><a/>",
                            "<a x=1/>"}) {
        err.clear();
        EXPECT_EQ(XmlReader(bad).parse(&err), nullptr) << bad;
        EXPECT_FALSE(err.empty()) << bad;
    }
    EXPECT_NE(XmlReader("<?xml version=\"1.0\"?><!-- c --><a><b x=\"1\"/></a>").parse(&err),
              nullptr);
}

brdf::Rgbd rgb_attr(const XmlNode& n) {
    brdf::Rgbd v;
    char comma;
    std::istringstream is(n.attrs.at("value"));
    is >> v[0] >> comma >> v[1] >> comma >> v[2];
    return v;
}

const XmlNode* param(const XmlNode& bsdf, const std::string& name) {
    for (const auto& c : bsdf.children) {
        if (c->attrs.count("name") && c->attrs.at("name") == name) {
            return c.get();
        }
    }
    return nullptr;
}

/// What a Mitsuba BSDF tree means: each leaf with the weight the blends give it.
struct MitsubaLeaf {
    const XmlNode* node;
    double weight;
};

void collect_leaves(const XmlNode& n, double w, std::vector<MitsubaLeaf>& out) {
    ASSERT_EQ(n.name, "bsdf");
    if (n.attrs.at("type") != "blendbsdf") {
        out.push_back({&n, w});
        return;
    }
    const XmlNode* wt = param(n, "weight");
    ASSERT_NE(wt, nullptr);
    const double b = std::stod(wt->attrs.at("value"));
    std::vector<const XmlNode*> kids;
    for (const auto& c : n.children) {
        if (c->name == "bsdf") {
            kids.push_back(c.get());
        }
    }
    ASSERT_EQ(kids.size(), 2u);
    collect_leaves(*kids[0], w * (1 - b), out);  // weight 0 selects the first
    collect_leaves(*kids[1], w * b, out);
}

double f0_of_eta(double eta) {
    const double r = (eta - 1) / (eta + 1);
    return r * r;
}

brdf::ModelD three_term_model() {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd(0.2, 0.15, 0.1);
    auto a = testing::lobe(brdf::Distribution::kGgx, 0.12);
    a.shadowing = brdf::Shadowing::kSmithSeparable;
    a.fresnel.f0 = brdf::Rgbd(0.04, 0.05, 0.06);
    a.scale = brdf::Rgbd(0.3, 0.25, 0.2);
    auto b = testing::lobe(brdf::Distribution::kBeckmann, 0.3);
    b.anisotropic = true;
    b.alpha_y = 0.45;
    b.fresnel.type = brdf::FresnelType::kConductor;
    b.fresnel.eta_rgb = brdf::Rgbd(0.2, 0.9, 1.1);
    b.fresnel.k = brdf::Rgbd(3.9, 2.4, 2.2);
    b.scale = brdf::Rgbd::Constant(0.1);
    m.lobes = {a, b};
    return m;
}

TEST(MitsubaExport, WellFormedAndRoundTripsTheParameters) {
    const brdf::ModelD m = three_term_model();
    auto ex = export_mitsuba(m, "paint");
    ASSERT_TRUE(ex) << ex.error().message;
    std::string err;
    auto root = XmlReader(ex->text).parse(&err);
    ASSERT_NE(root, nullptr) << err << "\n" << ex->text;
    EXPECT_EQ(root->name, "scene");
    EXPECT_EQ(root->attrs.at("version"), "3.0.0");
    ASSERT_EQ(root->children.size(), 1u);
    EXPECT_EQ(root->children[0]->attrs.at("id"), "paint");
    std::vector<MitsubaLeaf> leaves;
    collect_leaves(*root->children[0], 1.0, leaves);
    ASSERT_EQ(leaves.size(), 3u);

    // Diffuse: weight * reflectance = rho.
    ASSERT_EQ(leaves[0].node->attrs.at("type"), "diffuse");
    const brdf::Rgbd rho = leaves[0].weight * rgb_attr(*param(*leaves[0].node, "reflectance"));
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(rho[c], m.diffuse[c], 1e-9);
    }
    // GGX lobe with Schlick: alpha, weight * specular_reflectance = scale, F(0) = f0.
    const XmlNode& g = *leaves[1].node;
    EXPECT_EQ(g.attrs.at("type"), "roughconductor");
    EXPECT_EQ(param(g, "distribution")->attrs.at("value"), "ggx");
    EXPECT_NEAR(std::stod(param(g, "alpha")->attrs.at("value")), 0.12, 1e-12);
    const brdf::Rgbd s0 = leaves[1].weight * rgb_attr(*param(g, "specular_reflectance"));
    const brdf::Rgbd eta0 = rgb_attr(*param(g, "eta"));
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(s0[c], m.lobes[0].scale[c], 1e-9);
        EXPECT_NEAR(f0_of_eta(eta0[c]), m.lobes[0].fresnel.f0[c], 1e-9);
    }
    // Anisotropic Beckmann conductor: alpha_u, alpha_v, eta, k as given.
    const XmlNode& b = *leaves[2].node;
    EXPECT_EQ(param(b, "distribution")->attrs.at("value"), "beckmann");
    EXPECT_NEAR(std::stod(param(b, "alpha_u")->attrs.at("value")), 0.3, 1e-12);
    EXPECT_NEAR(std::stod(param(b, "alpha_v")->attrs.at("value")), 0.45, 1e-12);
    const brdf::Rgbd k = rgb_attr(*param(b, "k"));
    const brdf::Rgbd s1 = leaves[2].weight * rgb_attr(*param(b, "specular_reflectance"));
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(k[c], m.lobes[1].fresnel.k[c], 1e-9);
        EXPECT_NEAR(s1[c], 0.1, 1e-9);
    }
    // What is not exact is said: Schlick, the correlated shadowing of the second lobe, the blend.
    EXPECT_NE(ex->text.find("Schlick"), std::string::npos);
    EXPECT_NE(ex->text.find("lobes[1]: shadowing smith-correlated"), std::string::npos) << ex->text;
    EXPECT_EQ(ex->text.find("lobes[0]: shadowing"), std::string::npos);
}

TEST(MitsubaExport, ExactCaseSaysSoAndBlinnPhongIsMapped) {
    brdf::ModelD m;
    m.has_diffuse = false;
    auto l = testing::lobe(brdf::Distribution::kGgx, 0.2);
    l.shadowing = brdf::Shadowing::kSmithSeparable;
    l.fresnel.type = brdf::FresnelType::kNone;
    m.lobes = {l};
    auto ex = export_mitsuba(m, "x");
    ASSERT_TRUE(ex);
    EXPECT_TRUE(ex->approximations.empty());
    EXPECT_NE(ex->text.find("Every term is mapped exactly"), std::string::npos);
    EXPECT_NE(ex->text.find("<string name=\"material\" value=\"none\"/>"), std::string::npos);

    m.lobes[0].distribution = brdf::Distribution::kBlinnPhong;
    m.lobes[0].exponent = 98.0;  // alpha = sqrt(2 / 100)
    ex = export_mitsuba(m, "x");
    ASSERT_TRUE(ex);
    std::string err;
    auto root = XmlReader(ex->text).parse(&err);
    ASSERT_NE(root, nullptr) << err;
    EXPECT_NEAR(
        std::stod(param(*root->children[0], "alpha")->attrs.at("value")), std::sqrt(0.02), 1e-9);
}

TEST(RendererExport, RejectsOutOfDomainParametersNamingThem) {
    brdf::ModelD m = three_term_model();
    m.lobes[1].alpha_y = std::nan("");
    auto a = export_mitsuba(m, "x");
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("lobes[1].alpha_y"), std::string::npos);
    m = three_term_model();
    m.lobes[0].fresnel.f0[1] = 1.5;
    auto b = export_pbrt(m, "x");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("lobes[0].fresnel.f0"), std::string::npos);
}

TEST(RendererExport, RgbRoughnessIsRefusedUnlessTheChannelsAgree) {
    // One alpha per channel: the renderers' roughness is one number, so both exports refuse it,
    // name the lobe and the way out (an RGL material file).
    brdf::ModelD m;
    m.has_diffuse = false;
    auto l = testing::lobe(brdf::Distribution::kGgx, 0.2);
    l.shadowing = brdf::Shadowing::kSmithSeparable;
    l.fresnel.type = brdf::FresnelType::kNone;
    l.rgb_roughness = true;
    l.alpha_rgb = brdf::Rgbd(0.1, 0.2, 0.3);
    m.lobes = {l};
    auto a = export_mitsuba(m, "x");
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("lobes[0]: an RGB-varying roughness"), std::string::npos)
        << a.error().message;
    EXPECT_NE(a.error().message.find("out.bsdf"), std::string::npos) << a.error().message;
    auto b = export_pbrt(m, "x");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("pbrt-v4"), std::string::npos) << b.error().message;
    // Equal channels are the grey lobe: written with that alpha.
    m.lobes[0].alpha_rgb = brdf::Rgbd::Constant(0.25);
    m.lobes[0].alpha_x = m.lobes[0].alpha_y = 0.25;
    auto c = export_mitsuba(m, "x");
    ASSERT_TRUE(c) << c.error().message;
    std::string err;
    auto root = XmlReader(c->text).parse(&err);
    ASSERT_NE(root, nullptr) << err;
    EXPECT_DOUBLE_EQ(std::stod(param(*root->children[0], "alpha")->attrs.at("value")), 0.25);
    EXPECT_TRUE(export_pbrt(m, "x"));
}

TEST(RendererExport, TurnedLobeIsWrittenAlongTheTangentsOrRefusedNamingTheField) {
    // The renderers' anisotropic lobes run along the shape's tangents: a lobe turned by 0 or 180
    // degrees is written as it is, by 90 or 270 with its slopes exchanged, by any other angle
    // refused naming lobes[i].orientation_deg.
    brdf::ModelD m;
    m.has_diffuse = false;
    auto l = testing::lobe(brdf::Distribution::kGgx, 0.08);
    l.anisotropic = true;
    l.alpha_y = 0.3;
    l.fresnel.type = brdf::FresnelType::kNone;
    m.lobes = {l};
    auto alphas = [](const brdf::ModelD& model) {
        auto e = export_mitsuba(model, "x");
        EXPECT_TRUE(e) << e.error().message;
        std::string err;
        auto root = XmlReader(e->text).parse(&err);
        EXPECT_NE(root, nullptr) << err;
        const XmlNode& b = *root->children[0];
        return std::make_pair(std::stod(param(b, "alpha_u")->attrs.at("value")),
                              std::stod(param(b, "alpha_v")->attrs.at("value")));
    };
    for (double deg : {0.0, 180.0, -180.0}) {
        m.lobes[0].orientation_deg = deg;
        EXPECT_EQ(alphas(m), std::make_pair(0.08, 0.3)) << deg;
    }
    for (double deg : {90.0, 270.0, -90.0}) {
        m.lobes[0].orientation_deg = deg;
        EXPECT_EQ(alphas(m), std::make_pair(0.3, 0.08)) << deg;
        auto p = export_pbrt(m, "x");
        ASSERT_TRUE(p) << p.error().message;
        EXPECT_NE(p->text.find("\"float uroughness\" [ 0.3 ]"), std::string::npos) << p->text;
    }
    m.lobes[0].orientation_deg = 30;
    auto a = export_mitsuba(m, "x");
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("lobes[0].orientation_deg = 30: Mitsuba 3"), std::string::npos)
        << a.error().message;
    auto b = export_pbrt(m, "x");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("lobes[0].orientation_deg = 30: pbrt-v4"), std::string::npos)
        << b.error().message;
    // Equal slopes do not depend on the turn.
    m.lobes[0].alpha_y = 0.08;
    EXPECT_TRUE(export_mitsuba(m, "x"));
}

// ---- pbrt-v4 scene syntax: a tokenizer and a reader of MakeNamedMaterial statements. ----

struct Token {
    enum Kind { kIdent, kString, kNumber, kOpen, kClose, kBool } kind;
    std::string text;
};

/// Tokenizes pbrt scene text; returns false with a message on a character pbrt would reject.
bool tokenize(const std::string& s, std::vector<Token>& out, std::string* error) {
    std::size_t i = 0;
    while (i < s.size()) {
        const char c = s[i];
        if (std::isspace(static_cast<unsigned char>(c))) {
            ++i;
        } else if (c == '#') {
            while (i < s.size() && s[i] != '\n') {
                ++i;
            }
        } else if (c == '"') {
            const auto end = s.find('"', i + 1);
            if (end == std::string::npos || s.substr(i, end - i).find('\n') != std::string::npos) {
                *error = "unterminated string at offset " + std::to_string(i);
                return false;
            }
            out.push_back({Token::kString, s.substr(i + 1, end - i - 1)});
            i = end + 1;
        } else if (c == '[' || c == ']') {
            out.push_back({c == '[' ? Token::kOpen : Token::kClose, std::string(1, c)});
            ++i;
        } else if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' ||
                   c == '.') {
            std::size_t used = 0;
            try {
                std::stod(s.substr(i), &used);
            } catch (...) {
                *error = "bad number at offset " + std::to_string(i);
                return false;
            }
            out.push_back({Token::kNumber, s.substr(i, used)});
            i += used;
        } else if (std::isalpha(static_cast<unsigned char>(c))) {
            std::size_t b = i;
            while (i < s.size() && std::isalnum(static_cast<unsigned char>(s[i]))) {
                ++i;
            }
            const std::string w = s.substr(b, i - b);
            out.push_back({w == "true" || w == "false" ? Token::kBool : Token::kIdent, w});
        } else {
            *error = std::string("unexpected character '") + c + "' at offset " + std::to_string(i);
            return false;
        }
    }
    return true;
}

struct PbrtParam {
    std::string type;
    std::vector<std::string> values;
    double num(std::size_t i = 0) const { return std::stod(values.at(i)); }
};
using PbrtMaterial = std::map<std::string, PbrtParam>;

/// Reads MakeNamedMaterial "name" ("type name" [ values ])* statements.
bool read_materials(const std::vector<Token>& t,
                    std::map<std::string, PbrtMaterial>& out,
                    std::vector<std::string>& order,
                    std::string* error) {
    std::size_t i = 0;
    while (i < t.size()) {
        if (t[i].kind != Token::kIdent || t[i].text != "MakeNamedMaterial") {
            *error = "expected MakeNamedMaterial, got " + t[i].text;
            return false;
        }
        if (i + 1 >= t.size() || t[i + 1].kind != Token::kString) {
            *error = "MakeNamedMaterial without a name";
            return false;
        }
        const std::string name = t[i + 1].text;
        if (out.count(name)) {
            *error = "material defined twice: " + name;
            return false;
        }
        PbrtMaterial m;
        i += 2;
        while (i < t.size() && t[i].kind == Token::kString) {
            const std::string decl = t[i].text;
            const auto sp = decl.find(' ');
            if (sp == std::string::npos) {
                *error = "parameter declaration without a type: " + decl;
                return false;
            }
            PbrtParam p{decl.substr(0, sp), {}};
            const std::string pname = decl.substr(sp + 1);
            ++i;
            if (i < t.size() && t[i].kind == Token::kOpen) {
                ++i;
                while (i < t.size() && t[i].kind != Token::kClose) {
                    p.values.push_back(t[i].text);
                    ++i;
                }
                if (i >= t.size()) {
                    *error = "unclosed [";
                    return false;
                }
                ++i;
            } else if (i < t.size()) {
                p.values.push_back(t[i].text);
                ++i;
            }
            const bool typed_ok =
                (p.type == "string" || p.type == "float" || p.type == "rgb" || p.type == "bool");
            if (!typed_ok || p.values.empty() || (p.type == "rgb" && p.values.size() != 3)) {
                *error = "bad parameter " + decl;
                return false;
            }
            m[pname] = p;
        }
        if (!m.count("type")) {
            *error = name + ": no \"string type\"";
            return false;
        }
        // Every referenced material must be defined earlier.
        if (m["type"].values[0] == "mix") {
            for (const std::string& ref : m["materials"].values) {
                if (!out.count(ref)) {
                    *error = name + " references " + ref + " before its definition";
                    return false;
                }
            }
        }
        out[name] = m;
        order.push_back(name);
    }
    return true;
}

void collect_pbrt(const std::map<std::string, PbrtMaterial>& all,
                  const std::string& name,
                  double w,
                  std::vector<std::pair<const PbrtMaterial*, double>>& out) {
    const PbrtMaterial& m = all.at(name);
    if (m.at("type").values[0] == "mix") {
        const double amount = m.at("amount").num();
        collect_pbrt(all, m.at("materials").values.at(0), w * (1 - amount), out);
        collect_pbrt(all, m.at("materials").values.at(1), w * amount, out);
        return;
    }
    out.push_back({&m, w});
}

std::vector<std::pair<const PbrtMaterial*, double>> parse_pbrt(
    const std::string& text, const std::string& top, std::map<std::string, PbrtMaterial>& all) {
    std::vector<Token> tokens;
    std::string err;
    EXPECT_TRUE(tokenize(text, tokens, &err)) << err;
    std::vector<std::string> order;
    EXPECT_TRUE(read_materials(tokens, all, order, &err)) << err << "\n" << text;
    EXPECT_FALSE(order.empty());
    if (order.empty()) {
        return {};
    }
    EXPECT_EQ(order.back(), top);
    std::vector<std::pair<const PbrtMaterial*, double>> leaves;
    collect_pbrt(all, top, 1.0, leaves);
    return leaves;
}

TEST(PbrtTokenizer, RejectsWhatPbrtRejects) {
    std::vector<Token> t;
    std::string err;
    EXPECT_FALSE(tokenize("MakeNamedMaterial \"a\n\"", t, &err));
    EXPECT_FALSE(tokenize("MakeNamedMaterial {a}", t, &err));
    std::map<std::string, PbrtMaterial> all;
    std::vector<std::string> order;
    t.clear();
    ASSERT_TRUE(
        tokenize("MakeNamedMaterial \"m\" \"string type\" [ \"mix\" ] \"string materials\" "
                 "[ \"a\" \"b\" ]",
                 t,
                 &err));
    EXPECT_FALSE(read_materials(t, all, order, &err));
    EXPECT_NE(err.find("before its definition"), std::string::npos);
}

double f0_of_k(double k) {
    return k * k / (4 + k * k);  // eta = 1
}

TEST(PbrtExport, GreyLobesRoundTripThroughMixWeights) {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd(0.2, 0.1, 0.05);
    auto a = testing::lobe(brdf::Distribution::kGgx, 0.15);
    a.fresnel.f0 = brdf::Rgbd(0.04, 0.05, 0.06);
    a.scale = brdf::Rgbd::Constant(0.3);
    auto b = testing::lobe(brdf::Distribution::kGgx, 0.05);
    b.anisotropic = true;
    b.alpha_y = 0.2;
    b.fresnel.type = brdf::FresnelType::kConductor;
    b.fresnel.eta_rgb = brdf::Rgbd(0.2, 0.9, 1.1);
    b.fresnel.k = brdf::Rgbd(3.9, 2.4, 2.2);
    b.scale = brdf::Rgbd::Constant(0.25);
    m.lobes = {a, b};
    auto ex = export_pbrt(m, "fit");
    ASSERT_TRUE(ex) << ex.error().message;
    std::map<std::string, PbrtMaterial> all;
    const auto leaves = parse_pbrt(ex->text, "fit", all);
    ASSERT_EQ(leaves.size(), 3u);
    double total = 0;
    for (const auto& l : leaves) {
        total += l.second;
    }
    EXPECT_NEAR(total, 1.0, 1e-12);
    // Diffuse: weight * reflectance = rho, reflectance <= 1.
    const PbrtMaterial& d = *leaves[0].first;
    EXPECT_EQ(d.at("type").values[0], "diffuse");
    for (int c = 0; c < 3; ++c) {
        EXPECT_LE(d.at("reflectance").num(c), 1.0);
        EXPECT_NEAR(leaves[0].second * d.at("reflectance").num(c), m.diffuse[c], 1e-9);
    }
    // Schlick GGX lobe: weight = scale, roughness = alpha (no remapping), k gives f0 with eta 1.
    const PbrtMaterial& ga = *leaves[1].first;
    EXPECT_EQ(ga.at("type").values[0], "conductor");
    EXPECT_NEAR(leaves[1].second, 0.3, 1e-9);
    EXPECT_NEAR(ga.at("roughness").num(), 0.15, 1e-12);
    EXPECT_EQ(ga.at("remaproughness").values[0], "false");
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(ga.at("eta").num(c), 1.0, 1e-12);
        EXPECT_NEAR(f0_of_k(ga.at("k").num(c)), a.fresnel.f0[c], 1e-9);
    }
    // Conductor lobe: exact eta, k, anisotropic roughness.
    const PbrtMaterial& gb = *leaves[2].first;
    EXPECT_NEAR(leaves[2].second, 0.25, 1e-9);
    EXPECT_NEAR(gb.at("uroughness").num(), 0.05, 1e-12);
    EXPECT_NEAR(gb.at("vroughness").num(), 0.2, 1e-12);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(gb.at("eta").num(c), b.fresnel.eta_rgb[c], 1e-9);
        EXPECT_NEAR(gb.at("k").num(c), b.fresnel.k[c], 1e-9);
    }
    EXPECT_NE(ex->text.find("Schlick"), std::string::npos);
    EXPECT_EQ(ex->text.find("divided by"), std::string::npos);
}

TEST(PbrtExport, ColouredScaleFoldedIntoNormalReflectanceAndOverfullWeightsScaled) {
    // Ngan et al. style Cook-Torrance: coloured scale, Beckmann, V-groove; diffuse + scale > 1.
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = brdf::Rgbd(0.9, 0.5, 0.3);
    auto l = testing::lobe(brdf::Distribution::kBeckmann, 0.1);
    l.shadowing = brdf::Shadowing::kVGroove;
    l.fresnel.f0 = brdf::Rgbd::Constant(0.1);
    l.scale = brdf::Rgbd(0.6, 0.3, 0.15);
    m.lobes = {l};
    auto ex = export_pbrt(m, "ct");
    ASSERT_TRUE(ex) << ex.error().message;
    std::map<std::string, PbrtMaterial> all;
    const auto leaves = parse_pbrt(ex->text, "ct", all);
    ASSERT_EQ(leaves.size(), 2u);
    const double T = 0.6 + 0.9;  // max scale + max diffuse
    // The material is the model / T: diffuse weight * reflectance = rho / T.
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(
            leaves[0].second * leaves[0].first->at("reflectance").num(c), m.diffuse[c] / T, 1e-9);
    }
    // Lobe weight max(scale) / T, and normal reflectance = (scale_c / max scale) * f0.
    EXPECT_NEAR(leaves[1].second, 0.6 / T, 1e-9);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(leaves[1].second * T * f0_of_k(leaves[1].first->at("k").num(c)),
                    l.scale[c] * 0.1,
                    1e-9);
    }
    for (const char* said : {"divided by 1.5", "Beckmann", "v-groove", "colour of scale"}) {
        EXPECT_NE(ex->text.find(said), std::string::npos) << said << "\n" << ex->text;
    }
}

TEST(RendererExport, SchlickMappingsReproduceF0) {
    for (double f0 : {0.0, 0.02, 0.04, 0.5, 0.9}) {
        EXPECT_NEAR(f0_of_eta(eta_from_f0(f0)), f0, 1e-12);
        EXPECT_NEAR(f0_of_k(k_from_f0(f0)), f0, 1e-12);
    }
    EXPECT_NEAR(f0_of_k(k_from_f0(1.0)), 1.0, 1e-7);
}

}  // namespace
}  // namespace gonio::report
