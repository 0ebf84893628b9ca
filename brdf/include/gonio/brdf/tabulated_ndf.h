#pragma once

// A data-driven isotropic microfacet distribution: D(theta_h) tabulated at nodes, with the Smith
// Lambda of that same table, as extracted from measurements by power iteration.
//
// [DHI15] J. Dupuy, E. Heitz, J.-C. Iehl, P. Poulin, V. Ostromoukhov, "Extracting
//         Microfacet-based BRDF Parameters from Arbitrary Materials with Power Iterations",
//         Computer Graphics Forum 34(4), 2015: the NDF as the eigenvector of an operator built
//         from backscattering alone, the projected area sigma(k) = int D(m) <k, m>+ dm and
//         G1(k) = cos(theta_k) / sigma(k).
// [H14]   E. Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
//         JCGT 3(2), 2014, eqs. 10 and 72: for any D normalised so that int D cos = 1, the Smith
//         Lambda(k) = sigma(k) / cos(theta_k) - 1.
// [DJ18]  J. Dupuy, W. Jakob, "An Adaptive Parameterization for Efficient Material Acquisition and
//         Rendering", ACM TOG 37(6), 2018, sec. 4: the grid u = sqrt(theta / (pi/2)), the one RGL
//         files use, so that a table and a file's ndf field share their nodes.
//
// The table: n >= 2 nodes u_k = k / (n - 1), theta_k = (pi/2) u_k^2, D linear in u between them
// (the grid is fine near the normal, where a glossy peak needs it). D is normalised over projected
// area, 2 pi int_0^{pi/2} D(theta) cos(theta) sin(theta) dtheta = 1, evaluated exactly for the
// piecewise-linear table by the quadrature of sigma below. sigma is tabulated at the same nodes
// and linear in u between them; at the normal sigma = 1, toward the horizon sigma tends to the
// projected area of the microsurface onto a grazing plane (finite), so Lambda = sigma / cos - 1
// grows as 1 / cos.
//
// Evaluation: D and sigma are looked up from the value of cos(theta) (the table is data, not a
// parameter of any fit, and no fit differentiates with respect to directions): for T = double the
// value itself, for a ceres::Jet a Jet of that value with zero derivative, for SIMD packets lane by
// lane (model_eval_packets.cpp evaluates models with a tabulated lobe so).

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/math.h"

namespace gonio::brdf {

/// Node counts the tables accept.
constexpr std::size_t kTabulatedNdfMinNodes = 2;
constexpr std::size_t kTabulatedNdfMaxNodes = 1024;

struct TabulatedNdf {
    std::vector<double> d;      ///< D at theta_k = (pi/2) (k / (n - 1))^2, 1/sr, >= 0.
    std::vector<double> sigma;  ///< Projected area sigma(theta_k) of the normalised D, >= cos.
};

/// theta of node k of an n-node table, radians: (pi/2) (k / (n - 1))^2.
double tabulated_ndf_theta(std::size_t k, std::size_t n);

/// int_0^{2 pi} max(0, a + b cos(phi)) dphi for b >= 0: the azimuthal part of <w, m>+ with
/// a = cos(theta) cos(theta_m), b = sin(theta) sin(theta_m). Closed form: 2 pi a when the circle
/// lies wholly on the positive side (b <= a), 0 when wholly on the negative side (b <= -a), else
/// 2 (a phi0 + sqrt(b^2 - a^2)) with phi0 = acos(-a / b).
double azimuthal_cosine(double a, double b);

/// The linear map of the n node values of D (hat functions in u) to sigma at the n nodes,
/// row-major n x n: sigma(theta_j) = sum_k K[j n + k] D_k. Midpoint quadrature in u with 16
/// sub-intervals per grid interval (d omega = pi u sin(theta) du dphi); its error is below 1e-4
/// relative for the peaks of GGX and Beckmann with alpha >= 0.03 on 64 nodes (tests check it
/// against the closed forms).
std::vector<double> tabulated_ndf_sigma_matrix(std::size_t n);

/// sigma at the nodes for node values d through K (tabulated_ndf_sigma_matrix(d.size())).
std::vector<double> tabulated_ndf_sigma(const std::vector<double>& K, const std::vector<double>& d);

/// A table from node values: checked (n within the node counts, every value finite and >= 0, not
/// all 0), normalised so that sigma(normal) = int D cos = 1, with sigma. Errors name `where`.
Expected<TabulatedNdf> make_tabulated_ndf(std::vector<double> d, const std::string& where);

/// Position of cos(theta) in the table: the interval index k (node k to k + 1) and the weight t of
/// node k + 1, for cos_theta in [0, 1] (clamped to it).
inline void tabulated_ndf_locate(double cos_theta, std::size_t n, std::size_t* k, double* t) {
    const double c = cos_theta < 0.0 ? 0.0 : (cos_theta > 1.0 ? 1.0 : cos_theta);
    // theta = atan2(sin, cos) keeps its accuracy near the normal, where acos(cos) does not.
    const double theta = std::atan2(std::sqrt((1.0 - c) * (1.0 + c)), c);
    const double x = std::sqrt(theta * (2.0 / kPi)) * static_cast<double>(n - 1);
    std::size_t i = static_cast<std::size_t>(x);
    if (i >= n - 1) {
        // At the horizon (theta = pi/2): the last node.
        i = n - 2;
    }
    *k = i;
    *t = x - static_cast<double>(i);
}

/// Piecewise-linear lookup of node values v at cos(theta).
inline double tabulated_ndf_lookup(const std::vector<double>& v, double cos_theta) {
    std::size_t k = 0;
    double t = 0.0;
    tabulated_ndf_locate(cos_theta, v.size(), &k, &t);
    return v[k] + t * (v[k + 1] - v[k]);
}

/// D(h) of the table, 1/sr, from h_z = cos(theta_h) of a unit h (through its value; see the file
/// comment). Edge behaviour: 0 for h_z <= 0 (microfacet normals face outward).
template <class T>
inline T D_tabulated(const TabulatedNdf& table, const T& h_z) {
    const double c = value_of(h_z);
    if (!(c > 0.0)) {
        // Outward normals only.
        return T(0);
    }
    return T(tabulated_ndf_lookup(table.d, c));
}

/// Smith Lambda of the table for a direction with w_z = cos(theta) of a unit w [H14]:
/// sigma(theta) / cos(theta) - 1, clamped at 0 (sigma >= cos holds for a normalised D; the
/// interpolation can undercut it by rounding). Edge behaviour: +infinity for w_z <= 0 (masked).
template <class T>
inline T lambda_tabulated(const TabulatedNdf& table, const T& w_z) {
    const double c = value_of(w_z);
    if (!(c > 0.0)) {
        // At or below the horizon: masked.
        return T(std::numeric_limits<double>::infinity());
    }
    const double lambda = tabulated_ndf_lookup(table.sigma, c) / c - 1.0;
    return T(lambda > 0.0 ? lambda : 0.0);
}

/// Density over solid angle with which sample_tabulated_normal draws h: D cos(theta_h) averaged
/// over each grid interval (uniform in cos(theta) and phi within it), 1/sr. It equals D cos to
/// within the variation of D over one interval and integrates to 1 exactly.
double pdf_tabulated_normal(const TabulatedNdf& table, double cos_theta_h);

/// Draws a microfacet normal with pdf_tabulated_normal from two uniform numbers in [0, 1).
Vec3d sample_tabulated_normal(const TabulatedNdf& table, double u1, double u2);

}  // namespace gonio::brdf
