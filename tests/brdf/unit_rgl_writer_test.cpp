// Writing RGL files: a file written from an analytic model is read back by gonio's reader and by
// RGL's own (built here from ../shared/tools/rgl-reference), both agree with the model to the
// representation's error; the nodes of a file are its samples; a real measurement written again
// keeps its values.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/test_units.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "rgl_test_support.h"

namespace {

using namespace gonio::brdf;

using gonio::test_units::kDeg;

ModelD microfacet_model(Distribution d, double alpha) {
    ModelD m;
    m.has_diffuse = true;
    m.diffuse = Rgbd(0.12, 0.25, 0.4);
    Lobe<double> lobe;
    lobe.distribution = d;
    lobe.alpha_x = lobe.alpha_y = alpha;
    lobe.shadowing = Shadowing::kSmithCorrelated;
    lobe.fresnel.type = FresnelType::kSchlick;
    lobe.fresnel.f0 = Rgbd::Constant(0.04);
    m.lobes.push_back(lobe);
    return m;
}

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() /
            ("gonio_rgl_" + std::to_string(::getpid()) + "_" + name))
        .string();
}

struct Pair {
    double theta_i, phi_i, theta_o, phi_o;
};

// Seeded direction pairs with both elevations in [0, 80] degrees: half uniform, half within 10
// degrees of the mirror direction (the peak, where a representation errs most).
std::vector<Pair> test_pairs(unsigned seed, int count) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Pair> out;
    while (static_cast<int>(out.size()) < count) {
        Pair p{};
        p.theta_i = u(rng) * 80 * kDeg;
        p.phi_i = (2 * u(rng) - 1) * kPi;
        if (out.size() % 2 == 0) {
            p.theta_o = u(rng) * 80 * kDeg;
            p.phi_o = (2 * u(rng) - 1) * kPi;
        } else {
            p.theta_o = p.theta_i + (2 * u(rng) - 1) * 10 * kDeg;
            p.phi_o = p.phi_i + kPi + (2 * u(rng) - 1) * 10 * kDeg;
            if (p.theta_o < 0 || p.theta_o > 80 * kDeg) {
                continue;
            }
        }
        out.push_back(p);
    }
    return out;
}

// RGL's reference reader, compiled from ../shared/tools/rgl-reference into the temp folder; empty
// with the reason in *why when it is not there.
std::string build_rgl_eval(std::string* why) {
    const std::string src =
        std::string(GONIO_SOURCE_DIR) + "/../shared/tools/rgl-reference/rgl_eval.cpp";
    if (!std::ifstream(src).good()) {
        *why = "RGL's reference reader " + src + " not found";
        return {};
    }
    const std::string exe = temp_path("rgl_eval");
    const char* cxx = std::getenv("CXX");
    const std::string cmd =
        std::string(cxx ? cxx : "c++") + " -O2 -std=c++17 " + src + " -o " + exe;
    if (std::system(cmd.c_str()) != 0) {
        *why = "could not build RGL's reference reader: " + cmd;
        return {};
    }
    return exe;
}

// f_r from RGL's reader at the pairs.
std::vector<Rgbd> rgl_eval(const std::string& exe,
                           const std::string& file,
                           const std::vector<Pair>& pairs) {
    const std::string dirs = temp_path("dirs.csv"), vals = temp_path("vals.csv");
    {
        std::ofstream out(dirs);
        out << "theta_i,phi_i,theta_o,phi_o\n";
        out.precision(17);
        for (const Pair& p : pairs) {
            out << p.theta_i << "," << p.phi_i << "," << p.theta_o << "," << p.phi_o << "\n";
        }
    }
    const std::string cmd = exe + " " + file + " < " + dirs + " > " + vals;
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    std::vector<Rgbd> out;
    std::ifstream in(vals);
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
        Rgbd v;
        char c;
        std::istringstream s(line);
        s >> v[0] >> c >> v[1] >> c >> v[2];
        out.push_back(v);
    }
    std::remove(dirs.c_str());
    std::remove(vals.c_str());
    return out;
}

struct ErrorStats {
    double median = 0, p95 = 0, max = 0;
    Pair worst{};
};

ErrorStats stats(std::vector<std::pair<double, Pair>> errors) {
    std::sort(errors.begin(), errors.end(), [](auto& a, auto& b) { return a.first < b.first; });
    ErrorStats s;
    s.median = errors[errors.size() / 2].first;
    s.p95 = errors[errors.size() * 95 / 100].first;
    s.max = errors.back().first;
    s.worst = errors.back().second;
    return s;
}

// The relative error of a file against its model at the pairs (largest over the channels); the
// file's values in *values.
ErrorStats against_model(const RglBsdf& file,
                         const Brdf& model,
                         const std::vector<Pair>& pairs,
                         std::vector<Rgbd>* values) {
    std::vector<std::pair<double, Pair>> errors;
    for (const Pair& p : pairs) {
        const Vec3d wi = spherical_to_cartesian(p.theta_i, p.phi_i);
        const Vec3d wo = spherical_to_cartesian(p.theta_o, p.phi_o);
        const Rgbd truth = model.eval(wi, wo);
        const Rgbd f = file.eval_unclipped(wi, wo);
        values->push_back(f);
        errors.push_back({((f - truth).abs() / truth).maxCoeff(), p});
    }
    return stats(errors);
}

// RGL's reference reader on the same file gives gonio's values to single-precision rounding
// (skipped without the reader, failed in CI).
void expect_rgl_reader_agrees(const std::string& path,
                              const std::vector<Pair>& pairs,
                              const std::vector<Rgbd>& gonio_values) {
    std::string why;
    const std::string exe = build_rgl_eval(&why);
    if (exe.empty()) {
        if (gonio::test::running_in_ci()) {
            FAIL() << why;
        }
        GTEST_SKIP() << why;
    }
    const std::vector<Rgbd> theirs = rgl_eval(exe, path, pairs);
    ASSERT_EQ(theirs.size(), pairs.size());
    double worst = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        for (int c = 0; c < 3; ++c) {
            const double rel = std::abs(theirs[k][c] - gonio_values[k][c]) / std::abs(theirs[k][c]);
            // A NaN (either reader, or a zero reference value) is the worst there is:
            // std::max(worst, NaN) would keep `worst` and drop it.
            worst =
                std::isnan(rel) ? std::numeric_limits<double>::infinity() : std::max(worst, rel);
        }
    }
    std::printf(
        "RGL's reader on %s: largest relative difference to gonio's %.3g\n", path.c_str(), worst);
    EXPECT_LT(worst, 1e-5);
    std::remove(exe.c_str());
}

// theta_h and theta_d of a pair, degrees.
std::pair<double, double> half_diff_deg(const Pair& p) {
    const Vec3d wi = spherical_to_cartesian(p.theta_i, p.phi_i);
    const Vec3d wo = spherical_to_cartesian(p.theta_o, p.phi_o);
    const Vec3d h = (wi + wo).normalized();
    return {std::acos(std::clamp(h.z(), -1.0, 1.0)) / kDeg,
            std::acos(std::clamp(h.dot(wi), -1.0, 1.0)) / kDeg};
}

class RglWriter : public ::testing::TestWithParam<Distribution> {};

TEST_P(RglWriter, ModelFileReadByGonioAndRglAgreesWithModel) {
    const AnalyticBrdf model(microfacet_model(GetParam(), 0.2), "test model");
    const std::string path = temp_path(std::string(to_string(GetParam())) + ".bsdf");
    auto rep = write_rgl_bsdf(path, model);
    ASSERT_TRUE(rep) << rep.error().message;
    EXPECT_LT(rep->ndf.change, 1e-4);
    auto back = read_rgl_bsdf(path);
    ASSERT_TRUE(back) << back.error().message;

    const std::vector<Pair> pairs = test_pairs(20261201, 2000);
    std::vector<Rgbd> gonio_values;
    const ErrorStats s = against_model(*back, model, pairs, &gonio_values);
    const auto [th, td] = half_diff_deg(s.worst);
    std::printf(
        "%s alpha 0.2: relative error of the representation over %zu pairs: median %.3g, "
        "95th percentile %.3g, largest %.3g at theta_h %.1f deg, theta_d %.1f deg "
        "(theta_i %.1f, theta_o %.1f)\n",
        to_string(GetParam()),
        pairs.size(),
        s.median,
        s.p95,
        s.max,
        th,
        td,
        s.worst.theta_i / kDeg,
        s.worst.theta_o / kDeg);
    // The representation error (32 x 32 nodes per theta_i, 16 theta_i nodes): measured 0.42 %
    // median, 7-8 % at the 95th percentile, 52-57 % at worst, near the peak at grazing angles
    // (theta_d about 70 deg), where the peak is narrowest in the warped square.
    EXPECT_LT(s.median, 0.01);
    EXPECT_LT(s.p95, 0.12);
    EXPECT_LT(s.max, 0.8);

    expect_rgl_reader_agrees(path, pairs, gonio_values);
    std::remove(path.c_str());
}

INSTANTIATE_TEST_SUITE_P(Analytic,
                         RglWriter,
                         ::testing::Values(Distribution::kGgx, Distribution::kBeckmann));

// An anisotropic GGX lobe turned by 30 degrees (brushed metal mounted at an angle) over a Lambert
// base: the file has phi_i nodes over the full turn and an NDF over the whole square; gonio's
// reader and RGL's reference reader agree with each other, and both with the model to the
// representation's error.
TEST(RglWriterAnisotropic, TurnedBrushedLobeReadByGonioAndRglAgreesWithModel) {
    ModelD m = microfacet_model(Distribution::kGgx, 0.12);
    m.lobes[0].anisotropic = true;
    m.lobes[0].alpha_x = 0.12;
    m.lobes[0].alpha_y = 0.3;
    m.lobes[0].orientation_deg = 30;
    const AnalyticBrdf model(m, "brushed");
    ASSERT_FALSE(model.isotropic());
    const std::string path = temp_path("brushed.bsdf");
    RglWriteOptions one_azimuth;
    one_azimuth.phi_i_count = 1;
    auto refused = write_rgl_bsdf(path, model, one_azimuth);
    ASSERT_FALSE(refused);
    EXPECT_NE(refused.error().message.find("anisotropic"), std::string::npos);

    auto rep = write_rgl_bsdf(path, model);  // 16 azimuths, 64 x 64 NDF
    ASSERT_TRUE(rep) << rep.error().message;
    EXPECT_EQ(rep->ndf.rows, 64u);
    EXPECT_LT(rep->ndf.change, 1e-4);
    auto back = read_rgl_bsdf(path);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_FALSE(back->isotropic());
    ASSERT_EQ(back->phi_i().size(), 17u);
    EXPECT_NE(back->describe().find("anisotropic RGB, 17 phi_i"), std::string::npos);

    // The recovered NDF (retro-reflection includes the Lambert base, so only its shape is
    // checked): wider along the lobe's y axis (120 deg) than along its x axis (30 deg), and
    // symmetric under a half turn as the lobe is.
    const double h = 1.0 / 63.0;
    auto d_at = [&](double theta, double phi) {
        const double ux = rgl_theta_to_u(theta) / h, uy = rgl_phi_to_u(phi) / h;
        const auto c = static_cast<std::size_t>(std::lround(ux));
        const auto r = static_cast<std::size_t>(std::lround(uy));
        return rep->ndf.d[r * 64 + c];
    };
    const double theta_probe = 12 * kDeg;
    EXPECT_LT(d_at(theta_probe, 30 * kDeg), 0.8 * d_at(theta_probe, 120 * kDeg));
    EXPECT_NEAR(d_at(theta_probe, 30 * kDeg) / d_at(theta_probe, -150 * kDeg), 1.0, 0.05);
    EXPECT_NEAR(d_at(theta_probe, 120 * kDeg) / d_at(theta_probe, -60 * kDeg), 1.0, 0.05);

    const std::vector<Pair> pairs = test_pairs(20261202, 2000);
    std::vector<Rgbd> gonio_values;
    const ErrorStats s = against_model(*back, model, pairs, &gonio_values);
    const auto [th, td] = half_diff_deg(s.worst);
    std::printf(
        "anisotropic GGX 0.12 x 0.3 at 30 deg: relative error of the representation over %zu "
        "pairs: median %.3g, 95th percentile %.3g, largest %.3g at theta_h %.1f deg, theta_d "
        "%.1f deg\n",
        pairs.size(),
        s.median,
        s.p95,
        s.max,
        th,
        td);
    // The representation error (16 azimuths, 16 theta_i nodes, 32 x 32 nodes each, 64 x 64 NDF):
    // measured 0.8 % median, 20 % at the 95th percentile, 3.2 at worst (theta_i near 75 deg, near
    // the mirror direction). The tables are interpolated linearly between phi_i nodes with the half
    // vector's azimuth absolute, so a grazing peak is blended between two azimuths: the same
    // isotropic model written with 16, 32 and 64 azimuths gives 17 %, 13 % and 12.5 % at the 95th
    // percentile against 10.5 % for its isotropic file (docs/file-formats-tables.md).
    EXPECT_LT(s.median, 0.015);
    EXPECT_LT(s.p95, 0.3);
    EXPECT_LT(s.max, 6.0);

    // The file's nodes are the model at their directions, over every azimuth.
    const Dataset data = rgl_nodes_to_dataset(*back);
    std::set<long> azimuths;
    double worst_node = 0;
    for (const Sample& smp : data.samples) {
        azimuths.insert(std::lround((smp.phi_i + kPi) / (2 * kPi / 16)) % 16);
        const Rgbd truth = model.eval(spherical_to_cartesian(smp.theta_i, smp.phi_i),
                                      spherical_to_cartesian(smp.theta_o, smp.phi_o));
        worst_node = std::max(worst_node, ((smp.value - truth).abs() / truth).maxCoeff());
    }
    EXPECT_EQ(azimuths.size(), 16u);
    EXPECT_LT(worst_node, 1e-5) << "a node's value is the model's, to float rounding";

    expect_rgl_reader_agrees(path, pairs, gonio_values);
    std::remove(path.c_str());
}

// A file reduced by a symmetry (phi_i over half a turn) is refused naming the reduction, as the
// format's readers do; so is a file with two phi_i nodes (neither form).
TEST(RglWriterAnisotropic, ReducedAndTwoNodeAzimuthsAreRefused) {
    ModelD m = microfacet_model(Distribution::kGgx, 0.2);
    m.lobes[0].anisotropic = true;
    m.lobes[0].alpha_y = 0.4;
    const AnalyticBrdf model(m, "brushed");
    RglWriteOptions o;
    o.phi_i_count = 4;
    o.ndf_resolution = 16;
    o.rgb_resolution = 8;
    o.theta_i_count = 4;
    auto ndf = rgl_ndf_power_iteration(model, o);
    ASSERT_TRUE(ndf) << ndf.error().message;
    auto layout = rgl_layout(*ndf, o);
    ASSERT_TRUE(layout) << layout.error().message;
    std::vector<Rgbd> values;
    for (const RglNode& node : layout->nodes) {
        values.push_back(node.wo.z() > 0 ? model.eval(node.wi, node.wo) : Rgbd::Zero());
    }
    auto file = rgl_tensor(*layout, values);
    ASSERT_TRUE(file) << file.error().message;
    EXPECT_TRUE(RglBsdf::from_tensor(*file, "full.bsdf")) << "the full turn is read";
    for (TensorField& f : file->fields) {
        if (f.name == "phi_i") {
            f = TensorField::float32("phi_i", {5}, {0.0f, 0.785f, 1.571f, 2.356f, 3.1415f});
        }
    }
    auto reduced = RglBsdf::from_tensor(*file, "reduced.bsdf");
    ASSERT_FALSE(reduced);
    EXPECT_NE(reduced.error().message.find("reduced.bsdf: field \"phi_i\" spans 180"),
              std::string::npos)
        << reduced.error().message;
    EXPECT_NE(reduced.error().message.find("2-fold"), std::string::npos);
}

TEST(RglNodes, NodesOfAWrittenFileAreTheModelAtTheirDirections) {
    const AnalyticBrdf model(microfacet_model(Distribution::kGgx, 0.3), "test model");
    const std::string path = temp_path("nodes.bsdf");
    ASSERT_TRUE(write_rgl_bsdf(path, model));
    auto back = read_rgl_bsdf(path);
    ASSERT_TRUE(back) << back.error().message;
    const Dataset data = rgl_nodes_to_dataset(*back);
    // 15 theta_i nodes below 89 degrees, 31 x 31 + 1 distinct nodes each, less those below the
    // horizon.
    EXPECT_GT(data.samples.size(), 8000u);
    EXPECT_LT(data.samples.size(), 15u * (31 * 31 + 1));
    double worst = 0;
    for (const Sample& s : data.samples) {
        const Rgbd truth = model.eval(s.wi(), s.wo());
        worst = std::max(worst, ((s.value - truth).abs() / truth).maxCoeff());
    }
    EXPECT_LT(worst, 1e-5);
    std::remove(path.c_str());
}

TEST(RglNodes, RealFileNodesAreItsStoredValues) {
    GONIO_REQUIRE_RGL_DATA();
    auto bsdf = read_rgl_bsdf(gonio::test::rgl_data_dir() + "/satin_rosaline_rgb.bsdf");
    ASSERT_TRUE(bsdf) << bsdf.error().message;
    const Dataset data = rgl_nodes_to_dataset(*bsdf);
    EXPECT_GT(data.samples.size(), 3000u);
    std::vector<double> rel;
    for (const Sample& s : data.samples) {
        const Rgbd f = bsdf->eval(s.wi(), s.wo());
        if (s.value.maxCoeff() > 1e-3) {
            rel.push_back(((f - s.value).abs() / s.value.max(1e-3)).maxCoeff());
        }
    }
    std::sort(rel.begin(), rel.end());
    // The evaluation at a node's own directions returns the node (single-precision round trip of
    // the warp).
    EXPECT_LT(rel[rel.size() / 2], 1e-5);
    EXPECT_LT(rel[rel.size() * 99 / 100], 1e-3);
}

TEST(RglWriter, PaperWhiteWrittenAgainKeepsItsReferenceValues) {
    GONIO_REQUIRE_RGL_DATA();
    const std::string base = gonio::test::rgl_data_dir() + "/paper_white_rgb";
    auto original = read_rgl_bsdf(base + ".bsdf");
    ASSERT_TRUE(original) << original.error().message;
    const std::string path = temp_path("paper_again.bsdf");
    auto rep = write_rgl_bsdf(path, *original);
    ASSERT_TRUE(rep) << rep.error().message;
    auto back = read_rgl_bsdf(path);
    ASSERT_TRUE(back) << back.error().message;
    std::vector<std::pair<double, Pair>> errors;
    for (const auto& r : gonio::test::read_rgl_reference(base + ".reference.csv")) {
        const Pair p{r.theta_i, r.phi_i, r.theta_o, r.phi_o};
        const Rgbd f = back->eval(spherical_to_cartesian(r.theta_i, r.phi_i),
                                  spherical_to_cartesian(r.theta_o, r.phi_o));
        const Rgbd ref(r.value[0], r.value[1], r.value[2]);
        if (ref.minCoeff() > 1e-3 && r.theta_o < 80 * kDeg && r.theta_i < 80 * kDeg) {
            errors.push_back({((f - ref).abs() / ref).maxCoeff(), p});
        }
    }
    ASSERT_GT(errors.size(), 200u);
    const ErrorStats s = stats(errors);
    const auto [th, td] = half_diff_deg(s.worst);
    std::printf(
        "paper_white written again: relative error at %zu reference pairs (both elevations "
        "below 80 deg): median %.3g, 95th percentile %.3g, largest %.3g at theta_h %.1f, "
        "theta_d %.1f deg\n",
        errors.size(),
        s.median,
        s.p95,
        s.max,
        th,
        td);
    // Measured: median 0.27 %, 95th percentile 6.3 %, worst near the horizon (theta_h 76 deg).
    EXPECT_LT(s.median, 0.01);
    EXPECT_LT(s.p95, 0.1);
    std::remove(path.c_str());
}

}  // namespace
