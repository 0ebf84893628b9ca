// Properties over seeded random directions for every model combination (distribution x
// anisotropy x shadowing x Fresnel): reciprocity, non-negativity and finiteness, isotropy when
// claimed; and the library's property checks detect deliberate violations.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/checks.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {
namespace {

constexpr std::uint64_t kSeed = 424242;

Vec3d random_upper(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double cos_t = 1.0 - u(rng);  // (0, 1]
    const double phi = 2 * kPi * u(rng);
    const double sin_t = std::sqrt(1 - cos_t * cos_t);
    return Vec3d(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
}

std::vector<Lobe<double>> every_lobe() {
    std::vector<Lobe<double>> out;
    for (Distribution d : {Distribution::kGgx,
                           Distribution::kBeckmann,
                           Distribution::kBlinnPhong,
                           Distribution::kStudentT}) {
        for (bool aniso : {false, true}) {
            for (Shadowing s : {Shadowing::kSmithCorrelated,
                                Shadowing::kSmithSeparable,
                                Shadowing::kVGroove,
                                Shadowing::kNone}) {
                for (FresnelType f : {FresnelType::kSchlick,
                                      FresnelType::kDielectric,
                                      FresnelType::kConductor,
                                      FresnelType::kNone}) {
                    Lobe<double> l;
                    l.distribution = d;
                    l.anisotropic = aniso;
                    l.alpha_x = 0.15;
                    l.alpha_y = aniso ? 0.45 : 0.15;
                    l.exponent = 60;
                    l.gamma = 3.5;
                    l.shadowing = s;
                    l.fresnel.type = f;
                    l.fresnel.f0 = Rgbd(0.04, 0.5, 0.95);
                    l.fresnel.eta = 1.5;
                    l.fresnel.eta_rgb = Rgbd(0.2, 1.0, 1.2);
                    l.fresnel.k = Rgbd(3.6, 2.6, 2.3);
                    l.scale = Rgbd(1.0, 0.5, 2.0);
                    out.push_back(l);
                }
            }
        }
    }
    return out;
}

std::string name_of(const Lobe<double>& l) {
    return std::string(to_string(l.distribution)) + (l.anisotropic ? " aniso " : " iso ") +
           to_string(l.shadowing) + " " + to_string(l.fresnel.type);
}

TEST(ModelProperties, ReciprocityAndNonNegativityForEveryCombination) {
    const auto lobes = every_lobe();
    ASSERT_EQ(lobes.size(), 128u);
    std::mt19937_64 rng(kSeed);
    for (const Lobe<double>& l : lobes) {
        ModelD m;
        m.diffuse = Rgbd(0.1, 0.2, 0.3);
        m.lobes = {l};
        double worst_rel = 0;
        for (int i = 0; i < 3000; ++i) {
            const Vec3d wi = random_upper(rng);
            const Vec3d wo = (i % 3 == 0) ? reflect_z(wi) : random_upper(rng);
            const Rgbd a = eval_model(m, wi, wo);
            const Rgbd b = eval_model(m, wo, wi);
            for (int c = 0; c < 3; ++c) {
                ASSERT_TRUE(std::isfinite(a[c])) << name_of(l) << " seed " << kSeed;
                ASSERT_GE(a[c], 0.0) << name_of(l) << " seed " << kSeed;
                worst_rel = std::max(worst_rel, std::abs(a[c] - b[c]) / (std::abs(a[c]) + 1e-300));
            }
        }
        EXPECT_LT(worst_rel, 1e-10) << name_of(l) << " seed " << kSeed;
    }
}

TEST(ModelProperties, IsotropicLobesDependOnlyOnTheAzimuthDifference) {
    std::mt19937_64 rng(kSeed + 1);
    std::uniform_real_distribution<double> angle(-kPi, kPi);
    for (const Lobe<double>& l : every_lobe()) {
        ModelD m;
        m.has_diffuse = false;
        m.lobes = {l};
        double worst = 0;
        for (int i = 0; i < 500; ++i) {
            const Vec3d wi = random_upper(rng);
            const Vec3d wo = random_upper(rng);
            const double a = angle(rng);
            const Rgbd f = eval_model(m, wi, wo);
            const Rgbd g = eval_model(m, rotate_z(wi, a), rotate_z(wo, a));
            worst = std::max(worst, ((f - g).abs() / (f.abs() + 1e-300)).maxCoeff());
        }
        if (!l.anisotropic || l.distribution == Distribution::kBlinnPhong) {
            EXPECT_LT(worst, 1e-9) << name_of(l) << " seed " << kSeed + 1;
        } else {
            // The anisotropic lobes really depend on the orientation.
            EXPECT_GT(worst, 1e-2) << name_of(l) << " seed " << kSeed + 1;
        }
    }
}

TEST(Checks, PhysicalModelsPass) {
    ModelD m;
    m.diffuse = Rgbd(0.5, 0.4, 0.3);
    Lobe<double> l;
    l.alpha_x = l.alpha_y = 0.1;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd::Constant(0.04);
    m.lobes = {l};
    CheckOptions opts;
    opts.random_pairs = 3000;
    const auto results = run_checks(*make_analytic_brdf(m), opts);
    ASSERT_EQ(results.size(), 4u);
    EXPECT_TRUE(all_passed(results)) << format_check_table(results);
    EXPECT_EQ(results[0].name, "non-negativity");
    EXPECT_EQ(results[3].name, "energy");
}

TEST(Checks, DirectionalAlbedoOfLambertEqualsRho) {
    ModelD m;
    m.diffuse = Rgbd(0.25, 0.5, 1.0);
    const auto brdf = make_analytic_brdf(m);
    for (double t : {0.0, 0.5, 1.2, 1.55}) {
        const Rgbd a = directional_albedo(*brdf, spherical_to_cartesian(t, 0.7), 256, 128);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(a[c], m.diffuse[c], 2e-4 * m.diffuse[c]) << "theta_i " << t;
        }
    }
}

TEST(Checks, WhiteFurnaceOfAnUnshadowedLobeExceedsOne) {
    // Without shadowing-masking and with F = 1 the microfacet lobe's albedo is 1 + Lambda(wi) > 1
    // at grazing incidence (Heitz 2014, sec. 3): the energy check must flag it.
    ModelD m;
    m.has_diffuse = false;
    Lobe<double> l;
    l.alpha_x = l.alpha_y = 0.5;
    l.shadowing = Shadowing::kNone;
    l.fresnel.type = FresnelType::kNone;
    m.lobes = {l};
    const auto brdf = make_analytic_brdf(m);
    const CheckResult r = check_energy_conservation(*brdf);
    EXPECT_FALSE(r.passed) << r.where;
    EXPECT_GT(r.violation, 0.1);
    EXPECT_NE(r.where.find("theta_i 89"), std::string::npos) << r.where;
    // With height-correlated Smith and F = 1 the albedo at normal incidence of a smooth lobe is
    // close to 1 and never above it.
    m.lobes[0].shadowing = Shadowing::kSmithCorrelated;
    m.lobes[0].alpha_x = m.lobes[0].alpha_y = 0.05;
    const Rgbd a = directional_albedo(*make_analytic_brdf(m), Vec3d(0, 0, 1), 256, 128);
    EXPECT_GT(a[0], 0.99);
    EXPECT_LT(a[0], 1.0 + 1e-3);
}

/// A deliberately broken BRDF: not reciprocal, negative somewhere, not isotropic although it says
/// so. The checks must report each with its place.
class BrokenBrdf : public Brdf {
  public:
    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override {
        if (wi.z() <= 0 || wo.z() <= 0) {
            return Rgbd::Zero();
        }
        const double v = 0.1 + 0.05 * wi.x() - 0.02 * wo.z() + 0.3 * (wi.z() < 0.1 ? -1 : 0);
        return Rgbd::Constant(v);
    }
    bool isotropic() const override { return true; }
    std::string describe() const override { return "broken"; }
};

TEST(Checks, ViolationsAreReportedWithTheirPlace) {
    BrokenBrdf b;
    CheckOptions opts;
    opts.random_pairs = 2000;
    const auto results = run_checks(b, opts);
    EXPECT_FALSE(all_passed(results));
    EXPECT_FALSE(results[0].passed);
    EXPECT_GT(results[0].violation, 0.1);
    EXPECT_NE(results[0].where.find("wi (theta"), std::string::npos);
    EXPECT_FALSE(results[1].passed);
    EXPECT_FALSE(results[2].passed);
    const std::string table = format_check_table(results);
    EXPECT_NE(table.find("FAIL"), std::string::npos) << table;
}

}  // namespace
}  // namespace gonio::brdf
