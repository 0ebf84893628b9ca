// The packet instantiation of every formula against the scalar one. The bodies are the same
// templates; the packets evaluate sqrt, division and the arithmetic with the same IEEE operations
// in the same order, and exp, erfc and log1p with xsimd's vectorised functions instead of the C
// library's. Tolerances, in units in the last place (ulp) of the scalar result:
//   - formulas of arithmetic and sqrt only (GGX D and Lambda, the G forms, Schlick, the exact
//     dielectric and conductor, Lambert): kExactUlp = 1 (each lane rounds like the scalar code: the
//     packet files are compiled with -ffp-contract=off, so no product and sum is fused where the
//     baseline code rounds twice);
//   - formulas through exp, erfc or log1p (Beckmann D and Lambda, Blinn-Phong D, the whole model
//     with them): kTranscendentalUlp = 16, or a relative error of kRelativeFloor = 700 * 2^-52 (an
//     argument error of 1 ulp in e is amplified by |e| <= 700 in exp(-e));
//   - Beckmann's Lambda, (exp(-a^2)/(a sqrt(pi)) - erfc(a))/2, cancels by a factor of about 2 a^2
//     for large a, and xsimd's erfc is less accurate than the C library's in its tail (relative
//     error up to 6e-9 near a = 26, measured against long double), so where Lambda is small the
//     two differ by more than the above in relative terms. Against long double both keep Lambda's
//     absolute error below 2e-14 for a in [0.001, 26] (measured), so the packet Lambda is held to
//     an absolute kLambdaAbsolute = 1e-14 of the scalar one; G = 1/(1 + Lambda_i + Lambda_o)
//     inherits that absolute bound;
//   - magnitudes below kUnderflow = 1e-300 count as 0 (xsimd's exp returns 0 below the normal
//     range where the C library returns subnormals).
// Grids are seeded and include the edges: grazing directions (theta = pi/2 and 1e-9 below it), the
// normal (theta_h = 0, wi = wo = z), alpha at the fit's bounds [1e-4, 1.5], wi = -wo and
// directions below the horizon.

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_eval_packets.h"

namespace gonio::brdf {
namespace {

using B = xsimd::batch<double>;
constexpr std::size_t kLanes = B::size;
constexpr double kExactUlp = 1;
constexpr double kTranscendentalUlp = 16;
constexpr double kRelativeFloor = 700 * 2.220446049250313e-16;
constexpr double kUnderflow = 1e-300;
constexpr double kLambdaAbsolute = 1e-14;

/// Distance in ulp between two doubles of the same sign (0 when both are equal or both NaN).
double ulp_distance(double a, double b) {
    if (a == b || (std::isnan(a) && std::isnan(b))) {
        return 0;
    }
    if (!std::isfinite(a) || !std::isfinite(b) || (a < 0) != (b < 0)) {
        return std::numeric_limits<double>::infinity();
    }
    std::int64_t ia, ib;
    std::memcpy(&ia, &a, sizeof a);
    std::memcpy(&ib, &b, sizeof b);
    return static_cast<double>(ia > ib ? ia - ib : ib - ia);
}

/// True when packet and scalar agree within `ulp`, or (for relative > 0) within that relative
/// error, or (for absolute > 0) within that absolute error. Magnitudes below kUnderflow count as 0.
bool agrees(double packet, double scalar, double ulp, double relative = 0, double absolute = 0) {
    if (ulp_distance(packet, scalar) <= ulp) {
        return true;
    }
    if (std::abs(packet) < kUnderflow && std::abs(scalar) < kUnderflow) {
        return true;
    }
    const double diff = std::abs(packet - scalar);
    return (relative > 0 && diff <= relative * std::abs(scalar)) ||
           (absolute > 0 && diff <= absolute);
}

/// Unit directions: edges first, then seeded random ones.
std::vector<Vec3d> directions(std::uint32_t seed, int random_count) {
    std::vector<Vec3d> out;
    const double grazing = kPi / 2;
    for (double theta : {0.0, 1e-8, 0.3, 1.0, 1.4, grazing - 1e-9, grazing, grazing + 0.2}) {
        for (double phi : {0.0, 0.7, 2.0, -2.9}) {
            out.push_back(spherical_to_cartesian(theta, phi));
        }
    }
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < random_count; ++k) {
        out.push_back(spherical_to_cartesian(std::acos(u(rng)), 2 * kPi * u(rng)));
    }
    return out;
}

const double kAlphaGrid[] = {1e-4, 2e-3, 0.05, 0.3, 1.0, 1.5};

/// Evaluates f on packets filled lane by lane from the scalar arguments, returns the lanes.
template <class F>
std::vector<double> packet_values(const std::vector<std::vector<double>>& args, F f) {
    const std::size_t n = args.size();
    std::vector<double> out(n);
    for (std::size_t base = 0; base < n; base += kLanes) {
        const std::size_t arity = args[0].size();
        std::vector<B> packed(arity);
        for (std::size_t a = 0; a < arity; ++a) {
            alignas(64) double lanes[kLanes];
            for (std::size_t l = 0; l < kLanes; ++l) {
                // The last packet repeats the last argument set in its spare lanes.
                lanes[l] = args[std::min(base + l, n - 1)][a];
            }
            packed[a] = B::load_aligned(lanes);
        }
        alignas(64) double res[kLanes];
        f(packed).store_aligned(res);
        for (std::size_t l = 0; l < kLanes && base + l < n; ++l) {
            out[base + l] = res[l];
        }
    }
    return out;
}

/// Checks the packet instantiation of a formula of `arity` arguments against the scalar one.
template <class Scalar, class Packet>
void expect_agreement(const char* name,
                      const std::vector<std::vector<double>>& args,
                      Scalar scalar,
                      Packet packet,
                      double ulp,
                      double relative = 0,
                      double absolute = 0) {
    const std::vector<double> p = packet_values(args, packet);
    int failures = 0;
    for (std::size_t k = 0; k < args.size(); ++k) {
        const double s = scalar(args[k]);
        if (!agrees(p[k], s, ulp, relative, absolute) && ++failures <= 5) {
            ADD_FAILURE() << name << " case " << k << ": packet " << p[k] << " scalar " << s << " ("
                          << ulp_distance(p[k], s) << " ulp)";
        }
    }
    EXPECT_EQ(failures, 0) << name << ": " << failures << " of " << args.size() << " disagree";
}

/// Half vectors of direction pairs (wi + wo normalised), plus h = z; pairs with wi = -wo are left
/// out (no half vector).
std::vector<Vec3d> half_vectors(const std::vector<Vec3d>& dirs) {
    std::vector<Vec3d> out{Vec3d(0, 0, 1)};
    for (std::size_t i = 0; i < dirs.size(); i += 3) {
        for (std::size_t j = 0; j < dirs.size(); j += 5) {
            const Vec3d s = dirs[i] + dirs[j];
            if (s.norm() > 1e-12) {
                out.push_back(s.normalized());
            }
        }
    }
    return out;
}

TEST(PacketFormulas, MicrofacetDistributionsAgreeWithScalar) {
    const std::uint32_t seed = 20261201;
    SCOPED_TRACE(testing::Message() << "seed " << seed);
    const std::vector<Vec3d> hs = half_vectors(directions(seed, 200));
    std::vector<std::vector<double>> args;
    for (const Vec3d& h : hs) {
        for (double ax : kAlphaGrid) {
            for (double ay : {ax, 0.3}) {
                args.push_back({h.x(), h.y(), h.z(), ax, ay});
            }
        }
    }
    auto vec = [](const std::vector<double>& a) { return Vec3d(a[0], a[1], a[2]); };
    auto bvec = [](const std::vector<B>& a) { return Vec3<B>(a[0], a[1], a[2]); };
    expect_agreement(
        "D_ggx",
        args,
        [&](const std::vector<double>& a) { return D_ggx(vec(a), a[3], a[4]); },
        [&](const std::vector<B>& a) { return D_ggx(bvec(a), a[3], a[4]); },
        kExactUlp);
    expect_agreement(
        "D_beckmann",
        args,
        [&](const std::vector<double>& a) { return D_beckmann(vec(a), a[3], a[4]); },
        [&](const std::vector<B>& a) { return D_beckmann(bvec(a), a[3], a[4]); },
        kTranscendentalUlp,
        kRelativeFloor);
    expect_agreement(
        "D_blinn_phong",
        args,
        [&](const std::vector<double>& a) { return D_blinn_phong(vec(a), 2 / (a[3] * a[3])); },
        [&](const std::vector<B>& a) { return D_blinn_phong(bvec(a), B(2) / (a[3] * a[3])); },
        kTranscendentalUlp,
        kRelativeFloor);
}

TEST(PacketFormulas, SmithLambdaAndGAgreeWithScalar) {
    const std::uint32_t seed = 7;
    SCOPED_TRACE(testing::Message() << "seed " << seed);
    const std::vector<Vec3d> ws = directions(seed, 300);
    std::vector<std::vector<double>> args;
    for (std::size_t k = 0; k < ws.size(); ++k) {
        const Vec3d& w = ws[k];
        const Vec3d& v = ws[(k * 7 + 3) % ws.size()];
        for (double ax : kAlphaGrid) {
            for (double ay : {ax, 0.05}) {
                args.push_back({w.x(), w.y(), w.z(), ax, ay, v.x(), v.y(), v.z()});
            }
        }
    }
    auto vec = [](const std::vector<double>& a, int o) { return Vec3d(a[o], a[o + 1], a[o + 2]); };
    auto bvec = [](const std::vector<B>& a, int o) { return Vec3<B>(a[o], a[o + 1], a[o + 2]); };
    expect_agreement(
        "lambda_ggx",
        args,
        [&](const std::vector<double>& a) { return lambda_ggx(vec(a, 0), a[3], a[4]); },
        [&](const std::vector<B>& a) { return lambda_ggx(bvec(a, 0), a[3], a[4]); },
        kExactUlp);
    expect_agreement(
        "lambda_beckmann",
        args,
        [&](const std::vector<double>& a) { return lambda_beckmann(vec(a, 0), a[3], a[4]); },
        [&](const std::vector<B>& a) { return lambda_beckmann(bvec(a, 0), a[3], a[4]); },
        kTranscendentalUlp,
        kRelativeFloor,
        kLambdaAbsolute);
    for (bool correlated : {true, false}) {
        expect_agreement(
            correlated ? "G_smith_correlated" : "G_smith_separable",
            args,
            [&](const std::vector<double>& a) {
                const double li = lambda_ggx(vec(a, 0), a[3], a[4]);
                const double lo = lambda_ggx(vec(a, 5), a[3], a[4]);
                return correlated ? G_smith_correlated(li, lo) : G_smith_separable(li, lo);
            },
            [&](const std::vector<B>& a) {
                const B li = lambda_ggx(bvec(a, 0), a[3], a[4]);
                const B lo = lambda_ggx(bvec(a, 5), a[3], a[4]);
                return correlated ? G_smith_correlated(li, lo) : G_smith_separable(li, lo);
            },
            kExactUlp);
    }
    // V-groove from the cosines of the configuration (h and the cosines computed once in double,
    // wi = -wo giving cos_d = 0).
    std::vector<std::vector<double>> cosines;
    for (const std::vector<double>& a : args) {
        const Vec3d wi = vec(a, 0), wo = vec(a, 5);
        const Vec3d s = wi + wo;
        const Vec3d h = s.norm() > 0 ? Vec3d(s.normalized()) : Vec3d(0, 0, 1);
        cosines.push_back({h.z(), wi.z(), wo.z(), s.norm() > 0 ? wo.dot(h) : 0.0});
    }
    expect_agreement(
        "G_vgroove_from_cosines",
        cosines,
        [](const std::vector<double>& a) { return G_vgroove_from_cosines(a[0], a[1], a[2], a[3]); },
        [](const std::vector<B>& a) { return G_vgroove_from_cosines(a[0], a[1], a[2], a[3]); },
        kExactUlp);
}

TEST(PacketFormulas, FresnelAndLambertAgreeWithScalar) {
    std::vector<std::vector<double>> args;
    const std::uint32_t seed = 99;
    SCOPED_TRACE(testing::Message() << "seed " << seed);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<double> cosines{
        -1.0, -0.5, -1e-9, 0.0, 1e-9, 1e-3, 0.5, 1 - 1e-12, 1.0, 1.0 + 1e-15};
    for (int k = 0; k < 100; ++k) {
        cosines.push_back(2 * u(rng) - 1);
    }
    for (double c : cosines) {
        for (double eta : {0.5, 1.0, 1.0 + 1e-12, 1.5, 2.4}) {
            for (double k : {0.0, 1e-6, 0.5, 3.9}) {
                args.push_back({c, eta, k, 0.04 + 0.9 * u(rng)});
            }
        }
    }
    expect_agreement(
        "fresnel_schlick",
        args,
        [](const std::vector<double>& a) { return fresnel_schlick(a[0], a[3]); },
        [](const std::vector<B>& a) { return fresnel_schlick(a[0], a[3]); },
        kExactUlp);
    expect_agreement(
        "fresnel_dielectric",
        args,
        [](const std::vector<double>& a) { return fresnel_dielectric(a[0], a[1]); },
        [](const std::vector<B>& a) { return fresnel_dielectric(a[0], a[1]); },
        kExactUlp);
    expect_agreement(
        "fresnel_conductor",
        args,
        [](const std::vector<double>& a) { return fresnel_conductor(a[0], a[1], a[2]); },
        [](const std::vector<B>& a) { return fresnel_conductor(a[0], a[1], a[2]); },
        kExactUlp);
    expect_agreement(
        "lambert",
        args,
        [](const std::vector<double>& a) { return lambert_from_cosines(a[3], a[0], a[1] - 1); },
        [](const std::vector<B>& a) { return lambert_from_cosines(a[3], a[0], a[1] - B(1)); },
        kExactUlp);
}

/// Every structure of the model (distribution x shadowing x Fresnel), isotropic and anisotropic.
std::vector<ModelD> model_structures() {
    std::vector<ModelD> out;
    for (Distribution d :
         {Distribution::kGgx, Distribution::kBeckmann, Distribution::kBlinnPhong}) {
        for (Shadowing s : {Shadowing::kSmithCorrelated,
                            Shadowing::kSmithSeparable,
                            Shadowing::kVGroove,
                            Shadowing::kNone}) {
            for (FresnelType f : {FresnelType::kNone,
                                  FresnelType::kSchlick,
                                  FresnelType::kDielectric,
                                  FresnelType::kConductor}) {
                for (double alpha : {1e-4, 0.2, 1.5}) {
                    ModelD m;
                    m.diffuse = Rgbd(0.1, 0.2, 0.3);
                    Lobe<double> l;
                    l.distribution = d;
                    l.shadowing = s;
                    l.fresnel.type = f;
                    l.fresnel.eta_rgb = Rgbd(0.2, 0.9, 1.1);
                    l.fresnel.k = Rgbd(3.1, 2.4, 0.0);
                    l.alpha_x = alpha;
                    l.alpha_y = 0.3;
                    l.anisotropic = alpha == 0.2;
                    l.exponent = 2 / (alpha * alpha) - 2 + 1;
                    l.scale = Rgbd(1.0, 0.5, 2.0);
                    m.lobes.push_back(l);
                    out.push_back(m);
                }
            }
        }
    }
    return out;
}

TEST(PacketFormulas, WholeModelAgreesWithScalarIncludingHorizonAndOppositeDirections) {
    const std::uint32_t seed = 4242;
    SCOPED_TRACE(testing::Message() << "seed " << seed);
    const std::vector<Vec3d> dirs = directions(seed, 40);
    std::vector<std::vector<double>> args;
    for (std::size_t i = 0; i < dirs.size(); ++i) {
        for (std::size_t j = 0; j < dirs.size(); j += 3) {
            const Vec3d& wi = dirs[i];
            const Vec3d& wo = dirs[(i + j) % dirs.size()];
            args.push_back({wi.x(), wi.y(), wi.z(), wo.x(), wo.y(), wo.z()});
        }
        // wi = -wo (no half vector) and wi = wo.
        args.push_back(
            {dirs[i].x(), dirs[i].y(), dirs[i].z(), -dirs[i].x(), -dirs[i].y(), -dirs[i].z()});
        args.push_back(
            {dirs[i].x(), dirs[i].y(), dirs[i].z(), dirs[i].x(), dirs[i].y(), dirs[i].z()});
    }
    for (const ModelD& m : model_structures()) {
        const Lobe<double>& l = m.lobes[0];
        // Beckmann (exp, erfc) and Blinn-Phong (exp, log1p, and Beckmann's Lambda) go through
        // transcendental functions; GGX with any G and Fresnel is arithmetic and sqrt.
        const bool transcendental = l.distribution != Distribution::kGgx;
        for (int c = 0; c < 3; ++c) {
            const std::string name = std::string(to_string(l.distribution)) + "/" +
                                     to_string(l.shadowing) + "/" + to_string(l.fresnel.type) +
                                     " alpha " + std::to_string(l.alpha_x) + " channel " +
                                     std::to_string(c);
            expect_agreement(
                name.c_str(),
                args,
                [&](const std::vector<double>& a) {
                    return eval_model(m, Vec3d(a[0], a[1], a[2]), Vec3d(a[3], a[4], a[5]))[c];
                },
                [&](const std::vector<B>& a) {
                    B out[3];
                    eval_model_lanes(m, Dir3<B>{a[0], a[1], a[2]}, Dir3<B>{a[3], a[4], a[5]}, out);
                    return out[c];
                },
                transcendental ? kTranscendentalUlp : kExactUlp,
                transcendental ? kRelativeFloor : 0);
        }
    }
}

TEST(PacketFormulas, DispatchedPacketsAgreeWithScalar) {
    // eval_model_packets on the widest instruction set this processor offers, over the same
    // structures and direction pairs, with a length that leaves a partial last packet.
    const std::uint32_t seed = 77;
    SCOPED_TRACE(testing::Message() << "seed " << seed << ", " << packet_instruction_set());
    const std::vector<Vec3d> dirs = directions(seed, 30);
    std::vector<double> c[6];
    for (std::size_t i = 0; i < dirs.size(); ++i) {
        for (std::size_t j = 0; j < dirs.size(); j += 2) {
            const Vec3d& wi = dirs[i];
            const Vec3d wo = j == 0 ? Vec3d(-wi) : dirs[(i + j) % dirs.size()];
            for (int a = 0; a < 3; ++a) {
                c[a].push_back(wi[a]);
                c[3 + a].push_back(wo[a]);
            }
        }
    }
    const std::size_t n = c[0].size() - 1;
    ASSERT_NE(n % 8, 0u);
    const DirectionPairs pairs{
        c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data(), c[5].data()};
    std::vector<double> out[3];
    for (std::vector<double>& o : out) {
        o.assign(n + 1, -7.0);
    }
    double* const outp[3] = {out[0].data(), out[1].data(), out[2].data()};
    for (const ModelD& m : model_structures()) {
        const Lobe<double>& l = m.lobes[0];
        // Beckmann (exp, erfc) and Blinn-Phong (exp, log1p, and Beckmann's Lambda) go through
        // transcendental functions; GGX with any G and Fresnel is arithmetic and sqrt.
        const bool transcendental = l.distribution != Distribution::kGgx;
        eval_model_packets(m, n, pairs, outp);
        int failures = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const Rgbd f =
                eval_model(m, Vec3d(c[0][k], c[1][k], c[2][k]), Vec3d(c[3][k], c[4][k], c[5][k]));
            for (int ch = 0; ch < 3; ++ch) {
                const bool ok = agrees(out[ch][k],
                                       f[ch],
                                       transcendental ? kTranscendentalUlp : kExactUlp,
                                       transcendental ? kRelativeFloor : 0);
                if (!ok && ++failures <= 3) {
                    ADD_FAILURE() << to_string(l.distribution) << "/" << to_string(l.shadowing)
                                  << "/" << to_string(l.fresnel.type) << " alpha " << l.alpha_x
                                  << " pair " << k << " channel " << ch << ": packet " << out[ch][k]
                                  << " scalar " << f[ch];
                }
            }
        }
        // The element past the end is not written.
        for (int ch = 0; ch < 3; ++ch) {
            EXPECT_EQ(out[ch][n], -7.0);
        }
    }
}

TEST(JetFormulas, DerivativesStayFiniteAtTheEdgesOfTheDomains) {
    using J = ceres::Jet<double, 2>;
    // sqrt at 0 and below, acos at +-1 and beyond: exact values, zero derivatives.
    for (double x : {0.0, -1e-17}) {
        const J r = safe_sqrt(J(x, 0));
        EXPECT_EQ(r.a, 0.0);
        EXPECT_EQ(r.v[0], 0.0);
    }
    EXPECT_EQ(safe_acos(J(1.0, 0)).a, 0.0);
    EXPECT_EQ(safe_acos(J(1.0, 0)).v[0], 0.0);
    EXPECT_EQ(safe_acos(J(-1.0 - 1e-16, 0)).a, kPi);
    EXPECT_EQ(safe_acos(J(-1.0, 0)).v[0], 0.0);
    // Inside the domain the derivative is the ordinary one.
    EXPECT_NEAR(safe_sqrt(J(0.25, 0)).v[0], 1.0, 1e-15);
    EXPECT_NEAR(safe_acos(J(0.0, 0)).v[0], -1.0, 1e-15);
    // The whole model at theta_h = 0 (wi = wo = z), at grazing directions and at alpha on its
    // bounds: finite values and finite derivatives in alpha and f0, for every distribution.
    for (Distribution d :
         {Distribution::kGgx, Distribution::kBeckmann, Distribution::kBlinnPhong}) {
        for (double alpha : {1e-4, 1.5}) {
            Model<J> m;
            m.diffuse = Rgb<J>::Constant(J(0.2));
            Lobe<J> l;
            l.distribution = d;
            l.alpha_x = l.alpha_y = J(alpha, 0);
            l.exponent = J(2 / (alpha * alpha), 0);
            l.fresnel.type = FresnelType::kConductor;
            l.fresnel.eta_rgb = Rgb<J>::Constant(J(1.0, 1));
            l.fresnel.k = Rgb<J>::Constant(J(0.0));
            m.lobes.push_back(l);
            for (double theta : {0.0, kPi / 2 - 1e-9}) {
                const Vec3<J> w(J(std::sin(theta)), J(0), J(std::cos(theta)));
                const Rgb<J> f = eval_model(m, w, w);
                for (int c = 0; c < 3; ++c) {
                    EXPECT_TRUE(std::isfinite(f[c].a) && std::isfinite(f[c].v[0]) &&
                                std::isfinite(f[c].v[1]))
                        << to_string(d) << " alpha " << alpha << " theta " << theta << ": " << f[c];
                }
            }
        }
    }
}

}  // namespace
}  // namespace gonio::brdf
