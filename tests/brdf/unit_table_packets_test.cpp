// Table generation from a model: the packet path of tabulate() (an AnalyticBrdf, evaluated a
// packet of phi_d bins at a time through eval_model_packets, directions built from per-axis sines
// and cosines) against the scalar path (the same model behind a plain Brdf, eval_model bin by bin
// at TableGrid::centre_directions), on the full MERL grid.
//
// Tolerances, relative to the scalar bin value (the same as the packet formula tests,
// unit_packet_formulas_test.cpp): structures of arithmetic and sqrt only (GGX with any shadowing
// and Fresnel, Lambert) within kExactRelative = 4 * 2^-52 (1 ulp of the formula plus the rounding
// of the directions, built once from per-axis sines and cosines and once by rotations); structures
// through exp, erfc or log1p (Beckmann, Blinn-Phong, Student-t) within kTranscendentalRelative =
// 700 * 2^-52 (an argument error of 1 ulp amplified by |e| <= 700 in exp(-e)), or an absolute
// 1e-14 1/sr where Beckmann's Lambda cancels (G then differs absolutely, see that test).
// Validity, the report's counts and, for one and two threads, every stored bit must be equal.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"
#include "gonio/brdf/resample.h"

namespace gonio::brdf {
namespace {

constexpr double kEps = 2.220446049250313e-16;
constexpr double kExactRelative = 4 * kEps;
constexpr double kTranscendentalRelative = 700 * kEps;
constexpr double kAbsolute = 1e-14;

/// The model behind the Brdf interface only: tabulate() cannot see it is analytic and takes the
/// scalar path.
class ScalarModel : public Brdf {
  public:
    explicit ScalarModel(ModelD m) : m_(std::move(m)) {}
    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override { return eval_model(m_, wi, wo); }
    bool isotropic() const override { return true; }
    std::string describe() const override { return "scalar model"; }
    std::string statistics() const override { return {}; }

  private:
    ModelD m_;
};

Lobe<double> lobe(Distribution d, Shadowing s, FresnelType f, double alpha) {
    Lobe<double> l;
    l.distribution = d;
    l.shadowing = s;
    l.fresnel.type = f;
    l.fresnel.f0 = Rgbd(0.9, 0.7, 0.4);
    l.fresnel.eta_rgb = Rgbd(1.5, 1.6, 1.7);
    l.fresnel.k = Rgbd(3.1, 2.4, 1.9);
    l.alpha_x = alpha;
    l.alpha_y = alpha;
    l.exponent = 2 / (alpha * alpha) - 2;
    l.gamma = 3.5;
    l.scale = Rgbd(1.0, 0.8, 1.3);
    return l;
}

struct Case {
    std::string name;
    ModelD model;
    bool transcendental;
};

std::vector<Case> cases() {
    std::vector<Case> out;
    ModelD ggx;  // the fit's default structure
    ggx.diffuse = Rgbd(0.25, 0.2, 0.15);
    ggx.lobes.push_back(
        lobe(Distribution::kGgx, Shadowing::kSmithCorrelated, FresnelType::kSchlick, 0.25));
    out.push_back({"ggx/smith-correlated/schlick + lambert", ggx, false});
    ModelD narrow;  // a narrow peak: the largest values of the table
    narrow.lobes.push_back(
        lobe(Distribution::kGgx, Shadowing::kSmithSeparable, FresnelType::kConductor, 0.02));
    out.push_back({"ggx alpha 0.02/smith-separable/conductor", narrow, false});
    ModelD beckmann;  // Ngan et al.'s Cook-Torrance structure
    beckmann.diffuse = Rgbd(0.1, 0.05, 0.02);
    beckmann.lobes.push_back(
        lobe(Distribution::kBeckmann, Shadowing::kVGroove, FresnelType::kSchlick, 0.15));
    out.push_back({"beckmann/v-groove/schlick + lambert", beckmann, true});
    ModelD phong;
    phong.lobes.push_back(
        lobe(Distribution::kBlinnPhong, Shadowing::kNone, FresnelType::kDielectric, 0.3));
    out.push_back({"blinn-phong/none/dielectric", phong, true});
    ModelD mixed;  // two lobes, one through exp and erfc
    mixed.diffuse = Rgbd(0.05, 0.05, 0.05);
    mixed.lobes.push_back(
        lobe(Distribution::kGgx, Shadowing::kSmithCorrelated, FresnelType::kNone, 0.1));
    mixed.lobes.push_back(
        lobe(Distribution::kBeckmann, Shadowing::kSmithCorrelated, FresnelType::kNone, 0.5));
    out.push_back({"ggx + beckmann", mixed, true});
    ModelD student;  // lane by lane through the same body
    student.lobes.push_back(
        lobe(Distribution::kStudentT, Shadowing::kSmithCorrelated, FresnelType::kSchlick, 0.2));
    out.push_back({"student-t/smith-correlated/schlick", student, true});
    return out;
}

TEST(TablePackets, PacketTableEqualsScalarTableOnTheFullMerlGrid) {
    SCOPED_TRACE(packet_instruction_set());
    TabulateOptions o;  // the MERL grid and scale
    o.threads = 0;
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        TabulateReport rp, rs;
        const TabulatedBrdf packets = tabulate(AnalyticBrdf(c.model), o, &rp);
        const TabulatedBrdf scalar = tabulate(ScalarModel(c.model), o, &rs);
        EXPECT_EQ(rp.bins, rs.bins);
        EXPECT_EQ(rp.valid_bins, rs.valid_bins);
        EXPECT_EQ(rp.below_horizon, rs.below_horizon);
        EXPECT_EQ(rp.non_finite, 0u);
        EXPECT_EQ(rs.non_finite, 0u);
        EXPECT_EQ(rp.out_of_range, rs.out_of_range);
        EXPECT_GT(rp.valid_bins, 1000000u);
        const double rel_tol = c.transcendental ? kTranscendentalRelative : kExactRelative;
        double worst = 0;
        std::size_t compared = 0, failures = 0;
        const std::size_t n = packets.grid().size();
        for (std::size_t flat = 0; flat < n; ++flat) {
            ASSERT_EQ(packets.bin_valid(flat), scalar.bin_valid(flat)) << "bin " << flat;
            if (!packets.bin_valid(flat)) {
                continue;
            }
            const Rgbd p = packets.bin_value(flat);
            const Rgbd s = scalar.bin_value(flat);
            for (int ch = 0; ch < 3; ++ch) {
                const double diff = std::abs(p[ch] - s[ch]);
                const double rel = s[ch] > 0 ? diff / s[ch] : diff;
                const bool ok =
                    diff <= rel_tol * std::abs(s[ch]) || (c.transcendental && diff <= kAbsolute);
                worst = std::max(worst, rel);
                if (!ok && ++failures <= 3) {
                    ADD_FAILURE() << "bin " << flat << " channel " << ch << ": packets " << p[ch]
                                  << " scalar " << s[ch] << " (relative " << rel << ")";
                }
            }
            ++compared;
        }
        std::printf("%-45s %zu bins, worst relative difference %.3g (tolerance %.3g)\n",
                    c.name.c_str(),
                    compared,
                    worst,
                    rel_tol);
        EXPECT_EQ(failures, 0u);
    }
}

TEST(TablePackets, OneAndTwoThreadsStoreTheSameBits) {
    const Case c = cases()[2];
    TabulateOptions one;
    one.threads = 1;
    TabulateOptions two;
    two.threads = 2;
    TabulateReport r1, r2;
    const TabulatedBrdf a = tabulate(AnalyticBrdf(c.model), one, &r1);
    const TabulatedBrdf b = tabulate(AnalyticBrdf(c.model), two, &r2);
    EXPECT_EQ(r1.valid_bins, r2.valid_bins);
    EXPECT_EQ(r1.below_horizon, r2.below_horizon);
    ASSERT_EQ(a.raw().size(), b.raw().size());
    std::size_t differing = 0;
    for (std::size_t k = 0; k < a.raw().size(); ++k) {
        differing += a.raw()[k] != b.raw()[k] ? 1 : 0;
    }
    EXPECT_EQ(differing, 0u);
}

TEST(TablePackets, EmptyTableHasEveryBinInvalidAndFillsLikeAReadTable) {
    // empty() builds its storage without the reader's check: every bin invalid, raw -1, and a
    // bin set afterwards reads back as stored.
    const TableGrid g{9, 9, 18};
    TabulatedBrdf t = TabulatedBrdf::empty(g, {2.0, 1.0, 0.5}, "test");
    ASSERT_EQ(t.raw().size(), 3 * g.size());
    for (std::size_t flat = 0; flat < g.size(); ++flat) {
        ASSERT_FALSE(t.bin_valid(flat));
    }
    for (double v : t.raw()) {
        ASSERT_EQ(v, -1.0);
    }
    t.set_bin(17, Rgbd(0.5, 0.25, 4.0));
    EXPECT_TRUE(t.bin_valid(17));
    EXPECT_EQ(t.raw()[17], 0.25);
    EXPECT_EQ(t.raw()[g.size() + 17], 0.25);
    EXPECT_EQ(t.raw()[2 * g.size() + 17], 8.0);
    // The public constructor on the same raw values gives the same validity.
    const TabulatedBrdf copy(g, {2.0, 1.0, 0.5}, t.raw(), "copy");
    for (std::size_t flat = 0; flat < g.size(); ++flat) {
        ASSERT_EQ(copy.bin_valid(flat), t.bin_valid(flat));
    }
}

TEST(TablePackets, LineStoreKeepsWhatSetBinKeepsAndCountsTheRest) {
    // set_line against set_bin bin by bin, on an unaligned run of an odd length (the streaming
    // stores' head and tail), with every case: stored, no reflection, NaN, infinite, above the
    // limit, a negative rounding, and a value whose quotient overflows a tiny scale.
    const TableGrid g{3, 5, 7};
    const std::array<double, 3> scale{2.0, 1.0, 1e-300};
    const std::size_t first = 3;
    const std::size_t count = 27;
    std::vector<double> r(count), gr(count), b(count);
    std::vector<std::uint8_t> reflects(count, 1);
    for (std::size_t k = 0; k < count; ++k) {
        r[k] = 0.1 * static_cast<double>(k + 1);
        gr[k] = 0.05 * static_cast<double>(k);
        b[k] = 1e-290 * static_cast<double>(k % 4);
    }
    reflects[2] = 0;
    r[5] = std::numeric_limits<double>::quiet_NaN();
    gr[6] = std::numeric_limits<double>::infinity();
    b[7] = 2 * kMaxTableValue;
    r[8] = -1e-17;
    b[9] = 1e10;  // below kMaxTableValue, but 1e10 / 1e-300 overflows
    const double* const values[3] = {r.data(), gr.data(), b.data()};
    TabulatedBrdf line = TabulatedBrdf::unwritten(g, scale, "line");
    TabulatedBrdf bins = TabulatedBrdf::empty(g, scale, "bins");
    // The rest of the unwritten table, written around the run.
    for (std::size_t flat = 0; flat < g.size(); ++flat) {
        if (flat < first || flat >= first + count) {
            line.set_bin_invalid(flat);
        }
    }
    const LineStoreCounts c = line.set_line(first, count, values, reflects.data());
    EXPECT_EQ(c.no_reflection, 1u);
    EXPECT_EQ(c.non_finite, 2u);
    EXPECT_EQ(c.out_of_range, 2u);
    EXPECT_EQ(c.valid, count - 5);
    for (std::size_t k = 0; k < count; ++k) {
        const Rgbd f(r[k], gr[k], b[k]);
        const bool storable = reflects[k] != 0 && f.isFinite().all() && k != 7 && k != 9;
        if (storable) {
            bins.set_bin(first + k, f.max(0.0));
        }
        EXPECT_EQ(line.bin_valid(first + k), storable) << k;
    }
    for (std::size_t i = 0; i < line.raw().size(); ++i) {
        EXPECT_EQ(line.raw()[i], bins.raw()[i]) << i;
    }
    EXPECT_EQ(line.raw()[first + 8], 0.0);
    EXPECT_EQ(line.raw()[2 * g.size() + first + 9], -1.0);
}

}  // namespace
}  // namespace gonio::brdf
