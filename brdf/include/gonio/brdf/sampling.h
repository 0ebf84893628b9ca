#pragma once

// Importance sampling of the microfacet lobes. Given wi (toward the light, above the horizon) a
// lobe sampler returns wo and the density of wo in 1/sr (solid angle), so that the estimator
// f(wi, wo) cos(theta_o) / pdf has low variance. Uniform numbers u1, u2 in [0, 1) come from the
// caller (seeded generators in tests).
//
// Sources:
// [H18] E. Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018, sec. 2
//       (listing and its derivation): visible normals of GGX, density
//       D_wi(h) = G1(wi, h) max(0, wi . h) D(h) / wi.z.
// [W07] B. Walter et al., "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007,
//       sec. 5: sampling D(h) cos(theta_h) for Beckmann (eqs. 28-29), Phong (eqs. 35-36) and GGX
//       (eqs. 35-36), and the reflection Jacobian d(wh)/d(wo) = 1 / (4 |wo . h|) (eq. 14).
// [RBMS17] M. Ribardiere et al., "STD: Student's t-Distribution of Slopes for Microfacet Based
//       BSDFs", CGF 36(2), 2017: the Student-t slope law sampled by inverting its radial CDF.
// The anisotropic Beckmann and GGX normal samplers draw the microfacet slope from its
// distribution (a Gaussian for Beckmann; the bivariate Student-like law for GGX) scaled by
// alpha_x, alpha_y, which reduces to [W07] for alpha_x = alpha_y.

#include <algorithm>
#include <cmath>

#include "gonio/brdf/model_eval.h"

namespace gonio::brdf {

/// A sampled direction and its density (1/sr). pdf == 0 means no valid sample was produced
/// (the caller counts it as a zero contribution).
struct DirectionSample {
    Vec3d w = Vec3d(0, 0, 1);
    double pdf = 0;
};

/// Reflection of w about the unit normal h: 2 (w . h) h - w.
inline Vec3d reflect(const Vec3d& w, const Vec3d& h) {
    return 2.0 * w.dot(h) * h - w;
}

/// Unit microfacet normal from a slope (slope_x, slope_y): normalize(-slope_x, -slope_y, 1).
inline Vec3d normal_from_slope(double slope_x, double slope_y) {
    return Vec3d(-slope_x, -slope_y, 1.0).normalized();
}

/// Samples h with density D_student_t(h) cos(theta_h) (1/sr). The normalised slope radius has the
/// distribution function 1 - (1 + r^2 / (gamma - 1))^(1 - gamma) (from [RBMS17]'s slope law), so
/// r = sqrt((gamma - 1) ((1 - u1)^(1 / (1 - gamma)) - 1)),
/// slope = r (alpha_x cos 2 pi u2, alpha_y sin 2 pi u2).
inline Vec3d sample_student_t_normal(
    double alpha_x, double alpha_y, double gamma, double u1, double u2) {
    const double r = std::sqrt(std::max(
        0.0, (gamma - 1) * std::expm1(std::log1p(-std::min(u1, 1 - 1e-16)) / (1 - gamma))));
    const double phi = 2 * kPi * u2;
    return normal_from_slope(r * alpha_x * std::cos(phi), r * alpha_y * std::sin(phi));
}

/// Samples h with density D_beckmann(h) cos(theta_h) (1/sr). The slope is Gaussian:
/// r = sqrt(-ln(1 - u1)), slope = r (alpha_x cos 2 pi u2, alpha_y sin 2 pi u2).
inline Vec3d sample_beckmann_normal(double alpha_x, double alpha_y, double u1, double u2) {
    const double r = std::sqrt(-std::log1p(-u1));
    const double phi = 2.0 * kPi * u2;
    return normal_from_slope(r * alpha_x * std::cos(phi), r * alpha_y * std::sin(phi));
}

/// Samples h with density D_ggx(h) cos(theta_h): slope radius r^2 = u1 / (1 - u1),
/// slope = r (alpha_x cos 2 pi u2, alpha_y sin 2 pi u2).
inline Vec3d sample_ggx_normal(double alpha_x, double alpha_y, double u1, double u2) {
    const double r = std::sqrt(u1 / (1.0 - u1));
    const double phi = 2.0 * kPi * u2;
    return normal_from_slope(r * alpha_x * std::cos(phi), r * alpha_y * std::sin(phi));
}

/// Samples h with density D_blinn_phong(h) cos(theta_h): cos(theta_h) = u1^(1/(e + 2)), phi = 2 pi
/// u2 [W07 eqs. 35-36 for the Phong distribution].
inline Vec3d sample_blinn_phong_normal(double exponent, double u1, double u2) {
    const double cos_theta = std::pow(u1, 1.0 / (exponent + 2.0));
    const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
    const double phi = 2.0 * kPi * u2;
    return Vec3d(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta);
}

/// Samples a GGX visible normal for the direction v (v.z > 0) [H18]: stretch v by (alpha_x,
/// alpha_y), sample a point on the projected hemisphere of the stretched configuration, lift it to
/// the hemisphere and unstretch. Density D_v(h) = G1(v, h) max(0, v . h) D(h) / v.z with the
/// Smith G1 of GGX. Edge behaviour: v along the normal uses the x axis as first tangent.
inline Vec3d sample_ggx_vndf(const Vec3d& v, double alpha_x, double alpha_y, double u1, double u2) {
    // Section 1: the direction in the hemisphere configuration (alpha = 1).
    const Vec3d vh = Vec3d(alpha_x * v.x(), alpha_y * v.y(), v.z()).normalized();
    // Section 2: an orthonormal basis around vh.
    const double len2 = vh.x() * vh.x() + vh.y() * vh.y();
    const Vec3d t1 = len2 > 0 ? Vec3d(-vh.y(), vh.x(), 0) / std::sqrt(len2) : Vec3d(1, 0, 0);
    const Vec3d t2(vh.y() * t1.z() - vh.z() * t1.y(),
                   vh.z() * t1.x() - vh.x() * t1.z(),
                   vh.x() * t1.y() - vh.y() * t1.x());  // vh x t1
    // Section 3: a uniform point on the disk, warped onto the visible half of the projected
    // hemisphere.
    const double r = std::sqrt(u1);
    const double phi = 2.0 * kPi * u2;
    const double p1 = r * std::cos(phi);
    double p2 = r * std::sin(phi);
    const double s = 0.5 * (1.0 + vh.z());
    p2 = (1.0 - s) * std::sqrt(std::max(0.0, 1.0 - p1 * p1)) + s * p2;
    // Section 4: reprojection onto the hemisphere.
    const Vec3d nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    // Section 5: back to the ellipsoid configuration.
    return Vec3d(alpha_x * nh.x(), alpha_y * nh.y(), std::max(0.0, nh.z())).normalized();
}

/// Density of the half vector h of sample_ggx_vndf: G1(v, h) max(0, v . h) D(h) / v.z (1/sr).
inline double pdf_ggx_vndf(const Vec3d& v, const Vec3d& h, double alpha_x, double alpha_y) {
    if (v.z() <= 0) {
        // Direction at or below the horizon: nothing is visible.
        return 0.0;
    }
    const double g1 = G1(v, h, lambda_ggx(v, alpha_x, alpha_y));
    return g1 * std::max(0.0, v.dot(h)) * D_ggx(h, alpha_x, alpha_y) / v.z();
}

/// A sample-frame direction in the frame of an anisotropic lobe (turned by Lobe::orientation_deg
/// about the normal, lobe_orientation.h), and back; the identity for an isotropic lobe.
inline Vec3d to_lobe(const Lobe<double>& lobe, const Vec3d& w) {
    if (!lobe.anisotropic) {
        return w;
    }
    Vec3d out = w;
    to_lobe_frame(w.x(), w.y(), lobe_rotation_deg(lobe.orientation_deg), out.x(), out.y());
    return out;
}
inline Vec3d from_lobe(const Lobe<double>& lobe, const Vec3d& w) {
    if (!lobe.anisotropic) {
        return w;
    }
    Vec3d out = w;
    from_lobe_frame(w.x(), w.y(), lobe_rotation_deg(lobe.orientation_deg), out.x(), out.y());
    return out;
}

/// Density of wo for sample_lobe() given wi, in 1/sr over the whole sphere of wo (it may be
/// positive below the horizon, where the BRDF is zero). h = normalize(wi + wo); GGX: D_wi(h) /
/// (4 wi . h); Beckmann and Blinn-Phong: D(h) cos(theta_h) / (4 wi . h). Zero for wi at or below
/// the horizon and for wo = -wi.
inline double pdf_lobe(const Lobe<double>& lobe, const Vec3d& wi, const Vec3d& wo) {
    if (wi.z() <= 0) {
        // No sampling from below the horizon.
        return 0.0;
    }
    const Vec3d s = wi + wo;
    const double n2 = s.squaredNorm();
    if (n2 == 0) {
        // wo = -wi: no half vector.
        return 0.0;
    }
    const Vec3d h = s / std::sqrt(n2);
    const double cos_d = wi.dot(h);
    if (cos_d <= 0) {
        // Only reachable through rounding for wo close to -wi.
        return 0.0;
    }
    const double ay = lobe_alpha_y(lobe);
    if (lobe.distribution == Distribution::kGgx) {
        // In the lobe's own frame (Lobe::orientation_deg; the identity for an isotropic lobe).
        return pdf_ggx_vndf(to_lobe(lobe, wi), to_lobe(lobe, h), lobe.alpha_x, ay) / (4.0 * cos_d);
    }
    if (lobe.distribution == Distribution::kTabulated) {
        // The table's normals are drawn by interval (sample_tabulated_normal).
        return pdf_tabulated_normal(*lobe.table, h.z()) / (4.0 * cos_d);
    }
    return lobe_D(lobe, h) * std::max(0.0, h.z()) / (4.0 * cos_d);
}

/// Samples wo for the lobe given wi: GGX by visible normals [H18], Beckmann and Blinn-Phong by
/// D(h) cos(theta_h) [W07]; wo = reflect(wi, h). The returned pdf equals pdf_lobe(lobe, wi, wo)
/// (1/sr). pdf == 0 when wi is at or below the horizon or when the sampled normal faces away from
/// wi (Beckmann, Blinn-Phong only).
inline DirectionSample sample_lobe(const Lobe<double>& lobe,
                                   const Vec3d& wi,
                                   double u1,
                                   double u2) {
    DirectionSample out;
    if (wi.z() <= 0) {
        // No sampling from below the horizon.
        return out;
    }
    const double ay = lobe_alpha_y(lobe);
    Vec3d h(0, 0, 1);
    switch (lobe.distribution) {
        case Distribution::kGgx:
            h = sample_ggx_vndf(to_lobe(lobe, wi), lobe.alpha_x, ay, u1, u2);
            break;
        case Distribution::kBeckmann:
            h = sample_beckmann_normal(lobe.alpha_x, ay, u1, u2);
            break;
        case Distribution::kBlinnPhong:
            h = sample_blinn_phong_normal(lobe.exponent, u1, u2);
            break;
        case Distribution::kStudentT:
            h = sample_student_t_normal(lobe.alpha_x, ay, lobe.gamma, u1, u2);
            break;
        case Distribution::kTabulated:
            h = sample_tabulated_normal(*lobe.table, u1, u2);
            break;
    }
    // The normal was drawn in the lobe's own frame: back to the sample's.
    h = from_lobe(lobe, h);
    if (wi.dot(h) <= 0) {
        // Normal seen from behind: no reflection toward wo (mass lost, counted by the caller).
        return out;
    }
    out.w = reflect(wi, h);
    out.pdf = pdf_lobe(lobe, wi, out.w);
    return out;
}

}  // namespace gonio::brdf
