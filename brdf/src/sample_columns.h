#pragma once

// Columns of a dataset CSV (docs/file-formats.md), in file order, and their names in messages.
// Shared by the reader (samples_io.cpp) and the sample validation (dataset.cpp).

namespace gonio::brdf::detail {

enum Col { kTi, kPhiI, kTo, kPo, kR, kG, kB, kSr, kSg, kSb, kW, kF, kNumCols };
inline const char* const kColNames[kNumCols] = {"theta_i",
                                                "phi_i",
                                                "theta_o",
                                                "phi_o",
                                                "r",
                                                "g",
                                                "b",
                                                "sigma_r",
                                                "sigma_g",
                                                "sigma_b",
                                                "weight",
                                                "flag"};

}  // namespace gonio::brdf::detail
