#include "gonio/brdf/exposure_path.h"

#include <algorithm>
#include <cmath>

#include "gonio/base/check.h"

namespace gonio::brdf {

void gauss_legendre_unit(int n, double* x, double* w) {
    GONIO_CHECK(n >= 1 && n <= 64);
    // Roots of the Legendre polynomial P_n by Newton's method from Tricomi's estimate, the
    // weights 2 / ((1 - z^2) P_n'(z)^2); then mapped from [-1, 1] to [0, 1].
    for (int i = 0; i < (n + 1) / 2; ++i) {
        double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double dp = 1;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1;
            double p1 = z;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            if (n == 1) {
                p0 = 1;
            }
            dp = n * (z * p1 - p0) / (z * z - 1);
            const double dz = p1 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-16) {
                break;
            }
        }
        if (n == 1) {
            z = 0;
            dp = 1;
        }
        const double weight = n == 1 ? 2.0 : 2 / ((1 - z * z) * dp * dp);
        x[i] = 0.5 * (1 - z);
        x[n - 1 - i] = 0.5 * (1 + z);
        w[i] = w[n - 1 - i] = 0.5 * weight;
    }
}

Vec3d slerp_direction(const Vec3d& a, const Vec3d& b, double u) {
    const double c = std::clamp(a.dot(b), -1.0, 1.0);
    const double g = std::acos(c);
    if (g < 1e-9) {
        return ((1 - u) * a + u * b).normalized();
    }
    const double s = std::sin(g);
    return (std::sin((1 - u) * g) / s) * a + (std::sin(u * g) / s) * b;
}

std::vector<PathNode> exposure_path_nodes(const Vec3d& wi0,
                                          const Vec3d& wo0,
                                          const Vec3d& wi1,
                                          const Vec3d& wo1,
                                          double max_piece_rad,
                                          int per_piece,
                                          int max_pieces) {
    GONIO_CHECK(max_piece_rad > 0 && per_piece >= 1 && per_piece <= 64 && max_pieces >= 1);
    const double arc_i = std::acos(std::clamp(wi0.dot(wi1), -1.0, 1.0));
    const double arc_o = std::acos(std::clamp(wo0.dot(wo1), -1.0, 1.0));
    const double arc = std::max(arc_i, arc_o);
    const int pieces = std::clamp(static_cast<int>(std::ceil(arc / max_piece_rad)), 1, max_pieces);
    double x[64];
    double w[64];
    gauss_legendre_unit(per_piece, x, w);
    std::vector<PathNode> nodes;
    nodes.reserve(static_cast<std::size_t>(pieces) * per_piece);
    for (int p = 0; p < pieces; ++p) {
        for (int k = 0; k < per_piece; ++k) {
            const double u = (p + x[k]) / pieces;
            nodes.push_back(PathNode{
                slerp_direction(wi0, wi1, u), slerp_direction(wo0, wo1, u), w[k] / pieces});
        }
    }
    return nodes;
}

}  // namespace gonio::brdf
