#include "gonio/sim/instrument_errors.h"

#include <cmath>

namespace gonio::sim {

namespace {

constexpr double kDeg = brdf::kPi / 180.0;

// Streams of seeded_normal: one per kind of draw, so that no two terms share numbers.
enum Stream : std::uint64_t {
    kZeroOffset = 1,
    kAxisTilt = 2,
    kDrift = 3,
    kRepeatLight = 4,
    kRepeatDetector = 5,
    kLampFluctuation = 6,
};

std::uint64_t splitmix64(std::uint64_t x) {
    // Steele, Lea and Flood (2014), "Fast splittable pseudorandom number generators": the
    // finaliser of SplitMix64.
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

double unit_open(std::uint64_t word) {
    // (0, 1): the top 53 bits plus half a step, never 0 (the logarithm below needs it).
    return (static_cast<double>(word >> 11) + 0.5) * 0x1.0p-53;
}

}  // namespace

double seeded_normal(std::uint64_t seed, std::uint64_t stream, std::uint64_t n) {
    const std::uint64_t a = splitmix64(seed ^ splitmix64(stream ^ splitmix64(n)));
    const std::uint64_t b = splitmix64(a);
    // Box and Muller (1958): sqrt(-2 ln u1) cos(2 pi u2) is standard normal.
    return std::sqrt(-2.0 * std::log(unit_open(a))) * std::cos(2.0 * brdf::kPi * unit_open(b));
}

InstrumentErrors::InstrumentErrors(const brdf::RigErrorBudget& budget, std::uint64_t seed)
    : budget_(budget), seed_(seed) {
    for (int k = 0; k < 2; ++k) {
        const brdf::ArmErrors& a = arm_budget(static_cast<Arm>(k));
        zero_[k] = a.zero_offset_deg * kDeg * seeded_normal(seed_, kZeroOffset, k);
        tilt_[k] = a.axis_tilt_deg * kDeg * seeded_normal(seed_, kAxisTilt, k);
    }
    drift_rate_ = budget_.lamp_drift_per_hour * seeded_normal(seed_, kDrift, 0);
}

const brdf::ArmErrors& InstrumentErrors::arm_budget(Arm arm) const {
    return arm == Arm::kLight ? budget_.light_arm : budget_.detector_arm;
}

double InstrumentErrors::arm_angle(Arm arm, double angle_rad, std::uint64_t move) const {
    const int k = static_cast<int>(arm);
    const double repeat = arm_budget(arm).repeatability_deg * kDeg *
                          seeded_normal(seed_, k == 0 ? kRepeatLight : kRepeatDetector, move);
    return angle_rad + zero_[k] + repeat;
}

brdf::Vec3d InstrumentErrors::arm_direction(Arm arm, double angle_rad, std::uint64_t move) const {
    const double a = arm_angle(arm, angle_rad, move);
    return brdf::rotate_y(brdf::Vec3d(std::cos(a), std::sin(a), 0.0), tilt_[static_cast<int>(arm)]);
}

double InstrumentErrors::lamp_factor(std::uint64_t exposure, double hours) const {
    const double fluctuation =
        budget_.lamp_fluctuation * seeded_normal(seed_, kLampFluctuation, exposure);
    return (1 + drift_rate_ * hours) * (1 + fluctuation);
}

double InstrumentErrors::stray_radiance(double irradiance_w_m2) const {
    return budget_.stray_light * irradiance_w_m2 * brdf::kInvPi;
}

}  // namespace gonio::sim
