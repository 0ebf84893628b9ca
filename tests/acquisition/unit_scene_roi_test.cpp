#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/test_units.h"
#include "gonio/acquisition/plans/plan.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {
namespace {

using gonio::test_units::kDeg;

Scene ranges_scene(double margin_deg) {
    Scene sc;
    sc.margin = margin_deg * kDeg;
    sc.has_ranges = true;
    sc.theta_i_min = 0;
    sc.theta_i_max = 30 * kDeg;
    sc.theta_r_min = 0;
    sc.theta_r_max = 45 * kDeg;
    return sc;
}

PlannedConfig config(double theta_i_deg, double theta_r_deg, double dphi_deg) {
    PlannedConfig c;
    c.wi = brdf::spherical_to_cartesian(theta_i_deg * kDeg, 0.0);
    c.wo = brdf::spherical_to_cartesian(theta_r_deg * kDeg, dphi_deg * kDeg);
    return c;
}

TEST(SceneRoi, KeepsOnlyWhatTheSceneNeedsAndCountsTheRest) {
    auto plan = plan_uniform(UniformGridSpec{10, 80 * kDeg, 7});
    ASSERT_TRUE(plan) << plan.error().message;
    const std::size_t before = plan->configs.size();
    const Scene sc = ranges_scene(5);
    std::size_t expected_inside = 0;
    for (const PlannedConfig& c : plan->configs) {
        const brdf::Canonical<double> k = canonical_of(c);
        // Independent membership rule: theta ranges widened by the margin, either way round.
        auto in = [&](double ti, double tr) {
            return ti <= (30 + 5) * kDeg + 1e-12 && tr <= (45 + 5) * kDeg + 1e-12;
        };
        expected_inside += (in(k.theta_i, k.theta_r) || in(k.theta_r, k.theta_i)) ? 1 : 0;
    }
    apply_roi(sc, &*plan);
    EXPECT_EQ(plan->configs.size(), expected_inside);
    EXPECT_EQ(plan->outside_roi, before - expected_inside);
    EXPECT_LT(plan->configs.size(), before);
    for (const PlannedConfig& c : plan->configs) {
        EXPECT_TRUE(c.flags & brdf::kFlagRoi);
        EXPECT_GT(c.weight, 0.0);
        EXPECT_LE(c.weight, 1.0);
    }
}

TEST(SceneRoi, WeightIsOneInsideAndFallsAcrossTheMargin) {
    const Scene sc = ranges_scene(10);
    EXPECT_DOUBLE_EQ(roi_weight(sc, config(20, 40, 180)), 1.0);
    // theta_r 5 deg beyond the range: half way across a 10 deg margin.
    EXPECT_NEAR(
        roi_weight(sc, config(20, 50, 180)), 1.0 - (1.0 - kRoiMarginEdgeWeight) * 0.5, 1e-9);
    // Beyond the margin: not measured at all.
    EXPECT_EQ(roi_weight(sc, config(20, 56, 180)), 0.0);
    EXPECT_FALSE(in_roi(sc, config(20, 56, 180)));
    // Reciprocity: the same pair the other way round has the same weight.
    EXPECT_DOUBLE_EQ(roi_weight(sc, config(50, 20, 180)), roi_weight(sc, config(20, 50, 180)));
}

TEST(SceneRoi, PairsWeightTheListedConfigurationFully) {
    Scene sc;
    sc.margin = 8 * kDeg;
    const PlannedConfig exact = config(30, 45, 180);
    sc.pairs.emplace_back(exact.wi, exact.wo);
    EXPECT_DOUBLE_EQ(roi_weight(sc, exact), 1.0);
    const double w = roi_weight(sc, config(30, 49, 180));
    EXPECT_GT(w, kRoiMarginEdgeWeight);
    EXPECT_LT(w, 1.0);
    EXPECT_EQ(roi_weight(sc, config(30, 70, 180)), 0.0);
}

TEST(SceneRoi, ReadsTheShippedScenes) {
    for (const char* name : {"overhead-ranges.json", "studio-product.json"}) {
        const std::string path = std::string(GONIO_SOURCE_DIR) + "/data/scenes/" + name;
        auto sc = read_scene(path);
        ASSERT_TRUE(sc) << sc.error().message;
        EXPECT_TRUE(sc->has_ranges || !sc->pairs.empty()) << path;
    }
    const auto bad = std::filesystem::temp_directory_path() / "gonio_scene_roi_bad.json";
    std::ofstream(bad) << R"({"name": "nothing"})";
    auto sc = read_scene(bad.string());
    ASSERT_FALSE(sc);
    EXPECT_NE(sc.error().message.find("pairs"), std::string::npos) << sc.error().message;
    std::filesystem::remove(bad);
}

}  // namespace
}  // namespace gonio::acquisition
