#pragma once

// Synthetic measurements for the fitting tests: a goniometer-like angular grid and exact model
// values on it.

#include <cmath>
#include <vector>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model.h"
#include "gonio/brdf/model_eval.h"

namespace gonio::fitting::testing {

inline double deg(double d) {
    return d * brdf::kPi / 180.0;
}

/// A realistic measurement plan: incidence 5..75 degrees in steps of 10 at two sample
/// orientations (phi_i = 0 and 60 degrees); detector on a coarse hemisphere grid (theta_o 0..85 in
/// steps of 5, relative azimuth 0, 45, 90, 135, 180) and a fine scan around the mirror direction,
/// in plane and out of plane (+-0.25 .. +-8 degrees), as a gonioreflectometer resolves a peak.
inline std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> measurement_grid() {
    std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>> dirs;
    const double offsets[] = {-8, -4, -2, -1, -0.5, -0.25, 0, 0.25, 0.5, 1, 2, 4, 8};
    for (double phi_i_deg : {0.0, 60.0}) {
        for (double ti = 5; ti <= 75; ti += 10) {
            const double phi_i = deg(phi_i_deg);
            const brdf::Vec3d wi = brdf::spherical_to_cartesian(deg(ti), phi_i);
            if (phi_i_deg == 0.0) {
                for (double to = 0; to <= 85; to += 5) {
                    for (double dphi : {0.0, 45.0, 90.0, 135.0, 180.0}) {
                        dirs.emplace_back(wi,
                                          brdf::spherical_to_cartesian(deg(to), phi_i + deg(dphi)));
                    }
                }
            }
            for (double off : offsets) {
                const double to = ti + off;
                if (to >= 0 && to < 89) {
                    dirs.emplace_back(wi, brdf::spherical_to_cartesian(deg(to), phi_i + brdf::kPi));
                }
                if (off != 0) {
                    dirs.emplace_back(
                        wi, brdf::spherical_to_cartesian(deg(ti), phi_i + brdf::kPi + deg(off)));
                }
            }
        }
    }
    return dirs;
}

/// Exact model values at the given directions.
inline brdf::Dataset synthesize(const brdf::ModelD& truth,
                                const std::vector<std::pair<brdf::Vec3d, brdf::Vec3d>>& dirs) {
    brdf::Dataset d;
    d.source = "synthetic";
    for (const auto& [wi, wo] : dirs) {
        brdf::Sample s;
        const brdf::Spherical<double> si = brdf::cartesian_to_spherical(wi);
        const brdf::Spherical<double> so = brdf::cartesian_to_spherical(wo);
        s.theta_i = si.theta;
        s.phi_i = si.phi;
        s.theta_o = so.theta;
        s.phi_o = so.phi;
        s.value = brdf::eval_model(truth, s.wi(), s.wo());
        d.samples.push_back(s);
    }
    return d;
}

}  // namespace gonio::fitting::testing
