#pragma once

// Columns of a dataset CSV (docs/file-formats.md), in file order, and their names in messages.
// Shared by the reader (samples_io.cpp) and the sample validation (dataset.cpp).

namespace gonio::brdf::detail {

enum Col {
    kTi,
    kPhiI,
    kTo,
    kPo,
    kR,
    kG,
    kB,
    kSr,
    kSg,
    kSb,
    kW,
    kF,
    kTi0,  // the exposure path's start: theta_i, phi_i, theta_o, phi_o
    kPi0,
    kTo0,
    kPo0,
    kTi1,  // and its end
    kPi1,
    kTo1,
    kPo1,
    kNumCols
};
inline const char* const kColNames[kNumCols] = {
    "theta_i",     "phi_i",       "theta_o",       "phi_o",       "r",
    "g",           "b",           "sigma_r",       "sigma_g",     "sigma_b",
    "weight",      "flag",        "theta_i_start", "phi_i_start", "theta_o_start",
    "phi_o_start", "theta_i_end", "phi_i_end",     "theta_o_end", "phi_o_end"};

/// The column of the sample's own angles (kTi .. kPo) that a path column (kTi0 .. kPo1) follows.
inline int path_base_column(int c) {
    return c >= kTi0 ? (c - kTi0) % 4 : c;
}

}  // namespace gonio::brdf::detail
