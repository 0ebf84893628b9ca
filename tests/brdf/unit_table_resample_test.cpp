// Conversions: table -> dataset samples, scattered samples -> table (hand-countable kernel
// footprints), CSV -> table -> samples through load_samples and export_merl.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "gonio/brdf/merl.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {
namespace {

namespace fs = std::filesystem;

std::string temp_path(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() /
                         ("gonio_resample_test_" + std::to_string(static_cast<long>(::getpid())));
    fs::create_directories(dir);
    return (dir / name).string();
}

// A sample exactly at the centre of bin (ih, id, ip) of grid g with value v.
Sample sample_at_centre(const TableGrid& g, int ih, int id, int ip, const Rgbd& v) {
    const auto [wi, wo] = g.centre_directions(ih, id, ip);
    const Spherical<double> si = cartesian_to_spherical(wi);
    const Spherical<double> so = cartesian_to_spherical(wo);
    Sample s;
    s.theta_i = si.theta;
    s.phi_i = si.phi;
    s.theta_o = so.theta;
    s.phi_o = so.phi;
    s.value = v;
    return s;
}

std::size_t bins_above_horizon(const TableGrid& g) {
    std::size_t n = 0;
    for (std::size_t flat = 0; flat < g.size(); ++flat) {
        const std::array<int, 3> b = g.unflatten(flat);
        const auto [wi, wo] = g.centre_directions(b[0], b[1], b[2]);
        n += (wi.z() > 0 && wo.z() > 0) ? 1 : 0;
    }
    return n;
}

TEST(TableResample, OneSampleFillsItsBinOnly) {
    const TableGrid g{20, 20, 40};
    Dataset d;
    d.source = "one";
    d.samples.push_back(sample_at_centre(g, 5, 4, 10, Rgbd(0.5, 0.25, 0.125)));
    ResampleOptions o;
    o.grid = g;
    o.radius_bins = 0.9;  // neighbours are 1 bin away: outside
    ResampleReport rep;
    Expected<TabulatedBrdf> t = resample_dataset(d, o, &rep);
    ASSERT_TRUE(t) << t.error().message;
    EXPECT_EQ(rep.samples_used, 1u);
    EXPECT_EQ(rep.filled_bins, 1u);
    EXPECT_EQ(rep.bins, g.size());
    EXPECT_EQ(rep.filled_bins + rep.empty_bins, bins_above_horizon(g));
    EXPECT_EQ(rep.empty_bins + rep.filled_bins + rep.below_horizon, g.size());
    ASSERT_TRUE(t->bin_valid(g.index(5, 4, 10)));
    EXPECT_NEAR(t->bin_value(g.index(5, 4, 10))[0], 0.5, 1e-15);
    EXPECT_NEAR(t->bin_value(g.index(5, 4, 10))[2], 0.125, 1e-15);
    EXPECT_FALSE(t->bin_valid(g.index(5, 4, 11)));
}

TEST(TableResample, KernelFootprintCountsNeighbours) {
    const TableGrid g{20, 20, 40};
    Dataset d;
    d.source = "one";
    // Radius 1.5 around an interior centre: offsets with |o|^2 < 2.25 are the centre, 6 face
    // neighbours (|o|^2 = 1) and 12 edge neighbours (|o|^2 = 2): 19 bins.
    d.samples.push_back(sample_at_centre(g, 5, 4, 10, Rgbd(1, 1, 1)));
    ResampleOptions o;
    o.grid = g;
    o.radius_bins = 1.5;
    ResampleReport rep;
    ASSERT_TRUE(resample_dataset(d, o, &rep));
    EXPECT_EQ(rep.filled_bins, 19u);
    // Across phi_d = 0 = pi: a sample in the first phi_d bin fills the last one too.
    Dataset e;
    e.source = "edge";
    e.samples.push_back(sample_at_centre(g, 5, 4, 0, Rgbd(1, 1, 1)));
    Expected<TabulatedBrdf> t = resample_dataset(e, o, &rep);
    ASSERT_TRUE(t);
    EXPECT_EQ(rep.filled_bins, 19u);
    EXPECT_TRUE(t->bin_valid(g.index(5, 4, 39)));
    EXPECT_TRUE(t->bin_valid(g.index(5, 3, 39)));
    EXPECT_FALSE(t->bin_valid(g.index(5, 3, 38)));
}

TEST(TableResample, WeightedMeanOfTwoSamples) {
    const TableGrid g{20, 20, 40};
    Dataset d;
    d.source = "two";
    // Two samples at the centres of bins 10 and 11 along phi_d; radius 2: bin 10 sees the first at
    // distance 0 (weight 1) and the second at distance 1 (weight (1 - 1/4)^2 = 9/16).
    d.samples.push_back(sample_at_centre(g, 6, 6, 10, Rgbd(1, 1, 1)));
    d.samples.push_back(sample_at_centre(g, 6, 6, 11, Rgbd(3, 3, 3)));
    ResampleOptions o;
    o.grid = g;
    o.radius_bins = 2;
    Expected<TabulatedBrdf> t = resample_dataset(d, o);
    ASSERT_TRUE(t);
    const double expect = (1 * 1 + 3 * 9.0 / 16) / (1 + 9.0 / 16);
    EXPECT_NEAR(t->bin_value(g.index(6, 6, 10))[0], expect, 1e-12);
}

TEST(TableResample, RejectsBadOptions) {
    Dataset d;
    d.source = "empty.csv";
    Expected<TabulatedBrdf> t = resample_dataset(d);
    ASSERT_FALSE(t);
    EXPECT_NE(t.error().message.find("empty.csv: no valid samples"), std::string::npos);
    d.samples.push_back(sample_at_centre(TableGrid::merl(), 3, 3, 3, Rgbd(1, 1, 1)));
    ResampleOptions o;
    o.radius_bins = 0;
    Expected<TabulatedBrdf> u = resample_dataset(d, o);
    ASSERT_FALSE(u);
    EXPECT_NE(u.error().message.find("radius"), std::string::npos);
}

TEST(TableResample, TableToDatasetOneSamplePerValidBin) {
    const TableGrid g{6, 6, 12};
    TabulatedBrdf t = TabulatedBrdf::empty(g, kMerlScale, "t");
    std::size_t expected = 0;
    for (std::size_t flat = 0; flat < g.size(); flat += 3) {
        const std::array<int, 3> b = g.unflatten(flat);
        t.set_bin(flat, Rgbd(0.01 * b[0], 0.02 * b[1], 0.03 * b[2]));
        const auto [wi, wo] = g.centre_directions(b[0], b[1], b[2]);
        expected += (wi.z() > 0 && wo.z() > 0) ? 1 : 0;
    }
    const Dataset d = table_to_dataset(t);
    ASSERT_EQ(d.samples.size(), expected);
    for (const Sample& s : d.samples) {
        ASSERT_EQ(validate_sample(s), "");
        const HalfDiff<double> hd = to_half_diff(s.wi(), s.wo());
        const int ih = g.theta_h_index(hd.theta_h);
        const int id = g.theta_d_index(hd.theta_d);
        const int ip = g.phi_d_index(hd.phi_d);
        EXPECT_NEAR(s.value[0], 0.01 * ih, 1e-15);
        EXPECT_NEAR(s.value[1], 0.02 * id, 1e-15);
        EXPECT_NEAR(s.value[2], 0.03 * ip, 1e-15);
    }
}

// CSV of a dense seeded random measurement of a smooth function -> .gtab -> load_samples: values
// at filled bins close to the function at the centre.
TEST(TableResample, CsvToTableToSamples) {
    const unsigned seed = 3;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    auto truth = [](const Vec3d& wi, const Vec3d& wo) {
        // Smooth and reciprocal: depends on cos theta_i + cos theta_o and wi . wo.
        const double a = wi.z() + wo.z();
        const double b = wi.dot(wo);
        return Rgbd(0.1 + 0.05 * a, 0.2 + 0.02 * b, 0.05 + 0.01 * a * b);
    };
    Dataset d;
    d.source = "dense";
    for (int k = 0; k < 40000; ++k) {
        Sample s;
        s.theta_i = std::acos(u(rng) * 0.98 + 0.02);
        s.theta_o = std::acos(u(rng) * 0.98 + 0.02);
        s.phi_i = 2 * kPi * u(rng) - kPi;
        s.phi_o = 2 * kPi * u(rng) - kPi;
        s.value = truth(s.wi(), s.wo());
        d.samples.push_back(s);
    }
    const std::string csv = temp_path("dense.csv");
    ASSERT_TRUE(write_dataset_csv(csv, d));
    Expected<Dataset> back = load_samples(csv);
    ASSERT_TRUE(back) << back.error().message;
    ASSERT_EQ(back->samples.size(), d.samples.size());
    ResampleOptions o;
    o.grid = TableGrid{10, 10, 20};
    o.radius_bins = 1.0;
    const std::string gtab = temp_path("dense.gtab");
    Expected<ResampleReport> rep = export_merl(gtab, *back, o);
    ASSERT_TRUE(rep) << rep.error().message;
    EXPECT_GT(rep->filled_bins, rep->bins / 3) << "seed " << seed;
    Expected<Dataset> samples = load_samples(gtab);
    ASSERT_TRUE(samples) << samples.error().message;
    EXPECT_EQ(samples->samples.size(), rep->filled_bins);
    double worst = 0;
    for (const Sample& s : samples->samples) {
        worst = std::max(worst, ((s.value - truth(s.wi(), s.wo())).abs()).maxCoeff());
    }
    std::printf(
        "csv -> 10x10x20 table, radius 1 bin: %zu filled, %zu empty, worst abs error %.3g\n",
        rep->filled_bins,
        rep->empty_bins,
        worst);
    // The truth varies by at most ~0.05 1/sr across a bin and its kernel: the averages stay inside.
    EXPECT_LT(worst, 0.03) << "seed " << seed;
    fs::remove_all(fs::path(csv).parent_path());
}

}  // namespace
}  // namespace gonio::brdf
