// Rows of direction pairs evaluated together (direction_rows.h): each row's value is the BRDF's at
// its directions, in input order; a refused row and a row whose value is not finite give NaN in
// every channel and keep their place; only the latter is named.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "gonio/brdf/direction_rows.h"

namespace gonio::brdf {
namespace {

/// (wi_z, wo_z, wi_x) as the value, Inf where wi_x is above 0.9 (a formula that overflows there).
class CosinesBrdf : public Brdf {
  public:
    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override {
        if (wi[0] > 0.9) {
            return Rgbd(std::numeric_limits<double>::infinity(), 1, 1);
        }
        return Rgbd(wi[2], wo[2], wi[0]);
    }
    bool isotropic() const override { return false; }
    std::string describe() const override { return "cosines"; }
};

TEST(DirectionRows, ValuesInOrderRefusedAndNonFiniteRowsNanInPlace) {
    const CosinesBrdf brdf;
    DirectionRows rows;
    rows.add(spherical_to_cartesian(0.3, 0.0), spherical_to_cartesian(0.5, 1.0));  // row 0
    rows.add_refused();                                                            // row 1
    rows.add(spherical_to_cartesian(1.5, 0.0), spherical_to_cartesian(0.2, 2.0));  // row 2: Inf
    rows.add(spherical_to_cartesian(0.7, 3.0), spherical_to_cartesian(0.1, 4.0));  // row 3
    ASSERT_EQ(rows.size(), 4u);
    std::vector<double> v[3] = {
        std::vector<double>(4), std::vector<double>(4), std::vector<double>(4)};
    double* const out[3] = {v[0].data(), v[1].data(), v[2].data()};
    const std::vector<std::size_t> non_finite = rows.evaluate(brdf, out);
    EXPECT_EQ(non_finite, std::vector<std::size_t>{2});
    for (const std::size_t k : {std::size_t{1}, std::size_t{2}}) {
        for (int c = 0; c < 3; ++c) {
            EXPECT_TRUE(std::isnan(v[c][k])) << "row " << k << " channel " << c << " " << v[c][k];
        }
    }
    EXPECT_DOUBLE_EQ(v[0][0], std::cos(0.3));
    EXPECT_DOUBLE_EQ(v[1][0], std::cos(0.5));
    EXPECT_DOUBLE_EQ(v[2][0], std::sin(0.3));
    EXPECT_DOUBLE_EQ(v[0][3], std::cos(0.7));
    EXPECT_DOUBLE_EQ(v[1][3], std::cos(0.1));
    EXPECT_DOUBLE_EQ(v[2][3], std::sin(0.7) * std::cos(3.0));
    // Cleared, the rows start again from row 0.
    rows.clear();
    EXPECT_EQ(rows.size(), 0u);
    rows.add(spherical_to_cartesian(0.4, 0.0), spherical_to_cartesian(0.4, 0.0));
    EXPECT_TRUE(rows.evaluate(brdf, out).empty());
    EXPECT_DOUBLE_EQ(v[0][0], std::cos(0.4));
}

}  // namespace
}  // namespace gonio::brdf
