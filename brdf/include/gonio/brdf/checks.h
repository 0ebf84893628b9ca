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
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {

struct CheckOptions {
    std::uint64_t seed = 20261122;        ///< Seed of the random direction pairs.
    int random_pairs = 20000;             ///< Random (wi, wo) pairs per check.
    double reciprocity_tolerance = 1e-6;  ///< Largest relative difference accepted.
    double isotropy_tolerance = 1e-6;     ///< Largest relative difference accepted.
    double energy_tolerance = 2e-3;       ///< Largest directional albedo accepted is 1 + this.
    int quadrature_theta = 256;  ///< Albedo quadrature: steps in theta_h (concentrated near 0).
    int quadrature_phi = 128;    ///< Albedo quadrature: steps in phi_h.

    // Tables (TabulatedBrdf). Two lookups of one table that should agree (reciprocity, isotropy)
    // may land in neighbouring bins through rounding, and a measured table carries noise, so a
    // table is held to its own resolution and noise instead of the relative tolerances above:
    //   |a_c - b_c| <= spread_c + noise_sigmas * sqrt(sigma_a,c^2 + sigma_b,c^2)
    // with spread_c the largest difference between the bins holding a and b and their 26
    // neighbours (one bin step on each axis, phi_d periodic), sigma from bin_sigma or
    // noise_relative. The violation is the largest ratio of the difference to that allowance
    // (tolerance 1). Pairs where either lookup falls in an unmeasured bin are skipped and counted.
    /// Stated relative noise (one standard deviation) of every table value; 0 = none stated.
    double noise_relative = 0;
    /// Stated per-bin standard deviations (1/sr, flat index of the table grid); empty = none.
    std::vector<Rgbd> bin_sigma;
    /// Multiple of the combined standard deviation a difference may reach.
    double noise_sigmas = 4;
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
    std::size_t skipped = 0;  ///< Pairs not compared (unmeasured table bins, unmatched samples).
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

/// Checks of a measured dataset (samples with their one-sigma uncertainties), with no random
/// choice: non-negativity (every value >= -k sigma), reciprocity (pairs measured with theta_i and
/// theta_o swapped at the same |delta_phi|) and isotropy (pairs at the same theta_i, theta_o,
/// |delta_phi| but another phi_i), each pair matched within match_tolerance_deg on every angle.
/// A pair's measure is z = max_c |a_c - b_c| / sqrt(sigma_a,c^2 + sigma_b,c^2 +
/// (relative_floor max(a_c, b_c))^2); it passes when the largest z stays at or below k, where k is
/// the two-sided normal quantile for which the chance that any of the n compared pairs exceeds it
/// by noise alone is false_alarm (Bonferroni): P(|z| > k) = false_alarm / n. Energy needs an
/// integral over directions and is reported as not applicable.
struct DatasetCheckOptions {
    double match_tolerance_deg = 0.5;
    double relative_floor = 1e-3;  ///< Relative uncertainty assumed besides the stated sigma.
    double false_alarm = 1e-6;
};
std::vector<CheckResult> check_dataset(const Dataset& data,
                                       const DatasetCheckOptions& options = {});

/// The k of DatasetCheckOptions for n comparisons: the two-sided normal quantile with tail
/// probability false_alarm / n (at least 3).
double bonferroni_threshold(std::size_t n, double false_alarm);

/// Per-bin standard deviations of a table from a dataset whose samples are the table's bins (an
/// image-mode campaign's dataset.csv: one sample per measured bin, with sigma): each sample's
/// (theta_h, theta_d, phi_d) bin gets its sigma. Bins without a sample get zero.
std::vector<Rgbd> bin_sigma_from_dataset(const TableGrid& grid, const Dataset& data);

/// True when every result passed.
bool all_passed(const std::vector<CheckResult>& results);

/// A fixed-width table, one line per check, with a header line.
std::string format_check_table(const std::vector<CheckResult>& results);

}  // namespace gonio::brdf
