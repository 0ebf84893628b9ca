// The tabulated NDF (tabulated_ndf.h): normalisation and Smith Lambda against the closed forms of
// GGX and Beckmann tabulated at the nodes, the model JSON round trip, non-negativity and
// reciprocity of a model with a tabulated lobe, and its sampling density against its draws.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/sampling.h"
#include "gonio/brdf/tabulated_ndf.h"

namespace gonio::brdf {
namespace {

/// Node values of an analytic isotropic D (GGX or Beckmann) on an n-node table.
std::vector<double> nodes_of(Distribution dist, double alpha, std::size_t n) {
    std::vector<double> d(n);
    for (std::size_t k = 0; k < n; ++k) {
        const double th = tabulated_ndf_theta(k, n);
        const Vec3d h(std::sin(th), 0, std::cos(th));
        d[k] = dist == Distribution::kGgx ? D_ggx(h, alpha, alpha) : D_beckmann(h, alpha, alpha);
    }
    return d;
}

/// 2 pi int_0^{pi/2} D(theta) cos sin dtheta of the table by a fine midpoint rule in theta (not
/// the table's own quadrature in u).
double projected_area(const TabulatedNdf& t) {
    const int m = 200000;
    double sum = 0;
    for (int i = 0; i < m; ++i) {
        const double th = (i + 0.5) / m * kPi / 2;
        sum += tabulated_ndf_lookup(t.d, std::cos(th)) * std::cos(th) * std::sin(th);
    }
    return 2 * kPi * sum * (kPi / 2) / m;
}

TEST(TabulatedNdf, NormalisedOverProjectedAreaAndSigmaAtTheNormalIsOne) {
    for (Distribution dist : {Distribution::kGgx, Distribution::kBeckmann}) {
        for (double alpha : {0.08, 0.2, 0.5}) {
            SCOPED_TRACE(std::string(to_string(dist)) + " alpha " + std::to_string(alpha));
            // A table scaled by 7 comes back normalised.
            std::vector<double> d = nodes_of(dist, alpha, 64);
            for (double& x : d) {
                x *= 7;
            }
            Expected<TabulatedNdf> t = make_tabulated_ndf(d, "table");
            ASSERT_TRUE(t) << t.error().message;
            EXPECT_NEAR(projected_area(*t), 1.0, 2e-3);
            EXPECT_NEAR(t->sigma[0], 1.0, 1e-12);
            // The tabulated closed form is normalised to within the interpolation error: the
            // factor applied is 1 / 7 within 2 %.
            const double peak = nodes_of(dist, alpha, 64)[0];
            EXPECT_NEAR(t->d[0], peak, 0.02 * peak);
        }
    }
}

TEST(TabulatedNdf, SmithLambdaOfTheTableMatchesTheClosedForms) {
    // Heitz 2014: Lambda = sigma / cos - 1 for any normalised D; on GGX and Beckmann tables it
    // equals their closed-form Lambda within the table's interpolation error.
    for (Distribution dist : {Distribution::kGgx, Distribution::kBeckmann}) {
        for (double alpha : {0.1, 0.3, 0.6}) {
            SCOPED_TRACE(std::string(to_string(dist)) + " alpha " + std::to_string(alpha));
            Expected<TabulatedNdf> t = make_tabulated_ndf(nodes_of(dist, alpha, 64), "table");
            ASSERT_TRUE(t) << t.error().message;
            for (double deg : {0.0, 20.0, 45.0, 60.0, 75.0, 85.0}) {
                const double th = deg * kPi / 180;
                const Vec3d w(std::sin(th), 0, std::cos(th));
                const double expect = dist == Distribution::kGgx ? lambda_ggx(w, alpha, alpha)
                                                                 : lambda_beckmann(w, alpha, alpha);
                const double got = lambda_tabulated(*t, w.z());
                EXPECT_NEAR(got, expect, 0.01 * (1 + expect)) << deg << " deg";
            }
        }
    }
}

TEST(TabulatedNdf, RefusesTablesThatAreNoDistribution) {
    EXPECT_FALSE(make_tabulated_ndf({1.0}, "t"));
    EXPECT_FALSE(make_tabulated_ndf({0.0, 0.0, 0.0}, "t"));
    EXPECT_FALSE(make_tabulated_ndf({1.0, -0.1, 0.0}, "t"));
    EXPECT_FALSE(make_tabulated_ndf({1.0, std::nan(""), 0.0}, "t"));
    EXPECT_FALSE(make_tabulated_ndf(std::vector<double>(kTabulatedNdfMaxNodes + 1, 1.0), "t"));
    Expected<TabulatedNdf> bad = make_tabulated_ndf({1.0, -0.1, 0.0}, "lobes[0].ndf");
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("lobes[0].ndf[1]"), std::string::npos)
        << bad.error().message;
}

ModelD tabulated_model() {
    ModelD m;
    m.diffuse = Rgbd(0.3, 0.2, 0.1);
    Lobe<double> l;
    l.distribution = Distribution::kTabulated;
    l.table = std::make_shared<const TabulatedNdf>(
        *make_tabulated_ndf(nodes_of(Distribution::kGgx, 0.25, 32), "t"));
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd::Constant(0.05);
    l.scale = Rgbd(0.9, 0.8, 1.0);
    m.lobes.push_back(l);
    return m;
}

TEST(TabulatedNdf, ModelJsonRoundTripEvaluatesTheSame) {
    const ModelD m = tabulated_model();
    const std::string text = model_to_json(m);
    Expected<ModelD> back = parse_model_json(text, "model");
    ASSERT_TRUE(back) << back.error().message;
    ASSERT_EQ(back->lobes.size(), 1u);
    ASSERT_NE(back->lobes[0].table, nullptr);
    EXPECT_EQ(back->lobes[0].table->d.size(), 32u);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 200; ++i) {
        const Vec3d wi = spherical_to_cartesian(u(rng) * 1.5, u(rng) * 6.28);
        const Vec3d wo = spherical_to_cartesian(u(rng) * 1.5, u(rng) * 6.28);
        const Rgbd a = eval_model(m, wi, wo);
        const Rgbd b = eval_model(*back, wi, wo);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(a[c], b[c], 1e-9 * (1 + a[c]));
        }
    }
    // Keys that do not belong to a tabulated lobe are refused, naming them.
    Expected<ModelD> bad = parse_model_json(
        R"({"lobes": [{"distribution": "tabulated", "alpha": 0.1, "ndf": [1, 0.5],
            "shadowing": "smith-correlated", "fresnel": {"type": "none"}}]})",
        "m");
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("lobes[0].alpha"), std::string::npos) << bad.error().message;
    Expected<ModelD> missing = parse_model_json(
        R"({"lobes": [{"distribution": "tabulated",
            "shadowing": "smith-correlated", "fresnel": {"type": "none"}}]})",
        "m");
    ASSERT_FALSE(missing);
    EXPECT_NE(missing.error().message.find("ndf"), std::string::npos) << missing.error().message;
}

TEST(TabulatedNdf, ModelIsNonNegativeAndReciprocal) {
    const ModelD m = tabulated_model();
    const unsigned seed = 11;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 2000; ++i) {
        // Include the edges: normal incidence, grazing, mirror and retro-reflection.
        double ti = u(rng) * kPi / 2, to = u(rng) * kPi / 2;
        double pi = u(rng) * 2 * kPi, po = u(rng) * 2 * kPi;
        if (i % 10 == 0) {
            ti = 0;
        } else if (i % 10 == 1) {
            to = kPi / 2 - 1e-9;
        } else if (i % 10 == 2) {
            to = ti;
            po = pi + kPi;
        } else if (i % 10 == 3) {
            to = ti;
            po = pi;
        }
        const Vec3d wi = spherical_to_cartesian(ti, pi);
        const Vec3d wo = spherical_to_cartesian(to, po);
        const Rgbd a = eval_model(m, wi, wo);
        const Rgbd b = eval_model(m, wo, wi);
        for (int c = 0; c < 3; ++c) {
            ASSERT_TRUE(std::isfinite(a[c])) << "seed " << seed << " i " << i;
            EXPECT_GE(a[c], 0.0) << "seed " << seed << " i " << i;
            EXPECT_NEAR(a[c], b[c], 1e-12 * (1 + a[c])) << "seed " << seed << " i " << i;
        }
    }
}

TEST(TabulatedNdf, SampledNormalsFollowTheirDensity) {
    const TabulatedNdf t = *make_tabulated_ndf(nodes_of(Distribution::kBeckmann, 0.3, 32), "t");
    // The density integrates to 1 over the hemisphere (fine rule in theta).
    const int m = 100000;
    double total = 0;
    for (int i = 0; i < m; ++i) {
        const double th = (i + 0.5) / m * kPi / 2;
        total += pdf_tabulated_normal(t, std::cos(th)) * std::sin(th);
    }
    EXPECT_NEAR(2 * kPi * total * (kPi / 2) / m, 1.0, 1e-3);
    // Draws by theta band against the density's mass in the band (seeded; 200k draws).
    const unsigned seed = 5;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    const int bands = 9, draws = 200000;
    std::vector<int> count(bands, 0);
    for (int i = 0; i < draws; ++i) {
        const Vec3d h = sample_tabulated_normal(t, u(rng), u(rng));
        ASSERT_NEAR(h.norm(), 1.0, 1e-12);
        const double th = std::acos(std::min(1.0, h.z()));
        ++count[std::min(bands - 1, static_cast<int>(th / (kPi / 2) * bands))];
    }
    for (int b = 0; b < bands; ++b) {
        double mass = 0;
        const int sub = 2000;
        for (int i = 0; i < sub; ++i) {
            const double th = (b + (i + 0.5) / sub) * (kPi / 2) / bands;
            mass += pdf_tabulated_normal(t, std::cos(th)) * std::sin(th);
        }
        mass *= 2 * kPi * (kPi / 2) / bands / sub;
        const double expect = mass * draws;
        EXPECT_NEAR(count[b], expect, 5 * std::sqrt(expect) + 5)
            << "band " << b << " seed " << seed;
    }
}

}  // namespace
}  // namespace gonio::brdf
