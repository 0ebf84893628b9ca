// The Blender export without Blender: the Principled BSDF's index of refraction against its closed
// form, the Specular chosen for Schlick against the one a dielectric would give, the script is
// valid Python (python3 compiles it) with one closure per term, and the refusals name the term.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/model_json.h"
#include "gonio/report/blender_export.h"

namespace gonio::report {
namespace {

namespace fs = std::filesystem;

brdf::ModelD model(const std::string& json) {
    auto m = brdf::parse_model_json(json, "test model");
    EXPECT_TRUE(m) << m.error().message;
    return m ? *m : brdf::ModelD{};
}

/// Largest relative difference over theta_d in [0, 75] deg between Schlick's F and the Principled
/// BSDF's f0 + (1 - f0) F_H of Specular s (written out here from the definitions).
double worst_difference(double f0, double s) {
    const double root = std::sqrt(0.08 * s);
    const double eta = (1 + root) / (1 - root);
    const double fd0 = brdf::fresnel_dielectric(1.0, eta);
    double worst = 0;
    for (int a = 0; a <= 75; ++a) {
        const double c = std::cos(a * brdf::kPi / 180);
        const double principled =
            f0 + (1 - f0) * (brdf::fresnel_dielectric(c, eta) - fd0) / (1 - fd0);
        const double schlick = f0 + (1 - f0) * std::pow(1 - c, 5);
        worst = std::max(worst, std::abs(principled - schlick) / schlick);
    }
    return worst;
}

TEST(BlenderExport, PrincipledIndexIsTheOneOfItsNormalReflectance) {
    // Specular 0.5 is f0 = 0.04, the reflectance of eta 1.5: ((1.5 - 1) / (1.5 + 1))^2.
    EXPECT_NEAR(principled_eta(0.5), 1.5, 1e-12);
    for (double s : {0.1, 0.3, 1.0}) {
        const double eta = principled_eta(s);
        EXPECT_NEAR(std::pow((eta - 1) / (eta + 1), 2), 0.08 * s, 1e-12) << s;
    }
}

TEST(BlenderExport, SpecularForSchlickBeatsTheDielectricOfTheSameF0) {
    for (double f0 : {0.02, 0.04, 0.06}) {
        const double s = principled_specular_for_schlick(f0);
        const double chosen = worst_difference(f0, s);
        const double dielectric = worst_difference(f0, f0 / 0.08);
        EXPECT_LT(chosen, 0.8 * dielectric) << f0;
        EXPECT_LT(chosen, 0.2) << f0;
    }
    EXPECT_NEAR(principled_specular_for_schlick(0.04), 0.21, 0.02);
}

TEST(BlenderExport, ScriptIsPythonWithOneClosurePerTerm) {
    const auto m = model(R"({"diffuse": 0.2, "lobes": [
        {"distribution": "ggx", "alpha": 0.1, "shadowing": "smith-separable",
         "fresnel": {"type": "none"}},
        {"distribution": "ggx", "alpha_x": 0.1, "alpha_y": 0.3, "orientation_deg": 20,
         "shadowing": "smith-correlated", "fresnel": {"type": "schlick", "f0": 0.04},
         "scale": [1.0, 0.99, 0.98]}]})");
    BlenderExportOptions o;
    o.name = "unit.material-1";
    auto e = export_blender(m, o);
    ASSERT_TRUE(e) << e.error().message;
    ASSERT_EQ(e->terms.size(), 3u);
    EXPECT_NE(e->terms[1].find(": exact"), std::string::npos) << e->terms[1];
    EXPECT_NE(e->terms[2].find("approximated (schlick)"), std::string::npos) << e->terms[2];
    std::size_t appends = 0;
    for (std::size_t p = 0; (p = e->text.find("terms.append(", p)) != std::string::npos; ++p) {
        ++appends;
    }
    EXPECT_EQ(appends, 3u);
    // The near-grey scale is written exactly: a Principled BSDF plus a Glossy BSDF of the rest.
    EXPECT_EQ(e->text.find("scale-colour-fresnel"), std::string::npos);
    EXPECT_NE(e->text.find("add(anisotropic("), std::string::npos) << e->text;
    const fs::path dir = fs::path(GONIO_BINARY_DIR) / "tests" / "blender_unit";
    fs::create_directories(dir);
    const fs::path py = dir / "material.py";
    std::ofstream(py) << e->text;
    const int st = std::system(("python3 -m py_compile " + py.string() + " 2>&1").c_str());
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << "python3 could not compile " << py;
}

TEST(BlenderExport, RefusalsNameTheTermAndAreUsageErrors) {
    const auto bp = model(R"({"lobes": [{"distribution": "blinn-phong", "exponent": 50,
        "shadowing": "smith-separable", "fresnel": {"type": "none"}}]})");
    auto e = export_blender(bp, {});
    ASSERT_FALSE(e);
    EXPECT_TRUE(e.error().refused);
    EXPECT_NE(e.error().message.find("lobes[0]: a Blinn-Phong lobe"), std::string::npos);
    BlenderExportOptions approximate;
    approximate.approximate = true;
    EXPECT_TRUE(export_blender(bp, approximate));
    BlenderExportOptions bad_name;
    bad_name.name = "a\"b";
    auto n = export_blender(bp, bad_name);
    ASSERT_FALSE(n);
    EXPECT_TRUE(n.error().refused);
    const auto needle = model(R"({"lobes": [{"distribution": "ggx", "alpha_x": 0.0001,
        "alpha_y": 2, "shadowing": "smith-separable", "fresnel": {"type": "none"}}]})");
    auto a = export_blender(needle, approximate);
    ASSERT_FALSE(a);
    EXPECT_TRUE(a.error().refused);
    EXPECT_NE(a.error().message.find("lobes[0]: an anisotropic lobe with alpha ratio above 10^4"),
              std::string::npos)
        << a.error().message;
    auto invalid = bp;
    invalid.lobes[0].scale[1] = -1;
    auto v = export_blender(invalid, approximate);
    ASSERT_FALSE(v);
    EXPECT_FALSE(v.error().refused);
    EXPECT_NE(v.error().message.find("lobes[0].scale"), std::string::npos);
}

}  // namespace
}  // namespace gonio::report
