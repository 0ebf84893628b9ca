#include <gtest/gtest.h>

#include "gonio/brdf/brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {
namespace {

TEST(MaterialLibrary, HoldsThe86PublishedMaterials) {
    auto lib = default_material_library();
    ASSERT_TRUE(lib) << lib.error().message;
    auto names = material_names(*lib);
    ASSERT_TRUE(names) << names.error().message;
    EXPECT_EQ(names->size(), 86u);
}

TEST(MaterialLibrary, ConvertsThePublishedCookTorranceParameters) {
    // Published (Ngan et al. 2005): gold-metallic-paint3 = Lambertian(albedo = [0.0777, 0.056,
    // 0.0282]), NganCookTorrance(albedo = [0.142, 0.106, 0.0607], eta = 0.629, roughness = 0.144).
    auto m = load_material("gold-metallic-paint3");
    ASSERT_TRUE(m) << m.error().message;
    ASSERT_TRUE(m->has_diffuse);
    EXPECT_DOUBLE_EQ(m->diffuse[0], 0.0777);
    ASSERT_EQ(m->lobes.size(), 1u);
    const Lobe<double>& lobe = m->lobes[0];
    EXPECT_EQ(lobe.distribution, Distribution::kBeckmann);
    EXPECT_EQ(lobe.shadowing, Shadowing::kVGroove);
    EXPECT_EQ(lobe.fresnel.type, FresnelType::kSchlick);
    EXPECT_DOUBLE_EQ(lobe.alpha_x, 0.144);
    EXPECT_DOUBLE_EQ(lobe.fresnel.f0[1], 0.629);
    // Their lobe is albedo F D G / (pi cos_i cos_o); ours scale F D G / (4 cos_i cos_o).
    EXPECT_NEAR(lobe.scale[0], 0.142 * 4 / kPi, 1e-11);
    EXPECT_NEAR(lobe.scale[2], 0.0607 * 4 / kPi, 1e-11);
}

TEST(MaterialLibrary, UnknownNameSuggestsCloseOnes) {
    auto m = load_material("gold-metalic-paint3");
    ASSERT_FALSE(m);
    EXPECT_NE(m.error().message.find("gold-metallic-paint3"), std::string::npos)
        << m.error().message;
}

}  // namespace
}  // namespace gonio::brdf

namespace gonio::brdf {
namespace {

TEST(MaterialLibrary, LoadBrdfAcceptsMaterialNames) {
    auto b = load_brdf("material:gold-metallic-paint3");
    ASSERT_TRUE(b) << b.error().message;
    auto m = load_material("gold-metallic-paint3");
    ASSERT_TRUE(m);
    const Vec3d wi = spherical_to_cartesian(0.5, 0.0);
    const Vec3d wo = spherical_to_cartesian(0.5, kPi);
    const Rgbd direct = eval_model(*m, wi, wo);
    const Rgbd through = (*b)->eval(wi, wo);
    EXPECT_DOUBLE_EQ(direct[0], through[0]);
    EXPECT_GT(direct[0], m->diffuse[0] / kPi);  // the specular peak adds to the diffuse floor
    EXPECT_FALSE(load_brdf("material:no-such-material"));
}

}  // namespace
}  // namespace gonio::brdf
