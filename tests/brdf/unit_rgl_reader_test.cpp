// The RGL reader against RGL's own reader: the three real measurements reproduce the reference
// values that RGL's reference implementation computed (RGB clipping off) at 400 seeded direction
// pairs each.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gonio/brdf/coords.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "rgl_test_support.h"

namespace {

using gonio::brdf::Rgbd;
using gonio::brdf::RglBsdf;
using gonio::brdf::spherical_to_cartesian;

class RglReference : public ::testing::TestWithParam<std::string> {};

TEST_P(RglReference, ReproducesReferenceReader) {
    GONIO_REQUIRE_RGL_DATA();
    const std::string base = gonio::test::rgl_data_dir() + "/" + GetParam();
    auto bsdf = gonio::brdf::read_rgl_bsdf(base + ".bsdf");
    ASSERT_TRUE(bsdf) << bsdf.error().message;
    const auto rows = gonio::test::read_rgl_reference(base + ".reference.csv");
    ASSERT_EQ(rows.size(), 400u);
    std::vector<double> all;
    for (const auto& r : rows) {
        all.insert(all.end(), r.value, r.value + 3);
    }
    std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
    const double median = all[all.size() / 2];
    double worst = 0;
    std::size_t compared = 0;
    for (std::size_t k = 0; k < rows.size(); ++k) {
        const auto& r = rows[k];
        const Rgbd f = bsdf->eval_unclipped(spherical_to_cartesian(r.theta_i, r.phi_i),
                                            spherical_to_cartesian(r.theta_o, r.phi_o));
        for (int c = 0; c < 3; ++c) {
            if (r.value[c] <= 1e-4 * median) {
                EXPECT_NEAR(f[c], r.value[c], 1e-4 * median) << "row " << k + 2 << " channel " << c;
                continue;
            }
            const double rel = std::abs(f[c] - r.value[c]) / r.value[c];
            worst = std::max(worst, rel);
            ++compared;
            EXPECT_LT(rel, 1e-5) << "row " << k + 2 << " channel " << c << ": " << f[c] << " vs "
                                 << r.value[c];
        }
    }
    EXPECT_GT(compared, 1000u);
    std::printf(
        "%s: %zu values, largest relative difference %.3g\n", GetParam().c_str(), compared, worst);
}

INSTANTIATE_TEST_SUITE_P(RealFiles,
                         RglReference,
                         ::testing::Values("paper_white_rgb",
                                           "satin_rosaline_rgb",
                                           "acrylic_felt_green_rgb"));

}  // namespace
