#pragma once

// The real RGL measurements beside the source tree (../shared/data/rgl): never copied into the
// repository. Missing: the test is skipped with the reason, or fails when CI=true (CI has them).

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace gonio::test {

inline std::string rgl_data_dir() {
    return std::string(GONIO_SOURCE_DIR) + "/../shared/data/rgl";
}

inline bool rgl_data_present() {
    std::ifstream probe(rgl_data_dir() + "/paper_white_rgb.bsdf", std::ios::binary);
    return probe.good();
}

inline bool running_in_ci() {
    const char* ci = std::getenv("CI");
    return ci != nullptr && std::string(ci) == "true";
}

/// One row of a *.reference.csv: directions (radians) and f_r (1/sr).
struct RglReferenceRow {
    double theta_i, phi_i, theta_o, phi_o;
    double value[3];
};

inline std::vector<RglReferenceRow> read_rgl_reference(const std::string& path) {
    std::vector<RglReferenceRow> rows;
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
        RglReferenceRow r{};
        char c = 0;
        std::istringstream s(line);
        s >> r.theta_i >> c >> r.phi_i >> c >> r.theta_o >> c >> r.phi_o >> c >> r.value[0] >> c >>
            r.value[1] >> c >> r.value[2];
        if (s) {
            rows.push_back(r);
        }
    }
    return rows;
}

}  // namespace gonio::test

/// Skips the test (or fails it under CI=true) when the RGL data folder is missing.
#define GONIO_REQUIRE_RGL_DATA()                                                            \
    do {                                                                                    \
        if (!gonio::test::rgl_data_present()) {                                             \
            if (gonio::test::running_in_ci()) {                                             \
                FAIL() << "CI=true but the RGL data folder " << gonio::test::rgl_data_dir() \
                       << " is missing";                                                    \
            }                                                                               \
            GTEST_SKIP() << "RGL data folder " << gonio::test::rgl_data_dir()               \
                         << " not found (real measurements are not in the repository)";     \
        }                                                                                   \
    } while (0)
