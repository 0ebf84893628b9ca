// Samples prepared once (geometry in double): model values against brdf::eval_model, the closed
// form and Jet derivatives against ceres::GradientChecker (numeric differentiation), the two
// derivative paths against each other, and the normal-equation cost against the full problem.

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "fit_test_util.h"
#include "gonio/base/instruction_set.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/prepared_samples.h"
#include "gonio/fitting/spec.h"

namespace gonio::fitting {
namespace {

using brdf::Distribution;
using brdf::FresnelType;
using brdf::Rgbd;
using brdf::Shadowing;

struct Structure {
    std::string label;
    Distribution dist;
    Shadowing shadowing;
    FresnelType fresnel;
    bool fresnel_rgb;
    bool anisotropic;
    int lobes;
};

const Structure kStructures[] = {
    {"ggx-smith-schlick",
     Distribution::kGgx,
     Shadowing::kSmithCorrelated,
     FresnelType::kSchlick,
     false,
     false,
     1},
    {"ggx-schlick-rgb",
     Distribution::kGgx,
     Shadowing::kSmithCorrelated,
     FresnelType::kSchlick,
     true,
     false,
     1},
    {"beckmann-separable",
     Distribution::kBeckmann,
     Shadowing::kSmithSeparable,
     FresnelType::kSchlick,
     false,
     false,
     1},
    {"beckmann-vgroove",
     Distribution::kBeckmann,
     Shadowing::kVGroove,
     FresnelType::kSchlick,
     false,
     false,
     1},
    {"blinn-phong-smith",
     Distribution::kBlinnPhong,
     Shadowing::kSmithCorrelated,
     FresnelType::kNone,
     false,
     false,
     1},
    {"ggx-two-lobes",
     Distribution::kGgx,
     Shadowing::kSmithCorrelated,
     FresnelType::kSchlick,
     false,
     false,
     2},
    {"ggx-dielectric",
     Distribution::kGgx,
     Shadowing::kSmithCorrelated,
     FresnelType::kDielectric,
     false,
     false,
     1},
    {"beckmann-conductor",
     Distribution::kBeckmann,
     Shadowing::kNone,
     FresnelType::kConductor,
     true,
     false,
     1},
    {"ggx-anisotropic",
     Distribution::kGgx,
     Shadowing::kSmithCorrelated,
     FresnelType::kSchlick,
     false,
     true,
     1},
    {"student-t-smith",
     Distribution::kStudentT,
     Shadowing::kSmithCorrelated,
     FresnelType::kSchlick,
     false,
     false,
     1},
    {"student-t-anisotropic-separable-two-lobes",
     Distribution::kStudentT,
     Shadowing::kSmithSeparable,
     FresnelType::kSchlick,
     true,
     true,
     2},
};

/// A spec of the structure with non-trivial start values (the point where derivatives are checked).
FitSpec spec_of(const Structure& st) {
    ModelOptions mo;
    mo.distribution = st.dist;
    mo.shadowing = st.shadowing;
    mo.fresnel = st.fresnel;
    mo.fresnel_rgb = st.fresnel_rgb;
    mo.anisotropic = st.anisotropic;
    mo.lobes = st.lobes;
    FitSpec spec = *make_fit_spec(mo);
    brdf::ModelD& m = spec.model;
    m.diffuse = Rgbd(0.3, 0.2, 0.1);
    for (std::size_t l = 0; l < m.lobes.size(); ++l) {
        brdf::Lobe<double>& lobe = m.lobes[l];
        lobe.alpha_x = 0.15 * (l + 1);
        lobe.alpha_y = 0.25 * (l + 1);
        lobe.exponent = 40;
        lobe.gamma = 1.9 + 2.5 * l;
        lobe.scale = Rgbd(0.9, 0.7, 0.5);
        lobe.fresnel.f0 = Rgbd(0.05, 0.08, 0.11);
        lobe.fresnel.eta = 1.6;
        lobe.fresnel.eta_rgb = Rgbd(0.2, 0.9, 1.1);
        lobe.fresnel.k = Rgbd(3.0, 2.5, 2.0);
    }
    return spec;
}

/// Seeded samples above the horizon with values near the model's (the residuals are not zero).
std::vector<brdf::Sample> samples_for(const brdf::ModelD& m, std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<brdf::Sample> out;
    while (out.size() < n) {
        brdf::Sample s;
        s.theta_i = std::acos(0.05 + 0.95 * u(rng));
        s.theta_o = std::acos(0.05 + 0.95 * u(rng));
        s.phi_i = 2 * brdf::kPi * u(rng);
        // Half of them near the mirror direction, where the lobe lives.
        s.phi_o = u(rng) < 0.5 ? s.phi_i + brdf::kPi + 0.2 * (u(rng) - 0.5)
                               : 2 * brdf::kPi * u(rng) - brdf::kPi;
        if (out.size() % 2 == 0) {
            s.theta_o = std::clamp(s.theta_i + 0.1 * (u(rng) - 0.5), 0.0, 1.5);
        }
        const Rgbd f = brdf::eval_model(m, s.wi(), s.wo());
        for (int c = 0; c < 3; ++c) {
            s.value[c] = f[c] * (1 + 0.3 * (u(rng) - 0.5));
            s.sigma[c] = 0.02 * s.value[c] + 1e-4;
        }
        s.weight = 0.5 + u(rng);
        out.push_back(s);
    }
    return out;
}

TEST(PreparedSamples, ModelValuesEqualBrdfEvalModelToRounding) {
    for (const Structure& st : kStructures) {
        const FitSpec spec = spec_of(st);
        auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
        const std::vector<brdf::Sample> samples = samples_for(spec.model, 500, 7);
        const PreparedSamples ps(map, samples, CostOptions{});
        std::vector<Rgbd> values;
        ps.model_values(spec.model, values, 1);
        double worst = 0;
        for (std::size_t i = 0; i < samples.size(); ++i) {
            const Rgbd ref = brdf::eval_model(spec.model, samples[i].wi(), samples[i].wo());
            for (int c = 0; c < 3; ++c) {
                worst =
                    std::max(worst, std::abs(values[i][c] - ref[c]) / (std::abs(ref[c]) + 1e-300));
            }
        }
        EXPECT_LT(worst, 1e-11) << st.label;
    }
}

TEST(PreparedSamples, ReweightRelativeMovesEachFactorFromTheMeasuredToTheModelValue) {
    // Before: s = 1 / (g'(d) sigma). After reweight_relative at the model values m: s = 1 / (g'(m)
    // rel m) with rel = sigma / d. At the same parameters the residual g(m) - g(d) is unchanged, so
    // r_after / r_before = g'(d) d / (g'(m) m): d / m for the absolute form, and
    // (1 + m cos_i) d / ((1 + d cos_i) m) for the log form (g'(x) = cos_i / (1 + x cos_i)). A
    // channel without sigma keeps its factor.
    const FitSpec spec = spec_of(kStructures[0]);
    auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
    std::vector<brdf::Sample> samples = samples_for(spec.model, 200, 11);
    for (std::size_t i = 0; i < samples.size(); i += 4) {
        samples[i].sigma[1] = 0;  // no uncertainty in this channel
    }
    const std::vector<double> x = map->values_of(spec.model);
    for (const ResidualForm form : {ResidualForm::kAbsolute, ResidualForm::kLog}) {
        CostOptions co;
        co.residual = form;
        PreparedSamples ps(map, samples, co);
        std::vector<double> before(3 * samples.size()), after(3 * samples.size());
        ASSERT_TRUE(ps.evaluate(x.data(), 0, samples.size(), before.data(), nullptr));
        std::vector<Rgbd> m;
        ps.model_values(spec.model, m, 1);
        ps.reweight_relative(samples, m);
        ASSERT_TRUE(ps.evaluate(x.data(), 0, samples.size(), after.data(), nullptr));
        double worst = 0;
        int compared = 0;
        for (std::size_t i = 0; i < samples.size(); ++i) {
            const double cos_i = std::cos(samples[i].theta_i);
            for (int c = 0; c < 3; ++c) {
                const double d = samples[i].value[c];
                const double mc = m[i][c];
                if (std::abs(before[3 * i + c]) < 1e-9) {
                    continue;  // a ratio of two zeros
                }
                double expect = 1;
                if (samples[i].sigma[c] > 0) {
                    expect = form == ResidualForm::kAbsolute
                                 ? d / mc
                                 : (1 + mc * cos_i) * d / ((1 + d * cos_i) * mc);
                }
                worst =
                    std::max(worst, std::abs(after[3 * i + c] / before[3 * i + c] / expect - 1));
                ++compared;
            }
        }
        EXPECT_GT(compared, 400);
        EXPECT_LT(worst, 1e-9) << "form " << static_cast<int>(form);
    }
}

TEST(PreparedSamples, DerivativesPassCeresGradientCheckerForEveryStructureAndForm) {
    const ResidualForm forms[] = {ResidualForm::kLog,
                                  ResidualForm::kAbsolute,
                                  ResidualForm::kRelative,
                                  ResidualForm::kCubeRoot};
    for (const Structure& st : kStructures) {
        for (ResidualForm form : forms) {
            for (bool sigma : {false, true}) {
                const FitSpec spec = spec_of(st);
                auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
                const std::vector<brdf::Sample> samples = samples_for(spec.model, 40, 11);
                CostOptions co;
                co.residual = form;
                co.use_sigma = sigma;
                std::unique_ptr<ceres::CostFunction> cost = make_batch_cost(map, samples, co);
                std::vector<double> x = map->values_of(spec.model);
                const double* params[] = {x.data()};
                ceres::NumericDiffOptions nd;
                nd.ridders_relative_initial_step_size = 1e-5;
                nd.max_num_ridders_extrapolations = 12;
                const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
                ceres::GradientChecker checker(cost.get(), no_manifolds, nd);
                ceres::GradientChecker::ProbeResults results;
                const PreparedSamples ps(map, samples, co);
                // Ceres' verdict is relative per entry; entries below 1e-9 of their column's
                // largest are at the noise floor of numeric differentiation (D underflowing in a
                // far tail), so the judgement here adds that absolute floor.
                checker.Probe(params, 1e-6, &results);
                const auto& user = results.jacobians[0];
                const auto& num = results.numeric_jacobians[0];
                int bad = 0;
                for (int col = 0; col < num.cols(); ++col) {
                    const double floor = 1e-9 * num.col(col).cwiseAbs().maxCoeff();
                    for (int row = 0; row < num.rows(); ++row) {
                        const double a = user(row, col), b = num(row, col);
                        const double err = std::abs(a - b);
                        if (err > 1e-6 * std::max(std::abs(a), std::abs(b)) && err > floor) {
                            ++bad;
                        }
                    }
                }
                EXPECT_EQ(bad, 0) << st.label << " " << to_string(form) << (sigma ? " sigma" : "")
                                  << (ps.analytic() ? " (closed form)" : " (Jets)") << "\n"
                                  << results.error_log;
            }
        }
    }
}

TEST(PreparedSamples, ClosedFormAndJetDerivativesAgree) {
    int analytic_structures = 0;
    for (const Structure& st : kStructures) {
        for (ResidualForm form :
             {ResidualForm::kLog, ResidualForm::kCubeRoot, ResidualForm::kRelative}) {
            const FitSpec spec = spec_of(st);
            auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
            const std::vector<brdf::Sample> samples = samples_for(spec.model, 300, 3);
            CostOptions co;
            co.residual = form;
            PreparedSamples closed(map, samples, co);
            PreparedSamples jets(map, samples, co);
            jets.set_analytic(false);
            if (!closed.analytic()) {
                continue;
            }
            ++analytic_structures;
            const std::vector<double> x = map->values_of(spec.model);
            NormalEquations a, b;
            ASSERT_TRUE(closed.normal_equations(x.data(), a, 2));
            ASSERT_TRUE(jets.normal_equations(x.data(), b, 1));
            EXPECT_NEAR(a.cost_sum, b.cost_sum, 1e-12 * b.cost_sum) << st.label;
            EXPECT_LT((a.jtj - b.jtj).norm(), 1e-10 * b.jtj.norm()) << st.label;
            EXPECT_LT((a.jtr - b.jtr).norm(), 1e-10 * b.jtr.norm() + 1e-300) << st.label;
        }
    }
    // The default structures take the closed form.
    EXPECT_GE(analytic_structures, 15);
}

TEST(PreparedSamples, FusedPacketPassesEqualThePerSamplePasses) {
    // The fused packet passes (normal_equation_packets.h) against the per-sample passes of the
    // same prepared samples: the same operations per sample and channel (log1p on packets in
    // both), summed in another order (per lane, then lanes), so the sums agree to rounding:
    // relative 1e-12 for the cost and J^T J (sums of squares), 1e-11 of |J^T r| for J^T r (its
    // terms have both signs). Two blocks and a partial last packet (8,205 samples), with the edges
    // grazing (1e-6 above the horizon), theta_h = 0 (both along the normal) and wi = wo; with and
    // without sigma, at the data's point and away from it.
    std::vector<Structure> structures;
    for (const Structure& st : kStructures) {
        structures.push_back(st);
    }
    structures.push_back({"ggx-no-shadowing",
                          Distribution::kGgx,
                          Shadowing::kNone,
                          FresnelType::kNone,
                          false,
                          false,
                          1});
    structures.push_back({"beckmann-correlated-two-lobes",
                          Distribution::kBeckmann,
                          Shadowing::kSmithCorrelated,
                          FresnelType::kSchlick,
                          true,
                          false,
                          2});
    int fused = 0;
    for (const Structure& st : structures) {
        for (bool sigma : {false, true}) {
            const FitSpec spec = spec_of(st);
            auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
            std::vector<brdf::Sample> samples = samples_for(spec.model, 8200, 17);
            for (const auto& [ti, to, dphi] : {std::tuple{0.0, 0.0, 0.0},
                                               std::tuple{brdf::kPi / 2 - 1e-6, 0.3, 3.0},
                                               std::tuple{0.7, brdf::kPi / 2 - 1e-6, 2.0},
                                               std::tuple{0.9, 0.9, 0.0},
                                               std::tuple{0.4, 0.4, brdf::kPi}}) {
                brdf::Sample s;
                s.theta_i = ti;
                s.theta_o = to;
                s.phi_i = 0.3;
                s.phi_o = 0.3 + dphi;
                const Rgbd f = brdf::eval_model(spec.model, s.wi(), s.wo());
                for (int c = 0; c < 3; ++c) {
                    s.value[c] = 1.1 * f[c] + 1e-3;
                    s.sigma[c] = 0.02 * s.value[c];
                }
                samples.insert(samples.begin() + 37 * samples.size() / 100, s);
            }
            ASSERT_EQ(samples.size(), 8205u);
            CostOptions co;
            co.use_sigma = sigma;
            PreparedSamples packets(map, samples, co);
            PreparedSamples per_sample(map, samples, co);
            per_sample.set_packets(false);
            EXPECT_FALSE(per_sample.packets());
            if (!packets.packets()) {
                continue;
            }
            ++fused;
            std::vector<double> x = map->values_of(spec.model);
            for (int point = 0; point < 2; ++point) {
                if (point == 1) {
                    for (double& v : x) {
                        v *= 1.07;
                    }
                }
                NormalEquations a, b;
                ASSERT_TRUE(packets.normal_equations(x.data(), a, 2));
                ASSERT_TRUE(per_sample.normal_equations(x.data(), b, 1));
                EXPECT_NEAR(a.cost_sum, b.cost_sum, 1e-12 * b.cost_sum) << st.label;
                EXPECT_LT((a.jtj - b.jtj).norm(), 1e-12 * b.jtj.norm()) << st.label;
                EXPECT_LT((a.jtr - b.jtr).norm(), 1e-11 * b.jtr.norm()) << st.label;
                double ca = 0, cb = 0;
                ASSERT_TRUE(packets.sum_of_squares(x.data(), &ca, 2));
                ASSERT_TRUE(per_sample.sum_of_squares(x.data(), &cb, 1));
                EXPECT_NEAR(ca, cb, 1e-12 * cb) << st.label;
                EXPECT_NEAR(ca, a.cost_sum, 1e-12 * cb) << st.label;
            }
        }
    }
    // ggx-smith-schlick, ggx-schlick-rgb, beckmann-separable, ggx-two-lobes and the two above,
    // each with and without sigma; none in a build without packet kernels (instruction_set.h).
    EXPECT_EQ(fused, packet_isa() == Isa::kScalar ? 0 : 12);
}

TEST(PreparedSamples, FusedPacketPassesReportANonFiniteResidual) {
    // A measured value of +inf makes g(d) infinite: both passes refuse the point.
    const FitSpec spec = spec_of(kStructures[0]);
    auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
    std::vector<brdf::Sample> samples = samples_for(spec.model, 5000, 19);
    samples[4321].value[1] = std::numeric_limits<double>::infinity();
    const PreparedSamples ps(map, samples, CostOptions{});
    ASSERT_EQ(ps.packets(), packet_isa() != Isa::kScalar);
    const std::vector<double> x = map->values_of(spec.model);
    NormalEquations ne;
    EXPECT_FALSE(ps.normal_equations(x.data(), ne, 2));
    double c = 0;
    EXPECT_FALSE(ps.sum_of_squares(x.data(), &c, 1));
}

TEST(NormalEquationCost, ReproducesTheGaussNewtonQuantitiesOfTheFullProblem) {
    const FitSpec spec = spec_of(kStructures[0]);
    auto map = std::make_shared<const ParameterMap>(*ParameterMap::make(spec));
    const std::vector<brdf::Sample> samples = samples_for(spec.model, 5000, 5);
    const CostOptions co;
    // The full problem: residuals and Jacobian of every sample.
    std::unique_ptr<ceres::CostFunction> full = make_batch_cost(map, samples, co);
    const int n = map->size();
    std::vector<double> x = map->values_of(spec.model);
    x[3] *= 1.3;  // away from the data's own point
    const double* params[] = {x.data()};
    Eigen::VectorXd r(3 * samples.size());
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> j(3 * samples.size(), n);
    double* jacs[] = {j.data()};
    ASSERT_TRUE(full->Evaluate(params, r.data(), jacs));
    // The compressed one.
    auto ps = std::make_shared<const PreparedSamples>(map, samples, co);
    NormalEquationCost cost(ps, 2);
    ASSERT_EQ(cost.num_residuals(), n + 1);
    Eigen::VectorXd rc(n + 1);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jc(n + 1, n);
    double* jcs[] = {jc.data()};
    ASSERT_TRUE(cost.Evaluate(params, rc.data(), jcs));
    const Eigen::MatrixXd jtj = j.transpose() * j;
    const Eigen::VectorXd jtr = j.transpose() * r;
    EXPECT_LT((jc.transpose() * jc - jtj).norm(), 1e-9 * jtj.norm());
    EXPECT_LT((jc.transpose() * rc - jtr).norm(), 1e-9 * jtr.norm());
    EXPECT_NEAR(rc.squaredNorm(), r.squaredNorm(), 1e-10 * r.squaredNorm());
    // A cost-only call at the same point answers from the same pass.
    Eigen::VectorXd r_only(n + 1);
    ASSERT_TRUE(cost.Evaluate(params, r_only.data(), nullptr));
    EXPECT_NEAR(r_only.squaredNorm(), r.squaredNorm(), 1e-10 * r.squaredNorm());
    EXPECT_EQ(cost.passes(), 1);
}

}  // namespace
}  // namespace gonio::fitting
