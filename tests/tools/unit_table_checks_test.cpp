// Checks that suit tables and measurements: a table made from a model passes for every seed (its
// own resolution is the tolerance, not 1e-6); a noisy measured table passes within its stated
// noise; a noisy measured dataset passes within its sigma and fails on a planted reciprocity error,
// with the worst pair named.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/checks.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/resample.h"

namespace gonio::brdf {
namespace {

using gonio::test_units::kDeg;

ModelD glossy(double alpha) {
    ModelD m;
    m.has_diffuse = true;
    m.diffuse = Rgbd(0.2, 0.1, 0.05);
    Lobe<double> l;
    l.distribution = Distribution::kGgx;
    l.alpha_x = alpha;
    l.alpha_y = alpha;
    l.shadowing = Shadowing::kSmithCorrelated;
    l.fresnel.type = FresnelType::kSchlick;
    l.fresnel.f0 = Rgbd(0.04, 0.04, 0.04);
    l.scale = Rgbd::Ones();
    m.lobes.push_back(l);
    return m;
}

const CheckResult& named(const std::vector<CheckResult>& rs, const std::string& name) {
    for (const CheckResult& r : rs) {
        if (r.name == name) {
            return r;
        }
    }
    static const CheckResult none;
    return none;
}

TEST(TableChecks, TablesMadeFromModelsPassForEverySeed) {
    for (double alpha : {0.1, 0.4}) {
        const AnalyticBrdf model(glossy(alpha));
        TabulateOptions to;
        to.grid = TableGrid{90, 90, 180};
        to.threads = 2;
        const TabulatedBrdf table = tabulate(model, to);
        for (std::uint64_t seed : {1ull, 2ull, 3ull, 20261122ull, 987654321ull}) {
            SCOPED_TRACE("alpha " + std::to_string(alpha) + " seed " + std::to_string(seed));
            CheckOptions o;
            o.seed = seed;
            o.random_pairs = 4000;
            const auto rs = run_checks(table, o);
            for (const char* n : {"non-negativity", "reciprocity", "isotropy"}) {
                const CheckResult& r = named(rs, n);
                EXPECT_TRUE(r.passed)
                    << n << ": " << r.violation << " > " << r.tolerance << " at " << r.where;
            }
            // A table's comparisons are held to the bins' spread: the measure says so.
            EXPECT_EQ(named(rs, "isotropy").measure, "difference / (bin spread + noise)");
            EXPECT_EQ(named(rs, "isotropy").tolerance, 1.0);
        }
    }
}

/// A measured-like table: the model with 3 % Gaussian noise per bin (seeded), the per-bin sigma
/// stated, theta_d above 60 degrees unmeasured.
TabulatedBrdf noisy_table(const Brdf& model, unsigned seed, std::vector<Rgbd>* sigma) {
    TabulateOptions to;
    to.grid = TableGrid{45, 45, 90};
    to.threads = 2;
    TabulatedBrdf t = tabulate(model, to);
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, 0.03);
    sigma->assign(t.grid().size(), Rgbd::Zero());
    for (std::size_t k = 0; k < t.grid().size(); ++k) {
        if (!t.bin_valid(k)) {
            continue;
        }
        if (t.grid().unflatten(k)[1] >= 30) {
            t.set_bin_invalid(k);
            continue;
        }
        const Rgbd v = t.bin_value(k);
        Rgbd noisy = v;
        for (int c = 0; c < 3; ++c) {
            noisy[c] = std::max(0.0, v[c] * (1 + n(rng)));
        }
        t.set_bin(k, noisy);
        (*sigma)[k] = 0.03 * v;
    }
    return t;
}

TEST(TableChecks, NoisyMeasuredTablePassesWithinItsStatedNoiseForEverySeed) {
    const AnalyticBrdf model(glossy(0.3));
    for (unsigned seed : {1u, 2u, 3u}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        std::vector<Rgbd> sigma;
        const TabulatedBrdf t = noisy_table(model, seed, &sigma);
        CheckOptions o;
        o.seed = seed;
        o.random_pairs = 4000;
        o.bin_sigma = sigma;
        o.noise_relative = 0.03;
        const auto rs = run_checks(t, o);
        for (const CheckResult& r : rs) {
            EXPECT_TRUE(r.passed) << r.name << ": " << r.violation << " > " << r.tolerance << " at "
                                  << r.where;
        }
        // Pairs that fall in the unmeasured theta_d > 60 degrees are counted, not compared.
        EXPECT_GT(named(rs, "isotropy").skipped, 0u);
        EXPECT_NE(named(rs, "isotropy").detail.find("unmeasured bins"), std::string::npos);
    }
}

/// Point measurements of the model: theta in {10, 25, ..., 70} for both directions, delta_phi in
/// {0, 45, ..., 180}, at two phi_i; 2 % noise with the stated sigma.
Dataset noisy_measurement(const Brdf& model, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, 0.02);
    Dataset d;
    d.source = "measured.csv";
    d.has_sigma = true;
    for (double phi_i : {0.0, 90.0}) {
        for (double ti = 10; ti <= 70; ti += 15) {
            for (double to = 10; to <= 70; to += 15) {
                for (double dp = 0; dp <= 180; dp += 45) {
                    Sample s;
                    s.theta_i = ti * kDeg;
                    s.phi_i = phi_i * kDeg;
                    s.theta_o = to * kDeg;
                    s.phi_o = (phi_i + dp) * kDeg;
                    const Rgbd f = model.eval(s.wi(), s.wo());
                    for (int c = 0; c < 3; ++c) {
                        s.value[c] = f[c] * (1 + n(rng));
                    }
                    s.sigma = 0.02 * f;
                    s.line = d.samples.size() + 2;
                    d.samples.push_back(s);
                }
            }
        }
    }
    return d;
}

TEST(DatasetChecks, NoisyMeasurementPassesWithinItsSigmaForEverySeed) {
    const AnalyticBrdf model(glossy(0.3));
    for (unsigned seed = 1; seed <= 8; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const auto rs = check_dataset(noisy_measurement(model, seed));
        EXPECT_TRUE(all_passed(rs)) << format_check_table(rs);
        EXPECT_TRUE(named(rs, "reciprocity").applicable);
        EXPECT_TRUE(named(rs, "isotropy").applicable);
        EXPECT_FALSE(named(rs, "energy").applicable);
    }
}

TEST(DatasetChecks, PlantedReciprocityErrorFailsAndIsNamed) {
    const AnalyticBrdf model(glossy(0.3));
    for (unsigned seed = 1; seed <= 4; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        Dataset d = noisy_measurement(model, seed);
        // theta_i 25, theta_o 55, delta_phi 90 at phi_i 0: 30 % brighter than its reciprocal.
        std::size_t planted = d.samples.size();
        for (std::size_t k = 0; k < d.samples.size(); ++k) {
            const Sample& s = d.samples[k];
            if (std::abs(s.theta_i - 25 * kDeg) < 1e-9 && std::abs(s.theta_o - 55 * kDeg) < 1e-9 &&
                std::abs(s.phi_o - s.phi_i - 90 * kDeg) < 1e-9 && s.phi_i == 0) {
                planted = k;
            }
        }
        ASSERT_LT(planted, d.samples.size());
        d.samples[planted].value *= 1.3;
        const auto rs = check_dataset(d);
        const CheckResult& r = named(rs, "reciprocity");
        EXPECT_FALSE(r.passed) << format_check_table(rs);
        EXPECT_GT(r.violation, r.tolerance);
        EXPECT_NE(r.where.find("line " + std::to_string(d.samples[planted].line)),
                  std::string::npos)
            << r.where;
    }
}

TEST(DatasetChecks, BonferroniThresholdMatchesTheNormalTail) {
    // P(|z| > 4.8916) = 1e-6 for one comparison (standard normal two-sided tail).
    EXPECT_NEAR(bonferroni_threshold(1, 1e-6), 4.8916, 1e-3);
    // More comparisons, a higher threshold: 1e-6 / 1000 per comparison.
    EXPECT_NEAR(bonferroni_threshold(1000, 1e-6), 6.1094, 1e-3);
}

}  // namespace
}  // namespace gonio::brdf
