// The fit-driven plan with fly scans (fit_sweeps.h): every line of its pool is one sweep to the
// runner (solved frame after frame, its poses differ in the moving arm alone); the batch is
// chosen as sweeps where the fit expects most information per rig second, nearer sweeps first
// when they teach alike; the space-filling share and the first batch are sweeps too.

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "../common/test_units.h"
#include "gonio/acquisition/point/fit_sweeps.h"

namespace gonio::acquisition::fit_sweeps_test {
namespace {

using gonio::test_units::kDeg;

RigConfig mono_rig() {
    auto rig = read_rig_config(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4-mono.json");
    EXPECT_TRUE(rig) << rig.error().message;
    return *rig;
}

FitSweepPool pool_of(const RigConfig& rig) {
    auto pool = fit_sweep_pool(FitPlanSpec{}, FlySpec{}, "", rig);
    EXPECT_TRUE(pool) << pool.error().message;
    return *pool;
}

std::vector<CandidateForPlan> candidates_of_pool(const FitSweepPool& pool) {
    std::vector<CandidateForPlan> out;
    for (const PlannedConfig& c : pool.pool.configs) {
        CandidateForPlan k;
        k.where = plan_features(c);
        out.push_back(k);
    }
    return out;
}

TEST(FitSweeps, EveryLineOfThePoolIsOneSweepToTheRunner) {
    const RigConfig rig = mono_rig();
    const FitSweepPool pool = pool_of(rig);
    ASSERT_GT(pool.lines.size(), 40u);
    EXPECT_GT(pool.pool.configs.size(), 1000u);
    const RigLimits lim = rig_limits(rig);
    const auto dyn = rig_dynamics(rig);
    for (std::size_t l = 0; l < pool.lines.size(); ++l) {
        const SweepLine& line = pool.lines[l];
        // The frames solved in order from wherever the rig stood (as the runner solves a batch)
        // stand alike but for one arm: plan_fly_units makes them one sweep.
        std::vector<brdf::RigPosed> poses;
        brdf::RigPosed prev{0.3, -0.4, 0.1, 0.2};
        for (std::size_t i : line.frames) {
            const PlannedConfig& c = pool.pool.configs[i];
            auto s = solve(Target{c.wi, c.wo, true, true}, lim, dyn, prev);
            ASSERT_TRUE(s) << s.error().message;
            poses.push_back(s->pose);
            prev = s->pose;
        }
        const auto units = plan_fly_units(poses, poses.front(), FlySpec{}, fly_limits_of(rig));
        ASSERT_EQ(units.size(), 1u) << "line " << l;
        EXPECT_FALSE(units[0].standing);
        EXPECT_EQ(units[0].sweep.members.size(), line.frames.size());
        for (std::size_t k = 1; k < line.angles.size(); ++k) {
            EXPECT_NEAR(line.angles[k] - line.angles[k - 1], kFitSweepGapRad, 1e-12);
        }
    }
}

/// A fit of one parameter whose Jacobian is `j_of(frame)` and variance 1.
FitView one_parameter_view(const FitSweepPool& pool, double (*j_of)(const SweepLine&, double)) {
    FitView v;
    v.parameters = 1;
    v.covariance = {1.0};
    v.jacobian.assign(pool.pool.configs.size(), 0.0);
    v.predicted.assign(pool.pool.configs.size(), 1.0);
    for (const SweepLine& line : pool.lines) {
        for (std::size_t k = 0; k < line.frames.size(); ++k) {
            v.jacobian[line.frames[k]] = j_of(line, line.angles[k]);
        }
    }
    return v;
}

/// The choice's input before anything is measured: `fit` over `pool`, the dynamics of `rig`, a
/// relative noise variance of 1e-2.
SweepChoiceInput unmeasured_input(const FitSweepPool& pool,
                                  const FitView& fit,
                                  const RigConfig& rig) {
    static const std::vector<MeasuredForPlan> none;
    SweepChoiceInput in;
    in.pool = &pool;
    in.measured = &none;
    in.fit = &fit;
    in.noise_rel_var = 1e-2;
    in.dyn = rig_dynamics(rig);
    return in;
}

/// `count` sweeps, `space_share` of them filling space.
FitChoiceOptions choice_options(int count, double space_share) {
    FitChoiceOptions o;
    o.count = count;
    o.space_share = space_share;
    return o;
}

TEST(FitSweeps, ChoosesTheSweepWhereTheFitIsLeastCertain) {
    const RigConfig rig = mono_rig();
    const FitSweepPool pool = pool_of(rig);
    // Only the in-plane line with the light at 30 deg, near the specular direction (-30 deg),
    // tells the parameter anything.
    const FitView fit = one_parameter_view(pool, [](const SweepLine& l, double a) {
        const bool line =
            std::abs(l.stand.tilt) < 1e-9 && std::abs(l.stand.light - 30 * kDeg) < 1e-9;
        return line && std::abs(a + 30 * kDeg) < 8 * kDeg ? 1.0 : 0.0;
    });
    SweepChoiceInput in = unmeasured_input(pool, fit, rig);
    in.readout_s = 0.0052;
    const FitChoiceOptions o = choice_options(8, 0.25);
    const SweepChoice c = choose_sweeps(candidates_of_pool(pool), in, o, 120);
    ASSERT_GE(c.sweeps, 2u);
    ASSERT_FALSE(c.frames.chosen.empty());
    EXPECT_EQ(c.frames.reasons.front(), ChoiceReason::kVariance);
    // The first sweep's frames lie on that line, within the informative arc, in arm order.
    const std::size_t line = pool.line_of[c.frames.chosen.front()];
    EXPECT_NEAR(pool.lines[line].stand.light, 30 * kDeg, 1e-9);
    EXPECT_NEAR(pool.lines[line].stand.tilt, 0, 1e-9);
    int informative = 0;
    for (std::size_t q = 0; q < c.frames.chosen.size(); ++q) {
        if (c.frames.reasons[q] != ChoiceReason::kSpace) {
            EXPECT_EQ(pool.line_of[c.frames.chosen[q]], line);
            informative += fit.jacobian[c.frames.chosen[q]] > 0;
        }
    }
    EXPECT_GE(informative, 4);
    // At least one space-filling sweep of kSpaceSweepFrames frames on one line.
    std::set<std::size_t> space_lines;
    int space = 0;
    for (std::size_t q = 0; q < c.frames.chosen.size(); ++q) {
        if (c.frames.reasons[q] == ChoiceReason::kSpace) {
            ++space;
            space_lines.insert(pool.line_of[c.frames.chosen[q]]);
        }
    }
    EXPECT_GE(space, 2);
    EXPECT_LE(space_lines.size(), static_cast<std::size_t>((space + 1) / 2));
    EXPECT_GE(static_cast<int>(c.frames.chosen.size()), o.count);
}

TEST(FitSweeps, OfTwoSweepsThatTeachAlikeTheNearerGoesFirst) {
    const RigConfig rig = mono_rig();
    const FitSweepPool pool = pool_of(rig);
    // Two in-plane lines teach alike (light at 20 and at 60 deg, every frame): from a rig
    // standing on the second, it is chosen first; from one standing on the first, the first.
    // Six frames each, from 5 to 15 deg beyond the light.
    const FitView fit = one_parameter_view(pool, [](const SweepLine& l, double a) {
        const bool in_plane = std::abs(l.stand.tilt) < 1e-9;
        const bool pick = std::abs(l.stand.light - 20 * kDeg) < 1e-9 ||
                          std::abs(l.stand.light - 60 * kDeg) < 1e-9;
        return in_plane && pick && a > l.stand.light && a < l.stand.light + 16 * kDeg ? 1.0 : 0.0;
    });
    SweepChoiceInput in = unmeasured_input(pool, fit, rig);
    const FitChoiceOptions o = choice_options(4, 0);
    for (double light_deg : {20.0, 60.0}) {
        in.start = brdf::RigPosed{light_deg * kDeg, (light_deg + 10) * kDeg, 0, 0};
        const SweepChoice c = choose_sweeps(candidates_of_pool(pool), in, o, 120);
        ASSERT_FALSE(c.frames.chosen.empty());
        EXPECT_NEAR(
            pool.lines[pool.line_of[c.frames.chosen.front()]].stand.light, light_deg * kDeg, 1e-9)
            << "from the light at " << light_deg << " deg";
    }
}

FitSweepPool anisotropic_pool_of(const RigConfig& rig, SampleSymmetry symmetry) {
    FitPlanSpec spec;
    spec.anisotropic = true;
    spec.symmetry = symmetry;
    auto pool = fit_sweep_pool(spec, FlySpec{}, "", rig);
    EXPECT_TRUE(pool) << pool.error().message;
    return *pool;
}

/// The spins of a pool's lines, degrees rounded.
std::set<long> spins_deg(const FitSweepPool& pool) {
    std::set<long> out;
    for (const SweepLine& line : pool.lines) {
        out.insert(std::lround(line.stand.spin / kDeg));
    }
    return out;
}

TEST(FitSweeps, AnisotropicPoolTurnsTheSampleAndEachLineIsOneSweep) {
    const RigConfig rig = mono_rig();
    const FitSweepPool pool = anisotropic_pool_of(rig, SampleSymmetry::kNone);
    ASSERT_TRUE(pool.anisotropic);
    // A full turn in 12 spins, 30 deg apart; a 2-fold sample half of it.
    const std::set<long> turn = spins_deg(pool);
    ASSERT_EQ(turn.size(), 12u);
    EXPECT_EQ(*turn.begin(), -165);
    EXPECT_EQ(*turn.rbegin(), 165);
    const std::set<long> half = spins_deg(anisotropic_pool_of(rig, SampleSymmetry::kTwoFold));
    EXPECT_EQ(half, (std::set<long>{-75, -45, -15, 15, 45, 75}));
    // Every configuration of the pool is a frame of its line (a sweep can take each one).
    for (std::size_t i = 0; i < pool.pool.configs.size(); ++i) {
        ASSERT_EQ(pool.lines[pool.line_of[i]].frames[pool.step_of[i]], i) << i;
    }
    const RigLimits lim = rig_limits(rig);
    const auto dyn = rig_dynamics(rig);
    for (std::size_t l = 0; l < pool.lines.size(); l += 7) {
        const SweepLine& line = pool.lines[l];
        // Solved as the runner solves an anisotropic batch (both azimuths kept), the frames of a
        // line stand at its spin and alike but for one arm: one sweep.
        std::vector<brdf::RigPosed> poses;
        brdf::RigPosed prev = line.stand;
        for (std::size_t i : line.frames) {
            const PlannedConfig& c = pool.pool.configs[i];
            ASSERT_FALSE(c.isotropic);
            auto s = solve(Target{c.wi, c.wo, false, true}, lim, dyn, prev);
            ASSERT_TRUE(s) << s.error().message;
            EXPECT_LT((s->wi - c.wi).norm() + (s->wo - c.wo).norm(), 1e-9);
            EXPECT_NEAR(s->pose.spin, line.stand.spin, 1e-9) << "line " << l;
            poses.push_back(s->pose);
            prev = s->pose;
        }
        const auto units = plan_fly_units(poses, poses.front(), FlySpec{}, fly_limits_of(rig));
        ASSERT_EQ(units.size(), 1u) << "line " << l;
        EXPECT_FALSE(units[0].standing);
        EXPECT_EQ(units[0].sweep.members.size(), line.frames.size());
    }
}

TEST(FitSweeps, AnisotropicChoiceTurnsTheSampleToTheSpinThatTeachesNearerFirst) {
    const RigConfig rig = mono_rig();
    const FitSweepPool pool = anisotropic_pool_of(rig, SampleSymmetry::kNone);
    // Two in-plane lines teach alike, the light at 30 deg with the sample turned to -45 and to
    // 105 deg: from a rig whose spin stands near either, that one's sweep is chosen first.
    const FitView fit = one_parameter_view(pool, [](const SweepLine& l, double a) {
        const long spin = std::lround(l.stand.spin / kDeg);
        const bool line = std::abs(l.stand.tilt) < 1e-9 &&
                          std::abs(l.stand.light - 30 * kDeg) < 1e-9 &&
                          (spin == -45 || spin == 105);
        return line && a > l.stand.light && a < l.stand.light + 16 * kDeg ? 1.0 : 0.0;
    });
    SweepChoiceInput in = unmeasured_input(pool, fit, rig);
    const FitChoiceOptions o = choice_options(4, 0);
    for (double spin_deg : {-45.0, 105.0}) {
        in.start = brdf::RigPosed{30 * kDeg, 40 * kDeg, 0, (spin_deg + 10) * kDeg};
        const SweepChoice c = choose_sweeps(candidates_of_pool(pool), in, o, 120);
        ASSERT_FALSE(c.frames.chosen.empty());
        const SweepLine& first = pool.lines[pool.line_of[c.frames.chosen.front()]];
        EXPECT_NEAR(first.stand.spin, spin_deg * kDeg, 1e-9) << "from the spin at " << spin_deg;
        EXPECT_NEAR(first.stand.light, 30 * kDeg, 1e-9);
        EXPECT_EQ(c.frames.reasons.front(), ChoiceReason::kVariance);
    }
    // The move to the other spin is paid for: the far sweep costs the spin's turn (150 deg at
    // 30 deg/s, about 5 s) more than the near one.
    std::size_t near_line = pool.lines.size(), far_line = pool.lines.size();
    for (std::size_t l = 0; l < pool.lines.size(); ++l) {
        const SweepLine& line = pool.lines[l];
        if (std::abs(line.stand.tilt) < 1e-9 && std::abs(line.stand.light - 30 * kDeg) < 1e-9 &&
            line.angles.front() > line.stand.light) {
            const long spin = std::lround(line.stand.spin / kDeg);
            if (spin == -45) {
                near_line = l;
            } else if (spin == 105) {
                far_line = l;
            }
        }
    }
    ASSERT_LT(near_line, pool.lines.size());
    ASSERT_LT(far_line, pool.lines.size());
    in.start = brdf::RigPosed{30 * kDeg, 40 * kDeg, 0, -45 * kDeg};
    brdf::RigPosed exit;
    const double near_s = sweep_cost_s(pool.lines[near_line], 0, 3, in.start, in, &exit);
    const double far_s = sweep_cost_s(pool.lines[far_line], 0, 3, in.start, in, &exit);
    EXPECT_NEAR(exit.spin, 105 * kDeg, 1e-9);
    EXPECT_GT(far_s - near_s, 4.0);
    EXPECT_LT(far_s - near_s, 7.0);
}

TEST(FitSweeps, FirstBatchIsSpaceFillingSweeps) {
    const RigConfig rig = mono_rig();
    const FitSweepPool pool = pool_of(rig);
    FitPlanSpec spec;
    spec.first = 16;
    const Plan first = fit_first_sweeps(pool, spec);
    ASSERT_EQ(first.configs.size(), 16u);
    // Runs of consecutive frames of one line (sweeps), at most half the batch long (two sweeps
    // of 8 where the lines are long enough).
    std::vector<int> runs;
    for (std::size_t q = 0; q < first.configs.size(); ++q) {
        const std::size_t i = first.configs[q].index;
        const bool joins = q > 0 && pool.line_of[i] == pool.line_of[first.configs[q - 1].index] &&
                           pool.step_of[i] == pool.step_of[first.configs[q - 1].index] + 1;
        if (joins && runs.back() < 8) {
            ++runs.back();
        } else {
            runs.push_back(1);
        }
    }
    EXPECT_GE(runs.size(), 2u);
    EXPECT_LE(runs.size(), 4u);
    for (int n : runs) {
        EXPECT_GE(n, 2);
    }
}

}  // namespace
}  // namespace gonio::acquisition::fit_sweeps_test
