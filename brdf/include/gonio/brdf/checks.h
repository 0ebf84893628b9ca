#pragma once

// Property checks usable on any BRDF (analytic models, tables, measurements): non-negativity and
// finiteness, reciprocity, isotropy and energy conservation. Each returns the worst violation it
// found, where, and whether that stays within a tolerance. The direction sets are seeded
// random directions (uniform over the hemisphere's area) plus fixed edge directions: the normal,
// 1e-6 rad off it, 89.999 degrees, exactly at the horizon, wi = wo and mirror pairs.

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/brdf/brdf.h"

namespace gonio::brdf {

struct CheckOptions {
    std::uint64_t seed = 20261122;        ///< Seed of the random direction pairs.
    int random_pairs = 20000;             ///< Random (wi, wo) pairs per check.
    double reciprocity_tolerance = 1e-6;  ///< Largest relative difference accepted.
    double isotropy_tolerance = 1e-6;     ///< Largest relative difference accepted.
    double energy_tolerance = 2e-3;       ///< Largest directional albedo accepted is 1 + this.
    int quadrature_theta = 256;  ///< Albedo quadrature: steps in theta_h (concentrated near 0).
    int quadrature_phi = 128;    ///< Albedo quadrature: steps in phi_h.
};

struct CheckResult {
    std::string name;        ///< "non-negativity", "reciprocity", "isotropy", "energy".
    double violation = 0;    ///< Worst violation found, >= 0 (inf for a non-finite value).
    double tolerance = 0;    ///< Violations up to this pass.
    std::string measure;     ///< What violation measures ("relative difference").
    std::string where;       ///< Directions (degrees) or angle of the worst case.
    std::string detail;      ///< Extra facts (max albedo and where).
    bool applicable = true;  ///< False when the property is not claimed (isotropy of an
                             ///< anisotropic BRDF); such a check always passes.
    bool passed = true;
    std::size_t evaluations = 0;  ///< BRDF evaluations made.
};

/// Every value finite and >= 0 over the direction set (including below-horizon directions, where
/// the value must also be finite and >= 0). violation = -(most negative value), inf if non-finite.
CheckResult check_non_negativity(const Brdf& brdf, const CheckOptions& options = {});

/// f(wi, wo) = f(wo, wi): violation = max |a - b| / (max(|a|, |b|) + 1e-8 / sr).
CheckResult check_reciprocity(const Brdf& brdf, const CheckOptions& options = {});

/// f(R wi, R wo) = f(wi, wo) for rotations R about the normal (random angles): same measure.
/// Not applicable (passes) when brdf.isotropic() is false.
CheckResult check_isotropy(const Brdf& brdf, const CheckOptions& options = {});

/// Directional albedo a(wi) = integral of f(wi, wo) cos(theta_o) d(wo) <= 1 per channel (white
/// furnace), over theta_i in {0, 10, ..., 80, 85, 89} degrees at phi_i in {0, 45, 90} degrees
/// (only 0 for an isotropic BRDF). violation = max(0, max albedo - 1).
CheckResult check_energy_conservation(const Brdf& brdf, const CheckOptions& options = {});

/// Directional albedo by quadrature over the half vector: wo = 2 (wi . h) h - wi, d(wo) =
/// 4 (wi . h) d(h), with theta_h = (pi/2) s^3 (s uniform, midpoint rule) so that the steps are
/// finest near the normal where sharp lobes peak, and phi_h uniform. wi above the horizon.
Rgbd directional_albedo(const Brdf& brdf, const Vec3d& wi, int n_theta, int n_phi);

/// The four checks in order.
std::vector<CheckResult> run_checks(const Brdf& brdf, const CheckOptions& options = {});

/// True when every result passed.
bool all_passed(const std::vector<CheckResult>& results);

/// A fixed-width table, one line per check, with a header line.
std::string format_check_table(const std::vector<CheckResult>& results);

}  // namespace gonio::brdf
