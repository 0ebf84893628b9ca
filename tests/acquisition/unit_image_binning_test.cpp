// Half/difference binning: index mapping against the MERL formula, Welford statistics against a
// two-pass computation, dataset rows and table files read back, and the uncertainty the rows
// state with a rig's error budget.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "gonio/acquisition/image/bin_uncertainty.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/point/stated_uncertainty.h"
#include "gonio/brdf/merl.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;

TEST(ImageBinning, IndexFollowsMerlFormula) {
    const TableLayout l = TableLayout::merl();
    const double th = 0.3, td = 0.5, pd = 1.0;
    // Matusik et al. layout: sqrt spacing in theta_h, linear theta_d and phi_d over [0, pi).
    const int i_h = static_cast<int>(std::sqrt(th / (kPi / 2)) * 90);
    const int i_d = static_cast<int>(td / (kPi / 2) * 90);
    const int i_p = static_cast<int>(pd / kPi * 180);
    EXPECT_EQ(bin_index(l, th, td, pd), static_cast<std::size_t>((i_h * 90 + i_d) * 180 + i_p));
    // Reciprocity: phi_d and phi_d + pi are the same bin.
    EXPECT_EQ(bin_index(l, th, td, pd - kPi), bin_index(l, th, td, pd));
    // Clamping at the ends of the domain.
    EXPECT_EQ(bin_index(l, kPi / 2, kPi / 2, kPi - 1e-12), l.size() - 1);
    EXPECT_EQ(bin_index(l, 0, 0, 0), 0u);
}

TEST(ImageBinning, CentreOfEveryBinMapsBackToIt) {
    const TableLayout l = coarse_layout(3);
    for (std::size_t b = 0; b < l.size(); b += 37) {
        const brdf::HalfDiff<double> c = bin_centre(l, b);
        EXPECT_EQ(bin_index(l, c.theta_h, c.theta_d, c.phi_d), b);
    }
}

TEST(ImageBinning, ValidBinsHaveBothDirectionsAboveHorizon) {
    const TableLayout l = coarse_layout(3);
    std::size_t valid = 0;
    for (std::size_t b = 0; b < l.size(); ++b) {
        const auto [wi, wo] = brdf::from_half_diff(bin_centre(l, b));
        EXPECT_EQ(bin_valid(l, b), wi.z() > 0 && wo.z() > 0);
        valid += bin_valid(l, b) ? 1 : 0;
    }
    // theta_h = theta_d = 0 is the normal-incidence mirror pair: valid; not every bin is.
    EXPECT_TRUE(bin_valid(l, 0));
    EXPECT_GT(valid, l.size() / 3);
    EXPECT_LT(valid, l.size());
}

TEST(ImageBinning, WelfordMatchesTwoPassStatistics) {
    const std::uint64_t seed = 20261122;
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    BinnedTable t(coarse_layout(3));
    const brdf::Vec3d wi = brdf::spherical_to_cartesian(0.4, 0.0);
    const brdf::Vec3d wo = brdf::spherical_to_cartesian(0.5, 2.5);
    std::vector<brdf::Rgbd> values;
    for (int i = 0; i < 500; ++i) {
        // Large offset: a naive sum-of-squares would lose digits here, Welford does not.
        brdf::Rgbd v(1e6 + noise(rng), 2.0 + 0.1 * noise(rng), 0.5 * noise(rng));
        values.push_back(v);
        t.add(wi, wo, v, brdf::Rgbd::Constant(0.01));
    }
    const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
    const std::size_t b = bin_index(t.layout(), hd.theta_h, hd.theta_d, hd.phi_d);
    ASSERT_EQ(t.count(b), 500u);
    brdf::Rgbd mean = brdf::Rgbd::Zero();
    for (const auto& v : values) {
        mean += v;
    }
    mean /= values.size();
    brdf::Rgbd ss = brdf::Rgbd::Zero();
    for (const auto& v : values) {
        ss += (v - mean).square();
    }
    const brdf::Rgbd var = ss / (values.size() - 1.0);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(t.mean(b)[c], mean[c], 1e-9 * std::max(1.0, std::abs(mean[c])));
        EXPECT_NEAR(t.sample_variance(b)[c], var[c], 1e-9 * var[c]);
        // Model standard error: sqrt(0.01 / 500).
        EXPECT_NEAR(t.model_standard_error(b)[c], std::sqrt(0.01 / 500), 1e-6);
    }
    // The standard error is the larger of the empirical and the model one.
    EXPECT_NEAR(t.standard_error(b)[0], std::sqrt(var[0] / 500), 1e-9);
    EXPECT_NEAR(t.standard_error(b)[2], std::sqrt(var[2] / 500), 1e-9);
    EXPECT_EQ(t.filled_bins(), 1u);
    EXPECT_EQ(t.total_samples(), 500u);
}

TEST(ImageBinning, SingleSampleBinUsesModelError) {
    BinnedTable t(coarse_layout(3));
    t.add(brdf::spherical_to_cartesian(0.2, 0.0),
          brdf::spherical_to_cartesian(0.3, 3.0),
          brdf::Rgbd(1, 2, 3),
          brdf::Rgbd(0.04, 0.09, 0.16));
    std::size_t b = 0;
    while (t.count(b) == 0) {
        ++b;
    }
    EXPECT_DOUBLE_EQ(t.sample_variance(b)[0], 0.0);
    EXPECT_NEAR(t.standard_error(b)[0], 0.2, 1e-7);
    EXPECT_NEAR(t.standard_error(b)[2], 0.4, 1e-7);
}

TEST(ImageBinning, DatasetRowsFallInTheirBinAndSurviveCsv) {
    const TableLayout l = coarse_layout(3);
    BinnedTable t(l);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 2000; ++i) {
        const brdf::Vec3d wi = brdf::spherical_to_cartesian(1.3 * u(rng), 2 * kPi * u(rng));
        const brdf::Vec3d wo = brdf::spherical_to_cartesian(1.3 * u(rng), 2 * kPi * u(rng));
        t.add(wi, wo, brdf::Rgbd(wi.z(), wo.z(), 0.5), brdf::Rgbd::Constant(1e-4));
    }
    const brdf::Dataset d = t.to_dataset("test", 1, true);
    ASSERT_GT(d.samples.size(), 500u);
    const std::string path =
        (std::filesystem::temp_directory_path() / "gonio_image_binning_test.csv").string();
    ASSERT_TRUE(brdf::write_dataset_csv(path, d));
    auto back = brdf::read_dataset_csv(path);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_TRUE(back->rejected.empty());
    ASSERT_EQ(back->samples.size(), d.samples.size());
    std::size_t matched = 0;
    for (const brdf::Sample& s : back->samples) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(s.wi(), s.wo());
        const std::size_t b = bin_index(l, hd.theta_h, hd.theta_d, hd.phi_d);
        ASSERT_GT(t.count(b), 0u);
        if ((t.mean(b) - s.value).abs().maxCoeff() < 1e-12) {
            ++matched;
        }
        EXPECT_TRUE(s.flags & brdf::kFlagHdr);
    }
    // The mean position of a bin lies inside the bin (float storage of the position may move a
    // few across a bin boundary).
    EXPECT_GT(matched, d.samples.size() * 99 / 100);
    std::filesystem::remove(path);
}

TEST(ImageBinning, TableFileReadsBackWithInvalidBins) {
    const TableLayout l = coarse_layout(3);
    BinnedTable t(l);
    const brdf::Vec3d wi = brdf::spherical_to_cartesian(0.5, 0.0);
    const brdf::Vec3d wo = brdf::spherical_to_cartesian(0.6, 2.0);
    t.add(wi, wo, brdf::Rgbd(0.3, 0.2, 0.1), brdf::Rgbd::Zero());
    t.add(wi, wo, brdf::Rgbd(0.5, 0.4, 0.3), brdf::Rgbd::Zero());
    const std::string path =
        (std::filesystem::temp_directory_path() / "gonio_image_binning_test.gtab").string();
    ASSERT_TRUE(brdf::write_merl(path, to_tabulated(t, 1, "test")));
    auto back = brdf::read_table_file(path);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->grid().n_theta_h, 30);
    const brdf::TableLookup hit = back->lookup_nearest(brdf::to_half_diff(wi, wo).theta_h,
                                                       brdf::to_half_diff(wi, wo).theta_d,
                                                       brdf::to_half_diff(wi, wo).phi_d);
    ASSERT_TRUE(hit.valid);
    EXPECT_NEAR(hit.value[0], 0.4, 1e-12);
    EXPECT_NEAR(hit.value[2], 0.2, 1e-12);
    EXPECT_EQ(back->compute_statistics().valid_bins, 1u);
    std::filesystem::remove(path);
}

TEST(ImageBinning, CoverageCellsAreFractionsOfValidBins) {
    const TableLayout l = coarse_layout(6);  // 15 x 15 x 30
    BinnedTable t(l);
    // Fill every valid phi_d bin of one cell, and one bin of another.
    const int i_h = 2, i_d = 3;
    for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
        const std::size_t b = l.index(i_h, i_d, i_p);
        if (bin_valid(l, b)) {
            t.add_to_bin(b, bin_centre(l, b), brdf::Rgbd::Ones(), brdf::Rgbd::Zero());
        }
    }
    t.add_to_bin(
        l.index(5, 5, 0), bin_centre(l, l.index(5, 5, 0)), brdf::Rgbd::Ones(), brdf::Rgbd::Zero());
    const std::vector<double> cells = coverage_cells(t, 1);
    EXPECT_DOUBLE_EQ(cells[i_d * l.n_theta_h + i_h], 1.0);
    int valid55 = 0;
    for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
        valid55 += bin_valid(l, l.index(5, 5, i_p)) ? 1 : 0;
    }
    EXPECT_DOUBLE_EQ(cells[5 * l.n_theta_h + 5], 1.0 / valid55);
    EXPECT_DOUBLE_EQ(cells[0], 0.0);
    // theta_h and theta_d both near pi/2: no valid bin in the cell.
    EXPECT_DOUBLE_EQ(cells[(l.n_theta_d - 1) * l.n_theta_h + l.n_theta_h - 1], -1.0);
}

// The uncertainty an image campaign's dataset states per bin (bin_uncertainty.h): the bin's
// standard error and the rig's error budget through the point path's add_error_budget, the slope
// from the rows of the neighbouring bins of the table.

/// A table with one sample in each of three bins of a 30 x 30 x 60 layout: A, its neighbour B one
/// theta_d row up, and C far from both. Values (1/sr) and noise-model variances as given.
struct BudgetBins {
    TableLayout layout = coarse_layout(3);
    BinnedTable table{layout};
    std::size_t a = layout.index(6, 10, 20);
    std::size_t b = layout.index(6, 11, 20);
    std::size_t c = layout.index(20, 3, 45);

    BudgetBins() {
        add(a, brdf::Rgbd(2.0, 1.0, 0.5), 1e-4);
        add(b, brdf::Rgbd(2.6, 1.2, 0.5), 4e-4);
        add(c, brdf::Rgbd(0.1, 0.1, 0.1), 1e-6);
    }
    void add(std::size_t bin, const brdf::Rgbd& f, double var) {
        const std::array<int, 3> i = layout.unflatten(bin);
        brdf::HalfDiff<double> hd;
        hd.theta_h = layout.theta_h_centre(i[0]);
        hd.theta_d = layout.theta_d_centre(i[1]);
        hd.phi_d = layout.phi_d_centre(i[2]);
        table.add_to_bin(bin, hd, f, brdf::Rgbd::Constant(var));
    }
};

brdf::RigErrorBudget arms_only_budget() {
    brdf::RigErrorBudget b = brdf::quiet_error_budget();
    b.profile = "custom";
    b.light_arm.repeatability_deg = 0.02;
    b.detector_arm.zero_offset_deg = 0.03;
    return b;
}

TEST(ImageBinUncertainty, QuietBudgetStatesTheStandardErrors) {
    const BudgetBins t;
    const brdf::Dataset plain = t.table.to_dataset("t", 1, false);
    const brdf::Dataset stated =
        stated_dataset(t.table, "t", 1, false, brdf::quiet_error_budget(), 2.0);
    ASSERT_EQ(stated.samples.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        for (int ch = 0; ch < 3; ++ch) {
            EXPECT_EQ(stated.samples[i].sigma[ch], plain.samples[i].sigma[ch]) << i << " " << ch;
            EXPECT_EQ(stated.samples[i].value[ch], plain.samples[i].value[ch]) << i << " " << ch;
        }
    }
    // One sample per bin: the noise model's standard error, sqrt(variance).
    EXPECT_NEAR(stated.samples[0].sigma[0], 1e-2, 1e-9);
}

TEST(ImageBinUncertainty, ArmTermsReachABinThroughItsTableNeighbours) {
    const BudgetBins t;
    const brdf::RigErrorBudget budget = arms_only_budget();
    const brdf::Dataset stated = stated_dataset(t.table, "t", 1, false, budget, 0);
    const brdf::Dataset plain = t.table.to_dataset("t", 1, false);
    ASSERT_EQ(stated.samples.size(), 3u);  // rows in bin order: a, b, c
    const brdf::Sample& sa = stated.samples[0];
    const brdf::Sample& sb = stated.samples[1];
    const double d = configuration_distance(sa, sb, true);
    ASSERT_GT(d, 0.01);  // a theta_d row (3 degrees) apart
    const double u_dir = std::hypot(0.02, 0.03) * brdf::kPi / 180;
    ASSERT_NEAR(budget_direction_sigma(budget), u_dir, 1e-15);
    // One sample per bin: the standard error is the noise model's sqrt(variance).
    EXPECT_NEAR(plain.samples[0].sigma[0], 1e-2, 1e-9);
    EXPECT_NEAR(plain.samples[1].sigma[0], 2e-2, 1e-9);
    for (int ch = 0; ch < 3; ++ch) {
        // A and B see each other: their slope is the difference quotient between them.
        const double slope = std::abs(sb.value[ch] - sa.value[ch]) / d;
        EXPECT_NEAR(sa.sigma[ch], std::hypot(plain.samples[0].sigma[ch], slope * u_dir), 1e-15)
            << ch;
        EXPECT_NEAR(sb.sigma[ch], std::hypot(plain.samples[1].sigma[ch], slope * u_dir), 1e-15)
            << ch;
        // C has no filled neighbouring bin: no slope, its standard error alone (the point path's
        // nearest configurations would have given it one from A and B).
        EXPECT_NEAR(stated.samples[2].sigma[ch], plain.samples[2].sigma[ch], 1e-18) << ch;
    }
    // The arm term is seen: 0.6 / sr over 3 degrees of theta_d, 0.036 degrees of arm error.
    EXPECT_GT(sa.sigma[0], 1.1e-2);
}

TEST(ImageBinUncertainty, RelativeAndStrayLightTermsAsAPointValue) {
    const BudgetBins t;
    brdf::RigErrorBudget budget = brdf::reference_error_budget();
    budget.light_arm = budget.detector_arm = brdf::ArmErrors{};
    const double hours = 1.5;
    const brdf::Dataset stated = stated_dataset(t.table, "t", 1, false, budget, hours);
    const brdf::Dataset plain = t.table.to_dataset("t", 1, false);
    // The point path's body on the same rows with no slope gives the same sigmas.
    std::vector<brdf::Sample> point = plain.samples;
    add_error_budget(budget, hours, false, &point);
    const double u_rel = brdf::relative_sigma(budget, hours);
    // 0.15 % twice, 0.15 % of drift, 0.1 % of non-linearity.
    EXPECT_NEAR(u_rel, std::sqrt(2 * 0.0015 * 0.0015 + 0.0015 * 0.0015 + 0.001 * 0.001), 1e-15);
    for (std::size_t i = 0; i < 3; ++i) {
        const brdf::Sample& s = stated.samples[i];
        const double stray = 2e-4 / brdf::kPi / std::cos(s.theta_i);
        for (int ch = 0; ch < 3; ++ch) {
            const double se = plain.samples[i].sigma[ch];
            const double rel = s.value[ch] * u_rel;
            EXPECT_NEAR(s.sigma[ch], std::sqrt(se * se + rel * rel + stray * stray), 1e-15);
            EXPECT_DOUBLE_EQ(s.sigma[ch], point[i].sigma[ch]);
        }
    }
}

}  // namespace
}  // namespace gonio::acquisition
