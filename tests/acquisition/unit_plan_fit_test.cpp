// The fit-driven plan's chooser: on a synthetic covariance and Jacobian the configurations it
// chooses are those the closed-form predictive variance (and its update after each choice)
// designates, per second of rig time; a misfit region is measured, not avoided; without a fit
// it fills space by farthest point (checked by brute force); distances respect reciprocity; the
// pool holds the specular neighbourhood.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "common/test_units.h"
#include "gonio/acquisition/plans/plan_fit.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {
namespace {

using brdf::kPi;
using brdf::Vec3d;
using gonio::test_units::kDeg;

PlannedConfig config(double ti_deg, double to_deg, double dphi_deg, bool isotropic = true) {
    PlannedConfig c;
    c.wi = brdf::spherical_to_cartesian(ti_deg * kDeg, 0.0);
    c.wo = brdf::spherical_to_cartesian(to_deg * kDeg, dphi_deg * kDeg);
    c.isotropic = isotropic;
    return c;
}

/// 40 candidates along theta_o at theta_i = 30 deg, delta_phi = 180 deg (through the mirror
/// direction), each costing one second.
std::vector<CandidateForPlan> line_of_candidates() {
    std::vector<CandidateForPlan> c;
    for (int k = 0; k < 40; ++k) {
        CandidateForPlan x;
        x.where = plan_features(config(30, 2.0 * k, 180));
        c.push_back(x);
    }
    return c;
}

/// Two parameters: a, felt only by candidates 10..14 (Jacobian 1 + (k - 10)), and b, felt by
/// every candidate with Jacobian 0.05; covariance diag(sa2, sb2).
FitView two_parameter_view(double sa2, double sb2) {
    FitView v;
    v.parameters = 2;
    v.covariance = {sa2, 0, 0, sb2};
    for (int k = 0; k < 40; ++k) {
        v.jacobian.push_back(k >= 10 && k < 15 ? 1.0 + (k - 10) : 0.0);
        v.jacobian.push_back(0.05);
        v.predicted.push_back(1);
    }
    return v;
}

TEST(PlanFit, ChoosesWhereTheClosedFormPredictiveVarianceIsLargest) {
    const std::vector<CandidateForPlan> cands = line_of_candidates();
    const double sa2 = 1e-4, sb2 = 1e-4, s2 = 1e-4;
    const FitView v = two_parameter_view(sa2, sb2);
    FitChoiceOptions o;
    o.count = 3;
    o.space_share = 0;
    const BatchChoice b = choose_batch(cands, {}, &v, s2, o);
    ASSERT_EQ(b.chosen.size(), 3u);
    // Independently: var_k = sa2 ja_k^2 + sb2 jb^2. The largest is candidate 14 (ja = 5).
    auto var = [&](int k, double a2, double b2) {
        const double ja = k >= 10 && k < 15 ? 1.0 + (k - 10) : 0.0;
        return a2 * ja * ja + b2 * 0.05 * 0.05;
    };
    EXPECT_EQ(b.chosen[0], 14u);
    EXPECT_NEAR(b.predictive_var[0], var(14, sa2, sb2), 1e-15);
    EXPECT_EQ(b.reasons[0], ChoiceReason::kVariance);
    // After measuring 14 (relative noise s2) the covariance is C - C j j^T C / (s2 + j^T C j),
    // written out for j = (5, 0.05):
    const double ja = 5, jb = 0.05;
    const double den = s2 + sa2 * ja * ja + sb2 * jb * jb;
    const double a2 = sa2 - sa2 * ja * sa2 * ja / den;
    const double b2 = sb2 - sb2 * jb * sb2 * jb / den;
    const double ab = -sa2 * ja * sb2 * jb / den;
    auto var_after = [&](int k) {
        const double x = k >= 10 && k < 15 ? 1.0 + (k - 10) : 0.0;
        return a2 * x * x + 2 * ab * x * jb + b2 * jb * jb;
    };
    int best = -1;
    for (int k = 0; k < 40; ++k) {
        if (k != 14 && (best < 0 || var_after(k) > var_after(best))) {
            best = k;
        }
    }
    EXPECT_EQ(static_cast<int>(b.chosen[1]), best);
    EXPECT_NEAR(b.predictive_var[1], var_after(best), 1e-12);
    // Every choice inside the region the covariance leaves uncertain.
    for (std::size_t c : b.chosen) {
        EXPECT_GE(c, 10u);
        EXPECT_LT(c, 15u);
    }
}

TEST(PlanFit, InformationIsPerSecondOfRigTime) {
    std::vector<CandidateForPlan> cands = line_of_candidates();
    FitView v = two_parameter_view(1e-4, 0);
    // Candidates 13 and 14 as informative (same Jacobian); 13 (the first on a tie) takes four
    // times the rig time.
    v.jacobian[13 * 2] = v.jacobian[14 * 2] = 5;
    cands[13].cost_s = 4;
    FitChoiceOptions o;
    o.count = 1;
    o.space_share = 0;
    const BatchChoice b = choose_batch(cands, {}, &v, 1e-4, o);
    ASSERT_EQ(b.chosen.size(), 1u);
    EXPECT_EQ(b.chosen[0], 14u);
}

TEST(PlanFit, AMisfitRegionIsMeasuredNotAvoided) {
    const std::vector<CandidateForPlan> cands = line_of_candidates();
    FitView v = two_parameter_view(1e-8, 1e-8);  // the fit is sure of itself everywhere
    // Measurements at theta_o = 0..78 deg every 6 deg; those at 30 and 36 deg miss the model by
    // 30 % (the rest within their 0.5 % noise).
    std::vector<MeasuredForPlan> measured;
    for (int k = 0; k < 40; k += 3) {
        MeasuredForPlan m;
        m.where = plan_features(config(30, 2.0 * k, 180));
        m.rel_sigma = 0.005;
        m.log_residual = (k == 15 || k == 18) ? std::log(1.3) : 0.004;
        measured.push_back(m);
    }
    FitChoiceOptions o;
    o.count = 2;
    o.space_share = 0;
    const BatchChoice b = choose_batch(cands, measured, &v, 0.005 * 0.005, o);
    ASSERT_EQ(b.chosen.size(), 2u);
    for (std::size_t k = 0; k < b.chosen.size(); ++k) {
        EXPECT_EQ(b.reasons[k], ChoiceReason::kMisfit);
        // Near the misfitting measurements (theta_o 30-36 deg: candidates 15-18, within 6 deg).
        EXPECT_GE(b.chosen[k], 12u);
        EXPECT_LE(b.chosen[k], 21u);
    }
}

TEST(PlanFit, WithoutAFitEveryChoiceIsTheFarthestPoint) {
    std::vector<CandidateForPlan> cands;
    std::vector<PlannedConfig> configs;
    for (double ti : {0.0, 20.0, 40.0, 60.0}) {
        for (double to : {10.0, 35.0, 70.0}) {
            for (double dp : {0.0, 90.0, 180.0}) {
                configs.push_back(config(ti, to, dp));
                CandidateForPlan c;
                c.where = plan_features(configs.back());
                cands.push_back(c);
            }
        }
    }
    std::vector<MeasuredForPlan> measured(1);
    measured[0].where = plan_features(config(30, 30, 180));
    FitChoiceOptions o;
    o.count = 6;
    const BatchChoice b = choose_batch(cands, measured, nullptr, 1e-4, o);
    ASSERT_EQ(b.chosen.size(), 6u);
    // Brute force: each choice maximises the distance to the measured and earlier choices.
    std::vector<PlanFeatures> have = {measured[0].where};
    std::set<std::size_t> taken;
    for (std::size_t k = 0; k < b.chosen.size(); ++k) {
        EXPECT_EQ(b.reasons[k], ChoiceReason::kSpace);
        double best = -1;
        for (std::size_t i = 0; i < cands.size(); ++i) {
            if (taken.count(i)) {
                continue;
            }
            double d = std::numeric_limits<double>::infinity();
            for (const PlanFeatures& h : have) {
                d = std::min(d, feature_distance(cands[i].where, h));
            }
            best = std::max(best, d);
        }
        double mine = std::numeric_limits<double>::infinity();
        for (const PlanFeatures& h : have) {
            mine = std::min(mine, feature_distance(cands[b.chosen[k]].where, h));
        }
        EXPECT_DOUBLE_EQ(mine, best) << "choice " << k;
        taken.insert(b.chosen[k]);
        have.push_back(cands[b.chosen[k]].where);
    }
}

TEST(PlanFit, ASpaceShareOfEveryInformedBatch) {
    const std::vector<CandidateForPlan> cands = line_of_candidates();
    const FitView v = two_parameter_view(1e-4, 1e-2);
    FitChoiceOptions o;
    o.count = 8;
    o.space_share = 0.25;
    const BatchChoice b = choose_batch(cands, {}, &v, 1e-4, o);
    ASSERT_EQ(b.chosen.size(), 8u);
    int space = 0;
    for (ChoiceReason r : b.reasons) {
        space += r == ChoiceReason::kSpace;
    }
    EXPECT_EQ(space, 2);
    std::set<std::size_t> unique(b.chosen.begin(), b.chosen.end());
    EXPECT_EQ(unique.size(), 8u);
}

TEST(PlanFit, DistancesHonourReciprocityAndIsotropy) {
    const PlannedConfig a = config(20, 50, 120);
    PlannedConfig swapped;
    swapped.wi = a.wo;
    swapped.wo = a.wi;
    EXPECT_NEAR(feature_distance(plan_features(a), plan_features(swapped)), 0, 1e-12);
    // Isotropic: a turn about the normal changes nothing; anisotropic: it does.
    PlannedConfig turned = a;
    const double c = std::cos(0.7), s = std::sin(0.7);
    turned.wi = Vec3d(c * a.wi.x() - s * a.wi.y(), s * a.wi.x() + c * a.wi.y(), a.wi.z());
    turned.wo = Vec3d(c * a.wo.x() - s * a.wo.y(), s * a.wo.x() + c * a.wo.y(), a.wo.z());
    EXPECT_NEAR(feature_distance(plan_features(a), plan_features(turned)), 0, 1e-12);
    PlannedConfig an = a, an_turned = turned;
    an.isotropic = an_turned.isotropic = false;
    EXPECT_GT(feature_distance(plan_features(an), plan_features(an_turned)), 0.1);
}

TEST(PlanFit, ThePoolHoldsTheSpecularNeighbourhood) {
    for (bool aniso : {false, true}) {
        FitPlanSpec s;
        s.anisotropic = aniso;
        auto pool = fit_plan_pool(s);
        ASSERT_TRUE(pool) << pool.error().message;
        int near_mirror = 0;
        for (const PlannedConfig& c : pool->configs) {
            EXPECT_EQ(c.isotropic, !aniso);
            const Vec3d h = (c.wi + c.wo).normalized();
            near_mirror += std::acos(std::min(1.0, h.z())) < 3 * kDeg;
            EXPECT_LE(std::acos(c.wi.z()), s.theta_max + 1e-9);
            EXPECT_LE(std::acos(c.wo.z()), s.theta_max + 1e-9);
        }
        EXPECT_GT(pool->configs.size(), 1000u) << aniso;
        EXPECT_GT(near_mirror, 50) << aniso;
    }
}

}  // namespace
}  // namespace gonio::acquisition
