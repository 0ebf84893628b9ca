// Model JSON: every rejection rule names the key path and the rule; round trips are exact; the
// shipped examples parse.

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "brdf_test_util.h"
#include "gonio/brdf/ior.h"
#include "gonio/brdf/model_json.h"

namespace gonio::brdf {
namespace {

using test_util::error_of;

const char* kLobeTail = R"("shadowing":"smith-correlated","fresnel":{"type":"none"})";

std::string lobe(const std::string& fields) {
    return std::string(R"({"lobes":[{)") + fields + "}]}";
}

TEST(ModelJson, ParsesTheDocumentedExample) {
    const auto m = parse_model_json(
        R"({"diffuse":[0.1,0.1,0.1],"lobes":[{"distribution":"ggx","alpha":0.2,"shadowing":"smith-correlated",
            "fresnel":{"type":"schlick","f0":[0.04,0.04,0.04]},"scale":[1,1,1]}]})",
        "x");
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_TRUE(m->has_diffuse);
    EXPECT_DOUBLE_EQ(m->diffuse[1], 0.1);
    ASSERT_EQ(m->lobes.size(), 1u);
    const Lobe<double>& l = m->lobes[0];
    EXPECT_EQ(l.distribution, Distribution::kGgx);
    EXPECT_FALSE(l.anisotropic);
    EXPECT_DOUBLE_EQ(l.alpha_x, 0.2);
    EXPECT_EQ(l.shadowing, Shadowing::kSmithCorrelated);
    EXPECT_EQ(l.fresnel.type, FresnelType::kSchlick);
    EXPECT_DOUBLE_EQ(l.fresnel.f0[2], 0.04);
}

TEST(ModelJson, ScalarsFillRgbAndDefaults) {
    const auto m = parse_model_json(
        R"({"diffuse":0.3,"lobes":[{"distribution":"beckmann","alpha_x":0.1,"alpha_y":0.4,
            "shadowing":"v-groove","fresnel":{"type":"schlick","f0":0.5}}]})",
        "x");
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_TRUE((m->diffuse == 0.3).all());
    EXPECT_TRUE(m->lobes[0].anisotropic);
    EXPECT_DOUBLE_EQ(m->lobes[0].alpha_y, 0.4);
    EXPECT_TRUE((m->lobes[0].scale == 1.0).all());
    EXPECT_TRUE((m->lobes[0].fresnel.f0 == 0.5).all());
    const auto no_diffuse = parse_model_json(R"({"lobes":[]})", "x");
    ASSERT_TRUE(no_diffuse);
    EXPECT_FALSE(no_diffuse->has_diffuse);
}

TEST(ModelJson, MaterialNamesComeFromTheIorTable) {
    const auto m = parse_model_json(
        lobe(
            R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"conductor","material":"gold"})"),
        "x");
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_TRUE((m->lobes[0].fresnel.eta_rgb == find_ior("gold")->eta).all());
    EXPECT_TRUE((m->lobes[0].fresnel.k == find_ior("gold")->k).all());
    const auto d = parse_model_json(
        lobe(
            R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"dielectric","material":"diamond"})"),
        "x");
    ASSERT_TRUE(d) << d.error().message;
    EXPECT_DOUBLE_EQ(d->lobes[0].fresnel.eta, 2.42);
}

TEST(ModelJson, RejectsEachRuleWithKeyPath) {
    const std::string tail = kLobeTail;
    struct Case {
        std::string text;
        std::string message;
    };
    const Case cases[] = {
        {lobe(R"("distribution":"ggx","alpha":-0.1,)" + tail),
         "model.json: lobes[0].alpha = -0.1: must be > 0"},
        {lobe(R"("distribution":"ggx","alpha":0,)" + tail),
         "model.json: lobes[0].alpha = 0: must be > 0"},
        {lobe(R"("distribution":"ggx","alpha_x":0.1,"alpha_y":-2,)" + tail),
         "model.json: lobes[0].alpha_y = -2: must be > 0"},
        {lobe(R"("distribution":"ggx","alpha":"rough",)" + tail),
         "model.json: lobes[0].alpha: expected a number, got string"},
        {lobe(R"("distribution":"ggx",)" + tail),
         "model.json: lobes[0]: missing key \"alpha\" (or \"alpha_x\" and \"alpha_y\")"},
        {lobe(R"("distribution":"ggx","alpha_x":0.1,)" + tail),
         "model.json: lobes[0]: missing key \"alpha_y\""},
        {lobe(R"("distribution":"ggx","alpha":0.1,"alpha_x":0.1,"alpha_y":0.1,)" + tail),
         "model.json: lobes[0]: give either \"alpha\" or \"alpha_x\" and \"alpha_y\", not both"},
        {lobe(R"("distribution":"ggx","alpha":0.1,"alhpa":0.1,)" + tail),
         "model.json: lobes[0].alhpa: unknown key (allowed here: distribution, alpha, alpha_x, "
         "alpha_y, orientation_deg, exponent, gamma, ndf, shadowing, fresnel, scale)"},
        {lobe(R"("distribution":"phong","alpha":0.1,)" + tail),
         "model.json: lobes[0].distribution = \"phong\": must be one of ggx, beckmann, "
         "blinn-phong, student-t, tabulated"},
        {lobe(R"("alpha":0.1,)" + tail), "model.json: lobes[0]: missing key \"distribution\""},
        {lobe(R"("distribution":"ggx","alpha":0.1,"fresnel":{"type":"none"})"),
         "model.json: lobes[0]: missing key \"shadowing\""},
        {lobe(R"("distribution":"ggx","alpha":0.1,"shadowing":"smith")"),
         "model.json: lobes[0].shadowing = \"smith\": must be one of smith-correlated, "
         "smith-separable, v-groove, none"},
        {lobe(R"("distribution":"ggx","alpha":0.1,"shadowing":"none")"),
         "model.json: lobes[0]: missing key \"fresnel\""},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"schlick","f0":1.5})"),
         "model.json: lobes[0].fresnel.f0 = 1.5: must be in [0, 1]"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"schlick","f0":[0.1,-0.1,0.1]})"),
         "model.json: lobes[0].fresnel.f0[1] = -0.1: must be in [0, 1]"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"schlick","f0":[0.1,0.1]})"),
         "model.json: lobes[0].fresnel.f0: expected a number or an array of 3 numbers, got an "
         "array of 2"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"dielectric","eta":0})"),
         "model.json: lobes[0].fresnel.eta = 0: must be > 0"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"dielectric"})"),
         "model.json: lobes[0].fresnel: give exactly one of \"eta\" and \"material\""},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"dielectric","material":"copper"})"),
         "model.json: lobes[0].fresnel.material = \"copper\": is a conductor, use \"type\": "
         "\"conductor\""},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"conductor","eta":[1,1,1],"k":[0,-1,0]})"),
         "model.json: lobes[0].fresnel.k[1] = -1: must be >= 0"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"conductor","eta":1})"),
         "model.json: lobes[0].fresnel: missing key \"k\""},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"conductor","material":"brass"})"),
         "model.json: lobes[0].fresnel.material = \"brass\": unknown material (known: " +
             ior_names() + ")"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"none","f0":0.1})"),
         "model.json: lobes[0].fresnel.f0: unknown key (allowed here: type)"},
        {lobe(R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"fancy"})"),
         "model.json: lobes[0].fresnel.type = \"fancy\": must be one of schlick, dielectric, "
         "conductor, none"},
        {lobe(
             R"("distribution":"ggx","alpha":0.1,"shadowing":"none","fresnel":{"type":"none"},"scale":-1)"),
         "model.json: lobes[0].scale = -1: must be >= 0"},
        {lobe(R"("distribution":"blinn-phong","alpha":0.1)"),
         "model.json: lobes[0].alpha: not used by blinn-phong lobes (they take \"exponent\")"},
        {lobe(R"("distribution":"blinn-phong")"), "model.json: lobes[0]: missing key \"exponent\""},
        {lobe(R"("distribution":"blinn-phong","exponent":-3)"),
         "model.json: lobes[0].exponent = -3: must be > 0"},
        {lobe(R"("distribution":"ggx","exponent":3,"alpha":0.1,)" + tail),
         "model.json: lobes[0].exponent: only for blinn-phong lobes (ggx uses alpha)"},
        {R"({"diffuse":[0.1,-0.2,0.1],"lobes":[]})", "model.json: diffuse[1] = -0.2: must be >= 0"},
        {R"({"diffuse":-0.5,"lobes":[]})", "model.json: diffuse = -0.5: must be >= 0"},
        {R"({"diffuse":"white","lobes":[]})",
         "model.json: diffuse: expected a number or an array of 3 numbers, got string"},
        {R"({"diffuse":0.5})", "model.json: top level: missing key \"lobes\""},
        {R"({"lobes":{}})", "model.json: lobes: expected an array, got object"},
        {R"({"lobes":[3]})", "model.json: lobes[0]: expected an object, got number"},
        {R"({"lobes":[],"name":"x"})",
         "model.json: name: unknown key (allowed here: diffuse, lobes, fit)"},
        {R"([1,2])", "model.json: top level: expected an object, got array"},
        {R"({"lobes":[)",
         "model.json: parse error at line 1, column 11: syntax error while parsing value - "
         "unexpected "
         "end of input; expected '[', '{', or a literal"},
        {lobe(R"("distribution":"ggx","alpha":1e400,)" + tail), ""},
    };
    for (const Case& c : cases) {
        const std::string got = error_of(c.text);
        if (c.message.empty()) {
            // Only the fact of the rejection is asserted (the parser's own wording of overflow).
            EXPECT_NE(got, "(parsed)") << c.text;
        } else {
            EXPECT_EQ(got, c.message) << c.text;
        }
    }
}

ModelD random_model(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    ModelD m;
    m.has_diffuse = u(rng) < 0.7;
    m.diffuse = m.has_diffuse ? Rgbd(u(rng), u(rng), u(rng)) : Rgbd::Zero();
    const int n = static_cast<int>(u(rng) * 3);
    for (int i = 0; i < n; ++i) {
        Lobe<double> l;
        l.distribution = static_cast<Distribution>(static_cast<int>(u(rng) * 3));
        l.anisotropic = u(rng) < 0.5;
        l.alpha_x = 1e-3 + u(rng);
        l.alpha_y = l.anisotropic ? 1e-3 + u(rng) : l.alpha_x;
        l.exponent = 1 + 1000 * u(rng);
        l.shadowing = static_cast<Shadowing>(static_cast<int>(u(rng) * 4));
        l.fresnel.type = static_cast<FresnelType>(static_cast<int>(u(rng) * 4));
        l.fresnel.f0 = Rgbd(u(rng), u(rng), u(rng));
        l.fresnel.eta = 1 + 3 * u(rng);
        l.fresnel.eta_rgb = Rgbd(0.1 + u(rng), 0.1 + u(rng), 0.1 + u(rng));
        l.fresnel.k = Rgbd(10 * u(rng), u(rng), 0);
        l.scale = Rgbd(u(rng), 1e-7 * u(rng), 3 * u(rng));
        m.lobes.push_back(l);
    }
    return m;
}

void expect_same_model(const ModelD& a, const ModelD& b) {
    ASSERT_EQ(a.has_diffuse, b.has_diffuse);
    if (a.has_diffuse) {
        EXPECT_TRUE((a.diffuse == b.diffuse).all());
    }
    ASSERT_EQ(a.lobes.size(), b.lobes.size());
    for (std::size_t i = 0; i < a.lobes.size(); ++i) {
        const Lobe<double>& x = a.lobes[i];
        const Lobe<double>& y = b.lobes[i];
        EXPECT_EQ(x.distribution, y.distribution);
        if (x.distribution == Distribution::kBlinnPhong) {
            EXPECT_EQ(x.exponent, y.exponent);
        } else {
            EXPECT_EQ(x.anisotropic, y.anisotropic);
            EXPECT_EQ(x.alpha_x, y.alpha_x);
            if (x.anisotropic) {
                EXPECT_EQ(x.alpha_y, y.alpha_y);
            }
        }
        EXPECT_EQ(x.shadowing, y.shadowing);
        EXPECT_EQ(x.fresnel.type, y.fresnel.type);
        switch (x.fresnel.type) {
            case FresnelType::kSchlick:
                EXPECT_TRUE((x.fresnel.f0 == y.fresnel.f0).all());
                break;
            case FresnelType::kDielectric:
                EXPECT_EQ(x.fresnel.eta, y.fresnel.eta);
                break;
            case FresnelType::kConductor:
                EXPECT_TRUE((x.fresnel.eta_rgb == y.fresnel.eta_rgb).all());
                EXPECT_TRUE((x.fresnel.k == y.fresnel.k).all());
                break;
            case FresnelType::kNone:
                break;
        }
        EXPECT_TRUE((x.scale == y.scale).all());
    }
}

TEST(ModelJson, RoundTripIsExact) {
    const std::uint64_t seed = 7;
    std::mt19937_64 rng(seed);
    for (int i = 0; i < 300; ++i) {
        const ModelD m = random_model(rng);
        const std::string text = model_to_json(m);
        const auto back = parse_model_json(text, "roundtrip");
        ASSERT_TRUE(back) << back.error().message << "\n" << text << " seed " << seed;
        SCOPED_TRACE(text);
        expect_same_model(m, *back);
        // And the text is a fixed point.
        EXPECT_EQ(model_to_json(*back), text);
    }
}

TEST(ModelJson, ShippedExamplesParse) {
    int n = 0;
    for (const auto& entry :
         std::filesystem::directory_iterator(std::string(GONIO_SOURCE_DIR) + "/data/models")) {
        if (entry.path().extension() != ".json") {
            continue;
        }
        const auto m = load_model_json(entry.path().string());
        EXPECT_TRUE(m) << (m ? "" : m.error().message);
        ++n;
    }
    EXPECT_GE(n, 5);
    const auto missing = load_model_json("no/such/model.json");
    ASSERT_FALSE(missing);
    EXPECT_EQ(missing.error().message,
              "no/such/model.json: cannot open: No such file or directory (model file)");
}

}  // namespace
}  // namespace gonio::brdf
