#pragma once

// Synthetic measurements for the fitting tests: a goniometer-like angular grid and exact model
// values on it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
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

/// The sigma a noisy dataset states for each value (Dataset::has_sigma).
enum class StatedSigma {
    kNone,        ///< No sigma column.
    kOfTruth,     ///< sqrt((relative v)^2 + absolute^2) of the true value v: the noise itself.
    kOfMeasured,  ///< relative times the measured value: what a user who knows only the relative
                  ///< noise writes.
};

/// Measurement noise: Gaussian, relative to the value and absolute.
struct Noise {
    double relative = 0.02;
    double absolute = 0;
    StatedSigma sigma = StatedSigma::kNone;
};

/// `data` with seeded noise on every channel of every value, as a measurement adds it: v becomes
/// max(0, v (1 + relative n1) + absolute n2) with n1, n2 standard normal draws from one
/// mt19937_64 seeded with `seed` (n2 drawn only when absolute > 0), channel by channel and sample
/// by sample in order, so that a seed names one dataset.
inline brdf::Dataset with_noise(brdf::Dataset data, std::uint64_t seed, const Noise& noise) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01(0.0, 1.0);
    data.has_sigma = noise.sigma != StatedSigma::kNone;
    for (brdf::Sample& s : data.samples) {
        for (int c = 0; c < 3; ++c) {
            const double v = s.value[c];
            const double n1 = n01(rng);
            const double n2 = noise.absolute > 0 ? n01(rng) : 0.0;
            s.value[c] = std::max(0.0, v * (1 + noise.relative * n1) + noise.absolute * n2);
            switch (noise.sigma) {
                case StatedSigma::kNone:
                    s.sigma[c] = 0.0;
                    break;
                case StatedSigma::kOfTruth:
                    s.sigma[c] = std::sqrt(noise.relative * v * noise.relative * v +
                                           noise.absolute * noise.absolute);
                    break;
                case StatedSigma::kOfMeasured:
                    s.sigma[c] = noise.relative * s.value[c];
                    break;
            }
        }
    }
    return data;
}

/// Exact model values on measurement_grid() with `noise` drawn from `seed`.
inline brdf::Dataset noisy_measurement(const brdf::ModelD& truth,
                                       std::uint64_t seed,
                                       const Noise& noise = {}) {
    return with_noise(synthesize(truth, measurement_grid()), seed, noise);
}

}  // namespace gonio::fitting::testing
