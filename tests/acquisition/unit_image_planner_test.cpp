// Image-mode planning: each light position fills the theta_d slice of half the light-camera angle,
// the greedy plan only grows the coverage and respects the blind zone, holes carry their reasons.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "gonio/acquisition/image/image_planner.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;

struct PlannerSetup {
    CameraModel camera;
    SphereGeometry sphere;
};

PlannerSetup orthographic_setup(double detector) {
    CameraIntrinsics k;
    k.width = k.height = 100;
    k.cx = k.cy = 49.5;
    k.fx = k.fy = 2000;
    PlannerSetup s;
    s.camera = camera_on_detector_arm(k, Projection::kOrthographic, detector, 1.0);
    s.sphere.radius_m = 0.02;  // 40 px
    s.sphere.silhouette = {49.5, 49.5, 40};
    return s;
}

TEST(ImagePlanner, EachLightFillsItsThetaDSlice) {
    const PlannerSetup s = orthographic_setup(0.2);
    const TableLayout l = coarse_layout(3);
    LightRange r;
    r.min_rad = -kPi;
    r.max_rad = kPi;
    r.step_rad = 10 * kPi / 180;
    const auto cands = light_candidates(s.camera, s.sphere, {}, l, 0.2, r, 1);
    ASSERT_GT(cands.size(), 10u);
    for (const LightCandidate& c : cands) {
        // Distant light and telecentric camera: theta_d = angle(l, v) / 2 for every pixel.
        const double sep = brdf::arm_separation(c.light_arm_rad, 0.2);
        EXPECT_GE(sep, r.blind_zone_rad);
        const int expected_d = l.theta_d_index(sep / 2);
        for (std::uint32_t b : c.bins) {
            const int i_d = l.unflatten(b)[1];
            // Rounding at a cell boundary may put a pixel in the neighbour.
            EXPECT_LE(std::abs(i_d - expected_d), 1) << "light " << c.light_arm_rad;
            EXPECT_TRUE(bin_valid(l, b));
        }
    }
}

TEST(ImagePlanner, GreedyPlanGrowsCoverageAndStopsAtTarget) {
    const PlannerSetup s = orthographic_setup(0.0);
    const TableLayout l = coarse_layout(6);
    LightRange r;
    r.step_rad = 2 * kPi / 180;
    const auto cands = light_candidates(s.camera, s.sphere, {}, l, 0.0, r, 1);
    const CoveragePlan plan = plan_lights(cands, l, 0.5, 100, 0.0);
    ASSERT_FALSE(plan.light_arm_rad.empty());
    EXPECT_TRUE(plan.target_met);
    for (std::size_t i = 1; i < plan.predicted_coverage.size(); ++i) {
        EXPECT_GT(plan.predicted_coverage[i], plan.predicted_coverage[i - 1]);
    }
    EXPECT_GE(plan.predicted_coverage.back(), 0.5);
    // It stopped as soon as the target was met.
    if (plan.predicted_coverage.size() > 1) {
        EXPECT_LT(plan.predicted_coverage[plan.predicted_coverage.size() - 2], 0.5);
    }
    EXPECT_LE(plan.reachable_bins, plan.valid_bins);
    // An unreachable target ends when no candidate adds a bin, and says so.
    const CoveragePlan all = plan_lights(cands, l, 1.0, 1000, 0.0);
    EXPECT_FALSE(all.target_met);
    EXPECT_NEAR(all.predicted_coverage.back(),
                static_cast<double>(all.reachable_bins) / all.valid_bins,
                1e-12);
}

TEST(ImagePlanner, NextLightPrefersGainThenShortMove) {
    const TableLayout l = coarse_layout(6);
    CoverageMap map(l);
    std::vector<std::uint32_t> valid;
    for (std::size_t b = 0; b < l.size() && valid.size() < 6; ++b) {
        if (bin_valid(l, b)) {
            valid.push_back(static_cast<std::uint32_t>(b));
        }
    }
    std::vector<LightCandidate> c(3);
    c[0] = {1.0, {valid[0], valid[1]}};
    c[1] = {-1.0, {valid[2], valid[3]}};
    c[2] = {2.0, {valid[4]}};
    EXPECT_EQ(next_light(c, map, 0.9), 0);  // equal gain, shorter move
    EXPECT_EQ(next_light(c, map, -0.8), 1);
    map.cover(valid[0]);
    EXPECT_EQ(next_light(c, map, 0.9), 1);  // larger gain wins
    // Accepting half the best gain: the nearest candidate with gain >= 1 (of best 2).
    EXPECT_EQ(next_light(c, map, 0.9, 0.5), 0);
    EXPECT_EQ(next_light(c, map, 1.9, 0.5), 2);
    map.cover(valid[2]);
    map.cover(valid[3]);
    map.cover(valid[1]);
    map.cover(valid[4]);
    EXPECT_EQ(next_light(c, map, 0.0), -1);  // nothing left to gain
    EXPECT_EQ(map.covered_bins(), 5u);
}

TEST(ImagePlanner, HolesNameTheBlindZone) {
    const PlannerSetup s = orthographic_setup(0.0);
    const TableLayout l = coarse_layout(6);  // theta_d cells of 6 degrees
    LightRange r;
    r.step_rad = 2 * kPi / 180;
    r.blind_zone_rad = 14 * kPi / 180;  // theta_d < 7 degrees unreachable
    const auto cands = light_candidates(s.camera, s.sphere, {}, l, 0.0, r, 1);
    CoverageMap map(l);
    for (const auto& c : cands) {
        for (std::uint32_t b : c.bins) {
            map.cover(b);
        }
    }
    const auto holes = coverage_holes(map, cands, r.blind_zone_rad);
    bool blind_first_cell = false;
    for (const CoverageHole& h : holes) {
        EXPECT_NE(h.reason, "not measured");  // everything reachable was covered
        if (h.theta_d_min == 0.0 && h.reason == "blind zone") {
            blind_first_cell = true;
        }
    }
    EXPECT_TRUE(blind_first_cell);
}

TEST(ImagePlanner, HolesTellEveryReasonApart) {
    const PlannerSetup s = orthographic_setup(0.0);
    const TableLayout l = coarse_layout(6);  // theta_d rows of 6 degrees
    LightRange r;
    r.min_rad = -120 * kPi / 180;  // separations up to 120 degrees: theta_d <= 60
    r.max_rad = 120 * kPi / 180;
    r.step_rad = 2 * kPi / 180;
    r.blind_zone_rad = 14 * kPi / 180;
    ExclusionRules rules;
    rules.max_theta_i = rules.max_theta_o = 70 * kPi / 180;
    const auto cands = light_candidates(s.camera, s.sphere, rules, l, 0.0, r, 1);
    CoverageMap map(l);
    for (const auto& c : cands) {
        for (std::uint32_t b : c.bins) {
            map.cover(b);
        }
    }
    HoleLimits lim;
    lim.blind_zone_rad = r.blind_zone_rad;
    lim.max_separation_rad = 120 * kPi / 180;
    lim.max_theta_i = lim.max_theta_o = rules.max_theta_i;
    std::map<std::string, std::size_t> bins;
    std::size_t total = 0;
    for (const CoverageHole& h : coverage_holes(map, cands, lim)) {
        bins[h.reason] += h.bins;
        total += h.bins;
        if (h.reason == "blind zone") {
            EXPECT_LT(h.theta_d_min, 7 * kPi / 180);
        } else if (h.reason == "arm limits") {
            EXPECT_GE(h.theta_d_max, 60 * kPi / 180 - 1e-9);
        } else if (h.reason == "grazing (beyond max_theta)") {
            // Both directions of such a bin's centre beyond 70 degrees means theta_d or theta_h
            // is large.
            EXPECT_GT(h.theta_d_max + h.theta_h_max, 35 * kPi / 180);
        }
    }
    EXPECT_GT(bins["blind zone"], 0u);
    EXPECT_GT(bins["arm limits"], 0u);
    EXPECT_GT(bins["grazing (beyond max_theta)"], 0u);
    EXPECT_EQ(bins["not measured"], 0u);  // every candidate's bins were covered
    EXPECT_EQ(total, map.valid_bins() - map.covered_bins());
}

TEST(ImagePlanner, CachedGainsChooseAsTheFullScan) {
    const PlannerSetup s = orthographic_setup(0.0);
    const TableLayout l = coarse_layout(3);
    LightRange r;
    r.step_rad = 1 * kPi / 180;
    auto cands = light_candidates(s.camera, s.sphere, {}, l, 0.0, r, 2);
    ASSERT_GT(cands.size(), 100u);
    CoverageMap map(l);
    std::vector<std::size_t> gains = candidate_gains(cands, map);
    double current = 0.3;
    for (int frame = 0; frame < 40; ++frame) {
        const int a = next_light(cands, map, current, 0.5);
        const int b = next_light(cands, gains, current, 0.5);
        ASSERT_EQ(a, b) << "frame " << frame;
        ASSERT_GE(a, 0);
        const LightCandidate chosen = cands[a];
        cands.erase(cands.begin() + a);
        gains.erase(gains.begin() + a);
        // Cover only part of its bins, as a frame with lost pixels would.
        for (std::size_t k = 0; k < chosen.bins.size(); k += 2) {
            map.cover(chosen.bins[k]);
        }
        update_gains(cands, map, chosen.theta_d_lo, chosen.theta_d_hi, &gains);
        EXPECT_EQ(gains, candidate_gains(cands, map)) << "frame " << frame;
        current = chosen.light_arm_rad;
    }
}

TEST(ImagePlanner, CoveragePngHasOneBlockPerCell) {
    const TableLayout l = coarse_layout(6);
    std::vector<double> cells(l.n_theta_h * l.n_theta_d, 0.5);
    cells[0] = -1;
    const std::string path =
        (std::filesystem::temp_directory_path() / "gonio_image_planner_coverage.png").string();
    ASSERT_TRUE(write_coverage_png(path, cells, l, 3));
    const cv::Mat img = cv::imread(path);
    EXPECT_EQ(img.cols, 45);
    EXPECT_EQ(img.rows, 45);
    const cv::Vec3b grey = img.at<cv::Vec3b>(1, 1);
    EXPECT_EQ(grey, cv::Vec3b(128, 128, 128));
    EXPECT_FALSE(write_coverage_png(path, {1.0}, l, 3));
    std::filesystem::remove(path);
}

TEST(ImagePlanner, CoverageCellsOfTheMapMatchTheTable) {
    const TableLayout l = coarse_layout(6);  // 15 x 15 x 30
    BinnedTable t(l);
    CoverageMap m(l);
    // Every valid phi_d bin of one cell, one bin of another, and a bin filled twice.
    const int i_h = 4, i_d = 2;
    int valid_cell = 0;
    for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
        const std::size_t b = l.index(i_h, i_d, i_p);
        valid_cell += bin_valid(l, b) ? 1 : 0;
        if (bin_valid(l, b) && i_p % 3 == 0) {
            t.add_to_bin(b, bin_centre(l, b), brdf::Rgbd::Ones(), brdf::Rgbd::Zero());
        }
    }
    const std::size_t other = l.index(7, 6, 1);
    for (int k = 0; k < 2; ++k) {
        t.add_to_bin(other, bin_centre(l, other), brdf::Rgbd::Ones(), brdf::Rgbd::Zero());
    }
    m.cover_from(t, 1);
    const std::vector<double> from_map = coverage_cells(m);
    EXPECT_EQ(from_map, coverage_cells(t, 1));
    int filled = 0;
    for (int i_p = 0; i_p < l.n_phi_d; i_p += 3) {
        filled += bin_valid(l, l.index(i_h, i_d, i_p)) ? 1 : 0;
    }
    ASSERT_GT(valid_cell, 0);
    EXPECT_DOUBLE_EQ(from_map[i_d * l.n_theta_h + i_h], static_cast<double>(filled) / valid_cell);
    // Two samples count once as a covered bin; with min_count 2 only that bin is covered.
    CoverageMap twice(l);
    twice.cover_from(t, 2);
    EXPECT_EQ(twice.covered_bins(), 1u);
    const std::vector<double> cells2 = coverage_cells(twice);
    EXPECT_GT(cells2[6 * l.n_theta_h + 7], 0.0);
    EXPECT_DOUBLE_EQ(cells2[i_d * l.n_theta_h + i_h], 0.0);
    EXPECT_DOUBLE_EQ(cells2[(l.n_theta_d - 1) * l.n_theta_h + l.n_theta_h - 1], -1.0);
}

}  // namespace
}  // namespace gonio::acquisition
