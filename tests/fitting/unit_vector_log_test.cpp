// The packet logarithm of the log residual (fitting/vector_log.h) against a higher-precision
// reference: long double log1pl (64-bit significand), rounded error measured in ulps of the double
// result.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "gonio/base/instruction_set.h"
#include "gonio/fitting/vector_log.h"

namespace gonio::fitting {
namespace {

/// |y - ref| in units of the spacing of doubles at ref.
double ulp_error(double y, long double ref) {
    const double r = static_cast<double>(ref);
    const double spacing =
        std::nextafter(std::abs(r), std::numeric_limits<double>::infinity()) - std::abs(r);
    return static_cast<double>(std::abs(static_cast<long double>(y) - ref) / spacing);
}

TEST(VectorLog, Log1pWithinOneUlpOverTheRangeOfTheResidual) {
    // Seeded log-uniform values over 1e-300 .. 1e300 (the arguments m cos_i of the residual lie
    // in [0, 1e6] in practice; the range covers every finite non-negative model value).
    const std::uint64_t seed = 20261201;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> exponent(-300, 300);
    std::vector<double> x(200003);
    for (double& v : x) {
        v = std::pow(10.0, exponent(rng));
    }
    // Values near 1 and near the switch points of log1p's reductions.
    for (int k = 0; k < 1000; ++k) {
        x.push_back(1e-3 * k);
        x.push_back(std::sqrt(2.0) - 1 + 1e-6 * (k - 500));
    }
    std::vector<double> y(x.size());
    log1p_packets(x.data(), y.data(), x.size());
    double worst = 0;
    std::size_t at = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double e = ulp_error(y[i], std::log1pl(static_cast<long double>(x[i])));
        if (e > worst) {
            worst = e;
            at = i;
        }
    }
    EXPECT_LE(worst, 1.0) << "x = " << x[at] << ", seed " << seed << ", packets "
                          << isa_name(packet_isa());
}

TEST(VectorLog, EdgesFollowLog1p) {
    const double inf = std::numeric_limits<double>::infinity();
    const double x[] = {0.0,
                        std::numeric_limits<double>::denorm_min(),
                        1e-300,
                        1.0,
                        1e300,
                        inf,
                        -0.5,
                        -1.0,
                        -2.0,
                        std::numeric_limits<double>::quiet_NaN()};
    constexpr std::size_t n = sizeof x / sizeof x[0];
    double y[n];
    log1p_packets(x, y, n);
    EXPECT_EQ(y[0], 0.0);
    EXPECT_EQ(y[1], std::numeric_limits<double>::denorm_min());  // log1p(x) = x for tiny x
    EXPECT_EQ(y[2], 1e-300);
    EXPECT_LE(ulp_error(y[3], std::log1pl(1.0L)), 1.0);
    EXPECT_LE(ulp_error(y[4], std::log1pl(1e300L)), 1.0);
    EXPECT_EQ(y[5], inf);
    EXPECT_LE(ulp_error(y[6], std::log1pl(-0.5L)), 1.0);
    EXPECT_EQ(y[7], -inf);
    EXPECT_TRUE(std::isnan(y[8]));
    EXPECT_TRUE(std::isnan(y[9]));
}

TEST(VectorLog, EveryLengthGivesTheSameValuesAsOneLongCall) {
    // The padded last packet goes through the same code as full ones: a value does not depend on
    // where it stands in the array.
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 50);
    std::vector<double> x(40);
    for (double& v : x) {
        v = u(rng);
    }
    std::vector<double> full(x.size());
    log1p_packets(x.data(), full.data(), x.size());
    for (std::size_t n = 0; n <= x.size(); ++n) {
        for (std::size_t offset = 0; offset + n <= x.size() && offset < 9; ++offset) {
            std::vector<double> y(n, -1);
            log1p_packets(x.data() + offset, y.data(), n);
            for (std::size_t k = 0; k < n; ++k) {
                ASSERT_EQ(y[k], full[offset + k]) << "n " << n << " offset " << offset;
            }
        }
    }
}

}  // namespace
}  // namespace gonio::fitting
