// MERL binary format: index mapping against hand-computed cases, byte-exact round trips, and a
// table written from a closed-form BRDF read back and compared at the bin centres.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "common/test_units.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {
namespace {

namespace fs = std::filesystem;

// A smooth isotropic, reciprocal test BRDF written directly in half/difference angles, so that its
// value at a bin centre is known independently of the table code:
//   f_c = a_c + b_c exp(-theta_h^2 / 0.05) (1 + cos theta_d) / 2 + c_c cos^2(2 phi_d).
class HalfDiffFunction : public Brdf {
  public:
    static Rgbd at(double theta_h, double theta_d, double phi_d) {
        const Rgbd a(0.2, 0.3, 0.4);
        const Rgbd b(5.0, 4.0, 3.0);
        const Rgbd c(0.05, 0.1, 0.15);
        const double peak = std::exp(-theta_h * theta_h / 0.05) * (1 + std::cos(theta_d)) / 2;
        const double cp = std::cos(2 * phi_d);
        return a + b * peak + c * cp * cp;
    }
    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override {
        if (wi.z() <= 0 || wo.z() <= 0) {
            return Rgbd::Zero();
        }
        const HalfDiff<double> hd = to_half_diff(wi, wo);
        return at(hd.theta_h, hd.theta_d, hd.phi_d);
    }
    bool isotropic() const override { return true; }
    std::string describe() const override { return "half/diff test function"; }
};

std::string temp_path(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() /
                         ("gonio_merl_test_" + std::to_string(static_cast<long>(::getpid())));
    fs::create_directories(dir);
    return (dir / name).string();
}

std::vector<std::uint8_t> file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in),
                                     std::istreambuf_iterator<char>());
}

using gonio::test_units::kDeg;

TEST(MerlIndex, ThetaHalfHandCases) {
    const TableGrid g = TableGrid::merl();
    // theta_h = 0: the mirror configuration, first bin.
    EXPECT_EQ(g.theta_h_index(0.0), 0);
    // Rounding noise below 0 stays in the first bin.
    EXPECT_EQ(g.theta_h_index(-1e-17), 0);
    // 0.1 rad: sqrt(0.1 / 1.5707963) * 90 = 22.708 -> 22.
    EXPECT_EQ(g.theta_h_index(0.1), 22);
    // 45 deg: sqrt(0.5) * 90 = 63.64 -> 63.
    EXPECT_EQ(g.theta_h_index(45 * kDeg), 63);
    // 1 deg: sqrt(1/90) * 90 = 9.487 -> 9 (the mapping is fine near the specular peak).
    EXPECT_EQ(g.theta_h_index(1 * kDeg), 9);
    // Last bin: 89.9 deg -> sqrt(89.9/90) * 90 = 89.95 -> 89; pi/2 and beyond clamp to 89.
    EXPECT_EQ(g.theta_h_index(89.9 * kDeg), 89);
    EXPECT_EQ(g.theta_h_index(kPi / 2), 89);
    EXPECT_EQ(g.theta_h_index(2.0), 89);
    EXPECT_EQ(g.theta_h_index(std::nan("")), 0);
}

TEST(MerlIndex, ThetaDiffHandCases) {
    const TableGrid g = TableGrid::merl();
    EXPECT_EQ(g.theta_d_index(0.0), 0);
    // 45 deg = exactly half of the range -> 45.
    EXPECT_EQ(g.theta_d_index(kPi / 4), 45);
    // 30.5 deg -> 30.
    EXPECT_EQ(g.theta_d_index(30.5 * kDeg), 30);
    EXPECT_EQ(g.theta_d_index(kPi / 2), 89);
    EXPECT_EQ(g.theta_d_index(-0.2), 0);
}

TEST(MerlIndex, PhiDiffHandCases) {
    const TableGrid g = TableGrid::merl();
    EXPECT_EQ(g.phi_d_index(0.0), 0);
    // 1.5 deg over [0, 180) deg in 180 bins -> 1.
    EXPECT_EQ(g.phi_d_index(1.5 * kDeg), 1);
    // 90.5 deg -> 90.
    EXPECT_EQ(g.phi_d_index(90.5 * kDeg), 90);
    // Exactly pi: 180 clamped into the last bin, 179 (as the classic reader does).
    EXPECT_EQ(g.phi_d_index(kPi), 179);
    // Negative phi_d is shifted by pi: -pi/2 -> pi/2 -> 90; -0.1 rad -> (pi - 0.1)/pi * 180 =
    // 174.27 -> 174; -pi -> 0 -> 0.
    EXPECT_EQ(g.phi_d_index(-kPi / 2), 90);
    EXPECT_EQ(g.phi_d_index(-0.1), 174);
    EXPECT_EQ(g.phi_d_index(-kPi), 0);
}

TEST(MerlIndex, FlatIndexLayout) {
    const TableGrid g = TableGrid::merl();
    // index = i_phi_d + 180 i_theta_d + 16200 i_theta_h.
    EXPECT_EQ(g.index(1, 2, 3), 3u + 180u * 2u + 16200u * 1u);
    EXPECT_EQ(g.index(89, 89, 179), 1458000u - 1u);
    EXPECT_EQ(g.size(), 1458000u);
    const std::array<int, 3> b = g.unflatten(16563);
    EXPECT_EQ(b[0], 1);
    EXPECT_EQ(b[1], 2);
    EXPECT_EQ(b[2], 3);
    EXPECT_EQ(merl_file_size(g), 12u + 3u * 1458000u * 8u);
}

TEST(MerlIndex, DirectionsOfHandComputedPairs) {
    const TableGrid g = TableGrid::merl();
    TabulatedBrdf t = TabulatedBrdf::empty(g, kMerlScale, "probe");
    // wi at 60 deg (phi 0), wo along the normal: h at 30 deg, d = wi rotated back by 30 deg, so
    // theta_h = 30 deg -> floor(sqrt(1/3) * 90) = 51, theta_d = 30 deg -> 30, phi_d = 0 -> 0.
    const Vec3d wi = spherical_to_cartesian(60 * kDeg, 0.0);
    const Vec3d wo(0, 0, 1);
    const HalfDiff<double> hd = to_half_diff(wi, wo);
    EXPECT_NEAR(hd.theta_h, 30 * kDeg, 1e-12);
    EXPECT_NEAR(hd.theta_d, 30 * kDeg, 1e-12);
    EXPECT_EQ(g.theta_h_index(hd.theta_h), 51);
    EXPECT_EQ(g.theta_d_index(hd.theta_d + 1e-9), 30);
    EXPECT_EQ(g.phi_d_index(hd.phi_d), 0);
    // Mirror pair at 30 deg: theta_h = 0 -> 0, theta_d = 30 deg.
    const HalfDiff<double> m = to_half_diff(spherical_to_cartesian(30.2 * kDeg, 0.0),
                                            spherical_to_cartesian(30.2 * kDeg, kPi));
    EXPECT_EQ(g.theta_h_index(m.theta_h), 0);
    EXPECT_EQ(g.theta_d_index(m.theta_d), 30);
}

TEST(MerlIndex, BinCentresMapBackToTheirBin) {
    const TableGrid g{16, 12, 24};
    for (int ih = 0; ih < g.n_theta_h; ++ih) {
        for (int id = 0; id < g.n_theta_d; ++id) {
            for (int ip = 0; ip < g.n_phi_d; ++ip) {
                ASSERT_EQ(g.theta_h_index(g.theta_h_centre(ih)), ih);
                ASSERT_EQ(g.theta_d_index(g.theta_d_centre(id)), id);
                ASSERT_EQ(g.phi_d_index(g.phi_d_centre(ip)), ip);
                // Through the directions too.
                const auto [wi, wo] = g.centre_directions(ih, id, ip);
                const HalfDiff<double> hd = to_half_diff(wi, wo);
                ASSERT_EQ(g.theta_h_index(hd.theta_h), ih) << id << " " << ip;
                ASSERT_EQ(g.theta_d_index(hd.theta_d), id);
                ASSERT_EQ(g.phi_d_index(hd.phi_d), ip);
            }
        }
    }
}

TEST(MerlCodec, HandMadeBytesRoundTripExactly) {
    // Random bit patterns that are finite doubles, including -0.0, denormals and negative markers.
    const unsigned seed = 20261122;
    std::mt19937_64 rng(seed);
    const TableGrid g{3, 4, 5};
    std::vector<std::uint8_t> bytes(merl_file_size(g));
    const std::int32_t dims[3] = {3, 4, 5};
    std::memcpy(bytes.data(), dims, 12);  // little-endian host, as the format
    for (std::size_t k = 0; k < 3 * g.size(); ++k) {
        double v;
        do {
            const std::uint64_t bits = rng();
            std::memcpy(&v, &bits, 8);
        } while (!std::isfinite(v));
        if (k == 0) {
            v = -0.0;
        } else if (k == 1) {
            v = 4.9e-324;
        } else if (k == 2) {
            v = -1.0;
        }
        std::memcpy(bytes.data() + 12 + 8 * k, &v, 8);
    }
    const std::string path = temp_path("random.gtab");
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    Expected<TabulatedBrdf> t = read_merl(path, MerlDims::kAny);
    ASSERT_TRUE(t) << t.error().message << " seed " << seed;
    EXPECT_EQ(encode_merl(*t), bytes) << "seed " << seed;
    const std::string again = temp_path("random_again.gtab");
    ASSERT_TRUE(write_merl(again, *t));
    EXPECT_EQ(file_bytes(again), bytes) << "seed " << seed;
    fs::remove(path);
    fs::remove(again);
    // The parser of an in-memory image agrees with the file reader.
    Expected<TabulatedBrdf> p = parse_merl(bytes.data(), bytes.size(), "mem", MerlDims::kAny);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->raw(), t->raw());
}

TEST(MerlCodec, ValidityMaskFromNegativeEntries) {
    Expected<TabulatedBrdf> t =
        read_table_file(std::string(GONIO_SOURCE_DIR) + "/tests/brdf/data/merl/valid_2x2x4.gtab");
    ASSERT_TRUE(t) << t.error().message;
    // The corpus file marks bin 3 negative in all channels; -0.0 (bin 5, red) counts as measured.
    for (std::size_t k = 0; k < 16; ++k) {
        EXPECT_EQ(t->bin_valid(k), k != 3) << k;
    }
    EXPECT_EQ(t->compute_statistics().valid_bins, 15u);
    // Stored 0.5 + k scaled: red bin 0 = 0.5/1500, green bin 0 (k = 16) = 16.5 * 1.15/1500.
    EXPECT_DOUBLE_EQ(t->bin_value(0)[0], 0.5 / 1500);
    EXPECT_DOUBLE_EQ(t->bin_value(0)[1], 16.5 * 1.15 / 1500);
    EXPECT_DOUBLE_EQ(t->bin_value(0)[2], 32.5 * 1.66 / 1500);
}

// The full-size path: a 90 x 90 x 180 file written from the test function, read back, compared at
// every valid bin centre, and written again byte for byte.
TEST(MerlCodec, FullSizeModelTableReadBackAtBinCentres) {
    const HalfDiffFunction f;
    TabulateReport rep;
    TabulateOptions opts;
    opts.threads = 2;
    const TabulatedBrdf table = tabulate(f, opts, &rep);
    EXPECT_EQ(rep.bins, 1458000u);
    EXPECT_EQ(rep.valid_bins + rep.below_horizon, rep.bins);
    EXPECT_GT(rep.valid_bins, 700000u);
    const std::string path = temp_path("model.binary");
    ASSERT_TRUE(write_merl(path, table));
    const std::vector<std::uint8_t> written = file_bytes(path);
    ASSERT_EQ(written.size(), 34992012u);
    Expected<TabulatedBrdf> back = read_merl(path);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(encode_merl(*back), written);
    fs::remove(path);
    const TableGrid g = back->grid();
    double worst = 0;
    std::size_t checked = 0;
    for (int ih = 0; ih < g.n_theta_h; ih += 3) {
        for (int id = 0; id < g.n_theta_d; id += 2) {
            for (int ip = 0; ip < g.n_phi_d; ip += 5) {
                const auto [wi, wo] = g.centre_directions(ih, id, ip);
                const TableLookup l = back->lookup(wi, wo);
                if (wi.z() <= 0 || wo.z() <= 0) {
                    EXPECT_FALSE(l.valid);
                    continue;
                }
                ASSERT_TRUE(l.valid) << ih << " " << id << " " << ip;
                const Rgbd expect = HalfDiffFunction::at(
                    g.theta_h_centre(ih), g.theta_d_centre(id), g.phi_d_centre(ip));
                worst = std::max(worst, ((l.value - expect).abs() / expect).maxCoeff());
                ++checked;
            }
        }
    }
    std::printf("bin centres checked: %zu, worst relative error %.3g\n", checked, worst);
    // Stored as f / scale and read as stored * scale, after a direction round trip: a few ulps.
    EXPECT_LT(worst, 1e-13);
    EXPECT_GT(checked, 10000u);
}

}  // namespace
}  // namespace gonio::brdf
