// The fit-driven plan with fly scans: its pool of sweep lines and the choice of each batch as
// sweeps (fit_sweeps.h).

#include "gonio/acquisition/point/fit_sweeps.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace gonio::acquisition {

namespace {

constexpr double kDeg = brdf::kPi / 180;
/// Tilts of the arm plane away from the sample normal, degrees (0: the plane of incidence).
constexpr double kLineTiltsDeg[] = {0, 15, 30, 45, 60};
/// The standing light arm's angles, degrees (an anisotropic pool has them on both sides).
constexpr double kLineLightDeg[] = {0, 10, 20, 30, 40, 50, 60, 70};
/// Spins of an anisotropic pool's lines: every 30 deg of the sample's turn, off the ends of the
/// spin's range (-165 .. 165 deg).
constexpr double kLineSpinStepDeg = 30;
/// Travel at cruise speed before the first trigger and after the last frame (fly_plan.cpp).
constexpr double kCruiseMarginRad = 0.2 * kDeg;

/// Where a line stands: the sample's tilt and spin, the light arm; the detector turns on `side`.
struct LineStand {
    double tau = 0;
    double b = 0;
    int side = 1;
    double spin = 0;
};

/// A frame of a line before the pool is filtered.
struct LineFrame {
    double angle = 0;
    PlannedConfig config;
};

/// The frames of line `ls` on its side of the light: every kFitSweepGapRad of the detector arm
/// beyond the blind zone with both directions within theta_max. An isotropic pool's
/// configurations are canonical triples; an anisotropic one's keep the spin's azimuths.
std::vector<LineFrame> line_frames(const LineStand& ls,
                                   double theta_max,
                                   bool anisotropic,
                                   const RigLimits& lim) {
    std::vector<LineFrame> out;
    const double cos_max = std::cos(theta_max);
    const int axis = static_cast<int>(AxisRole::kDetector);
    if (std::cos(ls.b) * std::cos(ls.tau) < cos_max) {
        return out;  // the light beyond theta_max
    }
    for (int k = 0;; ++k) {
        const double a = ls.b + ls.side * (lim.blind_angle + k * kFitSweepGapRad);
        if (std::abs(a) > brdf::kPi / 2 || std::cos(a) * std::cos(ls.tau) < cos_max) {
            break;  // beyond theta_max: no more frames
        }
        if (std::abs(a) <= std::abs(ls.b)) {
            // The detector nearer the normal than the light: the same configurations as the
            // lines whose light stands there (reciprocity), and the solver would measure them
            // with the arms exchanged and mirrored, a pose away from the line's.
            continue;
        }
        brdf::RigPosed p;
        p.light = ls.b;
        p.tilt = ls.tau;
        p.spin = ls.spin;
        set_axis_angle(&p, axis, a);
        LineFrame f;
        f.angle = a;
        std::tie(f.config.wi, f.config.wo) = brdf::rig_forward(p);
        f.config.isotropic = !anisotropic;
        out.push_back(f);
        if (k > 400) {
            break;
        }
    }
    if (ls.side < 0) {
        std::reverse(out.begin(), out.end());
    }
    return out;
}

/// The spins of an anisotropic pool's lines, radians: a full turn, half of it for a 2-fold
/// sample (a half turn measures the same); an isotropic pool's lines stand at spin 0.
std::vector<double> line_spins(const FitPlanSpec& spec) {
    if (!spec.anisotropic) {
        return {0.0};
    }
    const bool two_fold = spec.symmetry == SampleSymmetry::kTwoFold;
    const double first = two_fold ? -90 + 0.5 * kLineSpinStepDeg : -180 + 0.5 * kLineSpinStepDeg;
    const double last = two_fold ? 90 : 180;
    std::vector<double> out;
    for (double s = first; s < last; s += kLineSpinStepDeg) {
        out.push_back(s * kDeg);
    }
    return out;
}

/// Every line's stand. Isotropy and the rig's mirror symmetries make tau >= 0 and b >= 0 enough
/// for an isotropic sample (b = 0 on one side only). An anisotropic sample's lines turn through
/// the spins, and its light stands on both sides of the normal (tilting the other way is the same
/// configuration at the opposite spin), except for a mirror-symmetric sample (b and the spin
/// mirrored measure the same).
std::vector<LineStand> line_stands(const FitPlanSpec& spec) {
    const bool both_sides = spec.anisotropic && spec.symmetry != SampleSymmetry::kMirror;
    std::vector<LineStand> out;
    for (double spin : line_spins(spec)) {
        for (double tau_deg : kLineTiltsDeg) {
            for (double b_deg : kLineLightDeg) {
                for (double sign : {1.0, -1.0}) {
                    if (sign < 0 && (!both_sides || b_deg == 0)) {
                        continue;
                    }
                    for (int side : {1, -1}) {
                        if (b_deg == 0 && side < 0 && !spec.anisotropic) {
                            continue;  // the mirror image of the other side
                        }
                        out.push_back(LineStand{tau_deg * kDeg, sign * b_deg * kDeg, side, spin});
                    }
                }
            }
        }
    }
    return out;
}

/// Whether the configuration goes into the pool: reachable, and inside the scene's ROI (its
/// weight and flag set).
bool keep_frame(const std::optional<Scene>& scene, const RigLimits& lim, PlannedConfig* c) {
    if (scene) {
        const double w = roi_weight(*scene, *c);
        if (w <= 0) {
            return false;
        }
        c->flags |= brdf::kFlagRoi;
        c->weight *= w;
    }
    const std::array<AxisDynamics, kNumAxes> dyn{};
    return solve(Target{c->wi, c->wo, c->isotropic, true}, lim, dyn, brdf::RigPosed{}).has_value();
}

/// Adds the kept frames of one line as lines of consecutive frames (a dropped frame splits it; a
/// piece of one frame is dropped too).
void add_line(const std::vector<LineFrame>& frames,
              const LineStand& ls,
              const std::optional<Scene>& scene,
              const RigLimits& lim,
              const SweepLine& shape,
              FitSweepPool* out) {
    SweepLine line = shape;
    auto close = [&]() {
        if (line.frames.size() >= 2) {
            out->lines.push_back(line);
        } else {
            // A lone frame is no sweep: it leaves the pool (it was the last one added).
            out->pool.configs.resize(out->pool.configs.size() - line.frames.size());
        }
        line = shape;
    };
    for (const LineFrame& f : frames) {
        PlannedConfig c = f.config;
        if (!keep_frame(scene, lim, &c)) {
            close();
            continue;
        }
        if (line.frames.empty()) {
            line.stand.light = ls.b;
            line.stand.tilt = ls.tau;
            line.stand.spin = ls.spin;
            set_axis_angle(&line.stand, line.axis, f.angle);
        }
        c.index = static_cast<std::uint32_t>(out->pool.configs.size());
        line.frames.push_back(out->pool.configs.size());
        line.angles.push_back(f.angle);
        out->pool.configs.push_back(c);
    }
    close();
}

/// Each window's gain sum: prefix sums of the frames' gains along a line.
std::vector<double> prefix_gain(const SweepLine& line, const std::vector<double>& gain) {
    std::vector<double> p(line.frames.size() + 1, 0.0);
    for (std::size_t k = 0; k < line.frames.size(); ++k) {
        p[k + 1] = p[k] + gain[line.frames[k]];
    }
    return p;
}

/// A chosen window.
struct Window {
    std::size_t line = 0, s = 0, e = 0;
    double score = 0;
};

/// The window of most gain per rig second from `at`, among those with at least two frames not
/// taken and at most `room` of them.
std::optional<Window> best_window(const std::vector<double>& gain,
                                  const std::vector<bool>& taken,
                                  const brdf::RigPosed& at,
                                  const SweepChoiceInput& in,
                                  int room) {
    std::optional<Window> best;
    const FitSweepPool& pool = *in.pool;
    for (std::size_t l = 0; l < pool.lines.size(); ++l) {
        const SweepLine& line = pool.lines[l];
        const std::vector<double> p = prefix_gain(line, gain);
        const std::size_t n = line.frames.size();
        for (std::size_t s = 0; s < n; ++s) {
            int open = 0;
            for (std::size_t e = s; e < n && e < s + kMaxSweepFrames; ++e) {
                open += !taken[line.frames[e]];
                if (open > room) {
                    break;
                }
                if (open < 2 || taken[line.frames[e]] || taken[line.frames[s]]) {
                    continue;
                }
                brdf::RigPosed exit;
                const double score = (p[e + 1] - p[s]) / sweep_cost_s(line, s, e, at, in, &exit);
                if (std::isfinite(score) && score > 0 && (!best || score > best->score)) {
                    best = Window{l, s, e, score};
                }
            }
        }
    }
    return best;
}

/// The frames of a window not yet taken, marked taken and appended with `reason`.
std::vector<std::size_t> take_window(const SweepLine& line,
                                     std::size_t s,
                                     std::size_t e,
                                     ChoiceReason reason,
                                     std::vector<bool>* taken,
                                     BatchChoice* out) {
    std::vector<std::size_t> got;
    for (std::size_t k = s; k <= e; ++k) {
        const std::size_t i = line.frames[k];
        if (!(*taken)[i]) {
            (*taken)[i] = true;
            got.push_back(i);
            out->chosen.push_back(i);
            out->reasons.push_back(reason);
            out->predictive_var.push_back(0);
            out->misfit.push_back(0);
        }
    }
    return got;
}

/// Sweeps chosen for what the fit expects them to teach, until `target` frames are taken.
void information_sweeps(const std::vector<CandidateForPlan>& candidates,
                        const SweepChoiceInput& in,
                        const FitChoiceOptions& o,
                        int target,
                        int max_frames,
                        std::vector<bool>* taken,
                        brdf::RigPosed* at,
                        SweepChoice* out) {
    const FitView& fit = *in.fit;
    const int p = fit.parameters;
    std::vector<double> cov = fit.covariance;
    std::vector<double> misfit = misfit_variance(candidates, *in.measured, o.length_scale);
    const double s2 = std::max(in.noise_rel_var, 1e-12);
    const double l2 = 2 * o.length_scale * o.length_scale;
    while (static_cast<int>(out->frames.chosen.size()) < target) {
        std::vector<double> gain(candidates.size(), 0.0), var(candidates.size(), 0.0);
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            if (!(*taken)[i]) {
                var[i] = predictive_variance(cov, &fit.jacobian[i * p], p);
                gain[i] = 0.5 * std::log1p((var[i] + misfit[i]) / s2);
            }
        }
        const int room = max_frames - static_cast<int>(out->frames.chosen.size());
        const auto w = best_window(gain, *taken, *at, in, std::min(room, kMaxSweepFrames));
        if (!w) {
            return;  // nothing left that the fit expects to teach
        }
        const SweepLine& line = in.pool->lines[w->line];
        std::size_t first = out->frames.chosen.size();
        for (std::size_t i :
             take_window(line, w->s, w->e, ChoiceReason::kVariance, taken, &out->frames)) {
            const std::size_t q = first++;
            out->frames.reasons[q] =
                var[i] >= misfit[i] ? ChoiceReason::kVariance : ChoiceReason::kMisfit;
            out->frames.predictive_var[q] = var[i];
            out->frames.misfit[q] = misfit[i];
            measured_update(&cov, &fit.jacobian[i * p], p, s2);
            for (std::size_t j = 0; j < candidates.size(); ++j) {
                const double d = feature_distance(candidates[j].where, candidates[i].where);
                misfit[j] *= 1 - std::exp(-d * d / l2);
            }
        }
        sweep_cost_s(line, w->s, w->e, *at, in, at);
        out->score.push_back(w->score);
        ++out->sweeps;
    }
}

/// Space-filling sweeps: in.space_frames frames of the line through the frame farthest from
/// everything measured or chosen, until `target` frames are taken.
void space_sweeps(const std::vector<CandidateForPlan>& candidates,
                  const SweepChoiceInput& in,
                  int target,
                  int max_frames,
                  std::vector<bool>* taken,
                  SweepChoice* out) {
    std::vector<double> nearest(candidates.size(), std::numeric_limits<double>::infinity());
    auto near_to = [&](std::size_t c) {
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            nearest[i] =
                std::min(nearest[i], feature_distance(candidates[i].where, candidates[c].where));
        }
    };
    for (const MeasuredForPlan& m : *in.measured) {
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            nearest[i] = std::min(nearest[i], feature_distance(candidates[i].where, m.where));
        }
    }
    for (std::size_t c : out->frames.chosen) {
        near_to(c);
    }
    while (static_cast<int>(out->frames.chosen.size()) < target) {
        std::size_t far = candidates.size();
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            if (!(*taken)[i] && (far == candidates.size() || nearest[i] > nearest[far])) {
                far = i;
            }
        }
        if (far == candidates.size()) {
            return;
        }
        const SweepLine& line = in.pool->lines[in.pool->line_of[far]];
        const int room =
            std::min(in.space_frames, max_frames - static_cast<int>(out->frames.chosen.size()));
        const std::size_t step = in.pool->step_of[far];
        std::size_t s = step, e = step;
        for (int open = 1; open < room;) {
            const bool up = e + 1 < line.frames.size() && !(*taken)[line.frames[e + 1]];
            const bool down = s > 0 && !(*taken)[line.frames[s - 1]];
            if (!up && !down) {
                break;
            }
            if (up && (!down || e - step <= step - s)) {
                ++e;
            } else {
                --s;
            }
            ++open;
        }
        for (std::size_t i : take_window(line, s, e, ChoiceReason::kSpace, taken, &out->frames)) {
            near_to(i);
        }
        ++out->sweeps;
    }
}

/// The angle equivalent to `spin` (by whole turns) within `range` nearest to `from` (`spin`
/// itself when no turn of it lies in the range).
double nearest_turn(double spin, double from, const AxisRange& range) {
    const double turn = 2 * brdf::kPi;
    double best = spin;
    const double base = spin + turn * std::round((from - spin) / turn);
    for (int k = -1; k <= 1; ++k) {
        const double c = base + k * turn;
        const bool inside = c >= range.min - 1e-12 && c <= range.max + 1e-12;
        if (inside && std::abs(c - from) < std::abs(best - from)) {
            best = c;
        }
    }
    return best;
}

/// Where the rig stood at the last measurement of the passes before `pass` (journal order).
brdf::RigPosed last_pose(const std::vector<JournalRecord>& records, int pass) {
    brdf::RigPosed p;
    for (const JournalRecord& r : records) {
        if (r.type == RecordType::kMeasurement && r.pass < pass) {
            p = brdf::RigPosed{r.pose_deg[0] * kDeg,
                               r.pose_deg[1] * kDeg,
                               r.pose_deg[2] * kDeg,
                               r.pose_deg[3] * kDeg};
        }
    }
    return p;
}

}  // namespace

FlyLimits fly_limits_of(const RigConfig& rig) {
    FlyLimits l;
    l.dyn = rig_dynamics(rig);
    l.range = rig_limits(rig).range;
    l.readout_s = rig.camera_readout_ms / 1000.0;
    l.min_exposure_s = rig.capture.min_exposure_us * 1e-6;
    l.max_exposure_s = rig.capture.max_exposure_us * 1e-6;
    return l;
}

Expected<FitSweepPool> fit_sweep_pool(const FitPlanSpec& spec,
                                      const FlySpec& fly,
                                      const std::string& scene,
                                      const RigConfig& rig) {
    if (auto ok = check_fit_plan_spec(spec); !ok) {
        return tl::unexpected(ok.error());
    }
    std::optional<Scene> sc;
    if (!scene.empty()) {
        auto s = read_scene(scene);
        if (!s) {
            return tl::unexpected(s.error());
        }
        sc = std::move(*s);
    }
    const RigLimits lim = rig_limits(rig);
    const FlyLimits fl = fly_limits_of(rig);
    FitSweepPool out;
    out.pool.kind = "fit";
    out.anisotropic = spec.anisotropic;
    out.spin_range = lim.range[static_cast<int>(AxisRole::kSpin)];
    SweepLine shape;
    const SweepSpeed v = sweep_speed(kFitSweepGapRad, shape.axis, fly, fl);
    shape.speed = v.speed;
    const double smear = std::min(fly.max_smear_deg * kDeg, 0.25 * kFitSweepGapRad);
    shape.ramp =
        v.speed * v.speed / (2 * fl.dyn[shape.axis].accel) + 0.5 * smear + kCruiseMarginRad;
    for (const LineStand& ls : line_stands(spec)) {
        add_line(line_frames(ls, spec.theta_max, spec.anisotropic, lim), ls, sc, lim, shape, &out);
    }
    out.line_of.assign(out.pool.configs.size(), 0);
    out.step_of.assign(out.pool.configs.size(), 0);
    for (std::size_t l = 0; l < out.lines.size(); ++l) {
        for (std::size_t k = 0; k < out.lines[l].frames.size(); ++k) {
            out.line_of[out.lines[l].frames[k]] = l;
            out.step_of[out.lines[l].frames[k]] = k;
        }
    }
    if (out.lines.empty()) {
        return make_error("fly: no sweep line of the fit plan is within the rig's limits" +
                          std::string(sc ? " and the scene's ROI" : ""));
    }
    return out;
}

double sweep_cost_s(const SweepLine& line,
                    std::size_t s,
                    std::size_t e,
                    const brdf::RigPosed& at,
                    const SweepChoiceInput& in,
                    brdf::RigPosed* exit_pose) {
    brdf::RigPosed lo = line.stand, hi = line.stand;
    // An isotropic sample is measured at any spin; an anisotropic one turns to the line's, the
    // nearer way round.
    lo.spin = hi.spin = in.pool->anisotropic
                            ? nearest_turn(line.stand.spin, at.spin, in.pool->spin_range)
                            : at.spin;
    set_axis_angle(&lo, line.axis, line.angles[s] - line.ramp);
    set_axis_angle(&hi, line.axis, line.angles[e] + line.ramp);
    const double to_lo = move_time(at, lo, in.dyn);
    const double to_hi = move_time(at, hi, in.dyn);
    *exit_pose = to_lo <= to_hi ? hi : lo;
    const double travel = line.angles[e] - line.angles[s] + 2 * line.ramp;
    const double frames = static_cast<double>(e - s + 1);
    return std::min(to_lo, to_hi) + trapezoid_time(travel, line.speed, in.dyn[line.axis].accel) +
           in.overhead_s + frames * in.readout_s;
}

SweepChoice choose_sweeps(const std::vector<CandidateForPlan>& candidates,
                          const SweepChoiceInput& in,
                          const FitChoiceOptions& o,
                          int max_frames) {
    SweepChoice out;
    std::vector<bool> taken(candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        taken[i] = !candidates[i].available;
    }
    int n_space = o.count;
    if (fit_is_usable(in.fit, candidates.size())) {
        n_space = std::min(o.count,
                           std::max(o.count >= 2 && o.space_share > 0 ? 1 : 0,
                                    static_cast<int>(std::lround(o.space_share * o.count))));
        brdf::RigPosed at = in.start;
        // The space-filling share is kept within the budget.
        information_sweeps(
            candidates, in, o, o.count - n_space, max_frames - n_space, &taken, &at, &out);
    }
    // What the fit expected nothing from goes to filling space too.
    const int target = std::max(o.count, static_cast<int>(out.frames.chosen.size()) + n_space);
    space_sweeps(candidates, in, std::min(target, max_frames), max_frames, &taken, &out);
    return out;
}

Plan fit_first_sweeps(const FitSweepPool& pool, const FitPlanSpec& spec) {
    std::vector<CandidateForPlan> cands;
    for (const PlannedConfig& c : pool.pool.configs) {
        CandidateForPlan k;
        k.where = plan_features(c);
        cands.push_back(k);
    }
    const std::vector<MeasuredForPlan> none;
    SweepChoiceInput in;
    in.pool = &pool;
    in.measured = &none;
    in.space_frames = std::max(kSpaceSweepFrames, spec.first / 2);
    FitChoiceOptions o;
    o.count = spec.first;
    const SweepChoice c = choose_sweeps(cands, in, o, spec.first);
    Plan first;
    first.kind = "fit";
    for (std::size_t k : c.frames.chosen) {
        first.configs.push_back(pool.pool.configs[k]);
    }
    return first;
}

FitBatch fit_next_sweeps(const std::vector<JournalRecord>& records,
                         int pass,
                         const FitSweepPool& pool,
                         const FitPlanSpec& spec,
                         const RigConfig& rig,
                         const PlanFitFn& fit) {
    FitBatch out;
    const FitBatchInputs in = fit_batch_inputs(records, pass, pool.pool, spec, rig, fit, &out);
    if (in.count <= 0) {
        return out;
    }
    SweepChoiceInput si;
    si.pool = &pool;
    si.measured = &in.for_plan;
    si.fit = in.fit ? &in.fit->view : nullptr;
    si.noise_rel_var = in.noise_rel_var;
    si.start = last_pose(records, pass);
    si.dyn = rig_dynamics(rig);
    si.readout_s = rig.camera_readout_ms / 1000.0;
    double settle = 0;
    for (const AxisDynamics& d : si.dyn) {
        settle = std::max(settle, d.settle_s);
    }
    si.overhead_s = settle + rig.capture.dark_frames * si.readout_s;
    FitChoiceOptions o;
    o.count = in.count;
    o.space_share = spec.space_share;
    const int room = spec.budget - static_cast<int>(in.measured.size());
    const SweepChoice c = choose_sweeps(in.candidates, si, o, room);
    for (std::size_t k : c.frames.chosen) {
        out.plan.configs.push_back(pool.pool.configs[k]);
    }
    out.sweeps = c.sweeps;
    describe_batch(in, c.frames, &out);
    out.note += " in " + std::to_string(c.sweeps) + " sweeps";
    return out;
}

}  // namespace gonio::acquisition
