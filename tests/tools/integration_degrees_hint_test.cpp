// Angles written in degrees where gonio reads radians: a dataset CSV whose azimuth or polar column
// is in degrees is refused with a hint that angles are radians, and `gonio plot --theta-i` (in
// degrees) given radians says what they would be in degrees.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_run.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

/// A small dataset of a Lambertian surface (rho = 0.5) in radians, or the same in degrees.
fs::path dataset(const fs::path& dir, const std::string& name, bool degrees) {
    const fs::path p = dir / name;
    std::ofstream out(p);
    out << "theta_i,phi_i,theta_o,phi_o,r,g,b\n";
    const double k = degrees ? 1.0 : M_PI / 180;
    for (double ti : {10.0, 30.0, 50.0}) {
        for (double to : {0.0, 20.0, 40.0, 60.0}) {
            for (double po : {0.0, 90.0, 180.0}) {
                out << ti * k << ",0," << to * k << "," << po * k << ",0.159,0.159,0.159\n";
            }
        }
    }
    return p;
}

TEST(DegreesHint, ADatasetInDegreesSaysAnglesAreRadians) {
    const fs::path dir = fresh_test_dir("degrees_csv");
    const fs::path deg = dataset(dir, "deg.csv", true);
    const CliRun r = run_gonio("fit " + deg.string());
    EXPECT_EQ(r.status, 1) << r.out;
    // The first refused field: theta_i = 10 on line 2 (a polar angle within 90).
    EXPECT_NE(r.out.find("deg.csv:2:1: theta_i = 10 outside [0, pi/2)"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("it looks like degrees: angles are radians"), std::string::npos) << r.out;
    // Only the azimuths in degrees: the azimuth column says so too.
    const fs::path az = dir / "az.csv";
    std::ofstream(az) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.2,0,0.3,180,0.1,0.1,0.1\n";
    const CliRun a = run_gonio("fit " + az.string());
    EXPECT_EQ(a.status, 1) << a.out;
    EXPECT_NE(a.out.find("az.csv:2:4: phi_o = 180 outside [-2 pi, 2 pi] (it looks like degrees: "
                         "angles are radians, 180 deg = 3.1416)"),
              std::string::npos)
        << a.out;
    // An azimuth beyond every reading (not degrees either) gets no such hint.
    std::ofstream(az) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.2,0,0.3,1000,0.1,0.1,0.1\n";
    const CliRun b = run_gonio("fit " + az.string());
    EXPECT_EQ(b.status, 1) << b.out;
    EXPECT_EQ(b.out.find("looks like degrees"), std::string::npos) << b.out;
    // The same data in radians fits.
    const CliRun ok = run_gonio("fit " + dataset(dir, "rad.csv", false).string());
    EXPECT_EQ(ok.status, 0) << ok.out;
}

TEST(DegreesHint, PlotThetaIInRadiansIsWarnedWithTheDegrees) {
    const fs::path dir = fresh_test_dir("degrees_plot");
    const fs::path data = dataset(dir, "rad.csv", false);
    const CliRun r =
        run_gonio("plot " + data.string() + " --theta-i 0.52 --out " + (dir / "plots").string());
    EXPECT_NE(r.out.find("gonio plot: warning: --theta-i is in degrees"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("(in degrees: --theta-i 29.79)"), std::string::npos) << r.out;
    // Degrees as meant: no warning.
    const CliRun d =
        run_gonio("plot " + data.string() + " --theta-i 10,30 --out " + (dir / "plots2").string());
    EXPECT_EQ(d.status, 0) << d.out;
    EXPECT_EQ(d.out.find("warning: --theta-i"), std::string::npos) << d.out;
}

}  // namespace
}  // namespace gonio::testing
