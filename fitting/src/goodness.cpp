// Goodness of fit: error metrics, lobe shares and the verdict on whether the model represents the
// data (docs/fitting-guide.md, "Goodness of fit").

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "fit_stages.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/thread_pool.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/values_below_zero.h"
#include "gonio/fitting/exposure_paths.h"
#include "gonio/fitting/vector_log.h"

namespace gonio::fitting {

namespace {

using brdf::ModelD;
using brdf::Rgbd;
using brdf::Sample;

constexpr double kBandEdgesDeg[] = {0, 2, 5, 10, 20, 40, 90};
/// The median relative error counts the values above this many of their noise sigmas.
constexpr double kSignalSigmas = 2;
/// From this many samples on the medians of the three channels run on the pool.
constexpr std::size_t kParallelMedianSamples = 65536;

constexpr int kBands = static_cast<int>(sizeof kBandEdgesDeg / sizeof kBandEdgesDeg[0]) - 1;

/// Sums of squared residuals (rows: absolute, relative, log; columns: channels) and of the log
/// residuals per theta_h band.
struct MetricSums {
    Eigen::Array<double, 3, 3> sq = Eigen::Array<double, 3, 3>::Zero();
    Eigen::Array<double, kBands, 3> band_sum = Eigen::Array<double, kBands, 3>::Zero();
    Eigen::Array<double, kBands, 3> band_sq = Eigen::Array<double, kBands, 3>::Zero();
    std::array<std::size_t, kBands> band_n{};

    MetricSums& operator+=(const MetricSums& p) {
        sq += p.sq;
        band_sum += p.band_sum;
        band_sq += p.band_sq;
        for (int k = 0; k < kBands; ++k) {
            band_n[k] += p.band_n[k];
        }
        return *this;
    }
};

/// cos of each band edge, in kBandEdgesDeg's order.
std::array<double, kBands + 1> band_cosines() {
    std::array<double, kBands + 1> band_cos;
    for (int b = 0; b <= kBands; ++b) {
        band_cos[b] = std::cos(kBandEdgesDeg[b] * brdf::kPi / 180);
    }
    return band_cos;
}

/// The theta_h band of cos_h (the last one beyond every edge).
int band_of(double cos_h, const std::array<double, kBands + 1>& band_cos) {
    for (int k = 0; k < kBands; ++k) {
        if (cos_h > band_cos[k + 1]) {
            return k;
        }
    }
    return kBands - 1;
}

/// Median of the relative errors (the lower median for an even count; NaN entries are not
/// errors), the three channels on the pool for a large set (a selection over a million values
/// takes about 15 ms).
void median_relative(std::vector<double> (&rel)[3], int threads, Rgbd* median_rel) {
    gonio::parallel_for(3, 1, threads, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
            std::vector<double>& v = rel[c];
            v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }),
                    v.end());
            if (!v.empty()) {
                const std::size_t k = (v.size() - 1) / 2;
                std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
                (*median_rel)[static_cast<int>(c)] = v[k];
            }
        }
    });
}

/// The mean and rms log residual of each band that holds samples.
std::vector<BandResidual> band_residuals(const MetricSums& total) {
    std::vector<BandResidual> bands;
    for (int k = 0; k < kBands; ++k) {
        if (total.band_n[k] == 0) {
            continue;
        }
        BandResidual b;
        b.theta_h_lo_deg = kBandEdgesDeg[k];
        b.theta_h_hi_deg = kBandEdgesDeg[k + 1];
        b.count = total.band_n[k];
        const double bn = static_cast<double>(b.count);
        for (int c = 0; c < 3; ++c) {
            b.mean_log[c] = total.band_sum(k, c) / bn;
            b.log_rmse[c] = std::sqrt(total.band_sq(k, c) / bn);
        }
        bands.push_back(b);
    }
    return bands;
}

/// The metrics of model values against `samples`: at(i, f, cos_i, cos_h, log_r) gives sample i's
/// model value (RGB, 1/sr), cos theta_i and cos theta_h, and returns true when it also gave the
/// log residuals log(1 + f cos_i) - log(1 + d cos_i) of the three channels in log_r.
template <class At>
Metrics metrics_of(const std::vector<Sample>& samples, double relative_floor, const At& at) {
    Metrics m;
    if (samples.empty()) {
        return m;
    }
    const int threads = detail::thread_count(0);
    // Per block, added in block order (the same metrics for every thread count).
    std::vector<MetricSums> partial(block_count(samples.size()));
    // |m - d| / d per sample and channel (NaN where d <= 0: no relative error), for the medians.
    std::vector<double> rel[3];
    for (int c = 0; c < 3; ++c) {
        resize_huge(rel[c], samples.size(), std::numeric_limits<double>::quiet_NaN());
    }
    const double implied = brdf::implied_noise(samples);
    const std::array<double, kBands + 1> band_cos = band_cosines();
    auto body = [&](std::size_t blk, std::size_t b, std::size_t e) {
        MetricSums acc;
        for (std::size_t i = b; i < e; ++i) {
            Rgbd f;
            double cos_i = 0, cos_h = 0;
            double logs[3];
            const bool have_logs = at(i, f, cos_i, cos_h, logs);
            const int band = band_of(cos_h, band_cos);
            ++acc.band_n[band];
            for (int c = 0; c < 3; ++c) {
                const double d = samples[i].value[c];
                const double abs_r = f[c] - d;
                const double rel_r =
                    channel_residual(ResidualForm::kRelative, f[c], d, cos_i, relative_floor);
                const double log_r =
                    have_logs ? logs[c] : channel_residual(ResidualForm::kLog, f[c], d, cos_i, 0);
                // Where the value is above its noise: a relative error of noise means nothing.
                const double sigma = samples[i].sigma[c] > 0 ? samples[i].sigma[c] : implied;
                if (d > 0 && d > kSignalSigmas * sigma) {
                    rel[c][i] = std::abs(abs_r) / d;
                }
                acc.sq(0, c) += abs_r * abs_r;
                acc.sq(1, c) += rel_r * rel_r;
                acc.sq(2, c) += log_r * log_r;
                acc.band_sum(band, c) += log_r;
                acc.band_sq(band, c) += log_r * log_r;
            }
        }
        partial[blk] = acc;
    };
    parallel_blocks(samples.size(), threads, body);
    MetricSums total;
    for (const MetricSums& p : partial) {
        total += p;
    }
    const double n = static_cast<double>(samples.size());
    for (int c = 0; c < 3; ++c) {
        m.rmse[c] = std::sqrt(total.sq(0, c) / n);
        m.rel_rmse[c] = std::sqrt(total.sq(1, c) / n);
        m.log_rmse[c] = std::sqrt(total.sq(2, c) / n);
    }
    median_relative(rel, samples.size() > kParallelMedianSamples ? threads : 1, &m.median_rel);
    m.bands = band_residuals(total);
    return m;
}

}  // namespace

Metrics evaluate_metrics(const ModelD& model,
                         const std::vector<Sample>& samples,
                         double relative_floor) {
    return metrics_of(samples,
                      relative_floor,
                      [&](std::size_t i, Rgbd& f, double& cos_i, double& cos_h, double*) {
                          const brdf::Vec3d wi = samples[i].wi();
                          const brdf::Vec3d wo = samples[i].wo();
                          f = sample_model_value(model, samples[i]);
                          cos_i = wi.z();
                          cos_h = (wi.z() + wo.z()) / (wi + wo).norm();
                          return false;
                      });
}

namespace detail {

Metrics evaluate_metrics(const ModelD& model,
                         const std::vector<Sample>& samples,
                         double relative_floor,
                         const PreparedSamples& ps,
                         int threads) {
    if (ps.size() != samples.size() || !ps.has_cos_h()) {
        return fitting::evaluate_metrics(model, samples, relative_floor);
    }
    std::vector<Rgbd> values;
    ps.model_values(model, values, threads);
    // With the log residual the prepared samples hold log(1 + d cos_i) (the same expression);
    // log(1 + f cos_i) of every sample and channel on packets (vector_log.h, within 1 ulp of
    // std::log1p).
    const bool log_form = ps.log_of_data();
    std::vector<double> log_m;
    if (log_form) {
        resize_huge(log_m, 3 * samples.size());
        parallel_ranges(samples.size(), threads, [&](std::size_t, std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) {
                for (int c = 0; c < 3; ++c) {
                    log_m[3 * i + c] = values[i][c] * ps.cos_i(i);
                }
            }
            log1p_packets(log_m.data() + 3 * b, log_m.data() + 3 * b, 3 * (e - b));
        });
    }
    return metrics_of(samples,
                      relative_floor,
                      [&](std::size_t i, Rgbd& f, double& cos_i, double& cos_h, double* log_r) {
                          f = values[i];
                          cos_i = ps.cos_i(i);
                          cos_h = ps.cos_h(i);
                          if (log_form) {
                              for (int c = 0; c < 3; ++c) {
                                  log_r[c] = log_m[3 * i + c] - ps.log_of_data(c, i);
                              }
                          }
                          return log_form;
                      });
}

}  // namespace detail

namespace detail {

namespace {

constexpr double kVanishedShare = 1e-3;  // a lobe below this share of the reflectance vanished
// Goodness of fit: thresholds of a misfit far beyond measurement noise (docs/fitting-guide.md).
constexpr double kLogRmseUnusable = 0.3;
constexpr double kLogRmseWarn = 0.15;
constexpr double kBandBiasUnusable = 0.3;
constexpr double kBandBiasWarn = 0.15;
// Median relative error |m - d| / d of a channel: 2 % multiplicative noise alone gives 1.35 %
// (0.674 sigma), so 5 % is a misfit well beyond such noise and 15 % one that changes the colour.
constexpr double kMedianRelWarn = 0.05;
constexpr double kMedianRelUnusable = 0.15;
constexpr double kChi2Unusable = 10;
constexpr double kChi2Warn = 2;
// A chi-square far above 1 makes a fit unusable only when the misfit is also of a size that matters
// (log RMSE above 2 %): below it the stated sigmas (photon noise of a region mean, often 1e-5
// relative) are simply smaller than the rig's systematic errors, which is a warning, not a failure.
constexpr double kLogRmsePractical = 0.02;

}  // namespace

/// Each lobe's share of the model's reflectance summed (weighted, channel mean) over `samples`:
/// sum_i w_i mean_c lobe_l(i) / sum_i w_i mean_c model(i). All zero when the model is zero on
/// every sample (nothing to share).
std::vector<double> lobe_shares(const ModelD& model, const std::vector<Sample>& samples) {
    std::vector<double> lobe_sum(model.lobes.size(), 0.0);
    double total = 0;
    // The model's value is its diffuse term plus its lobes' values added in lobe order, as
    // eval_model adds them (the same value), so each lobe is evaluated once.
    ModelD diffuse_only = model;
    diffuse_only.lobes.clear();
    for (const Sample& s : samples) {
        const brdf::Vec3d wi = s.wi();
        const brdf::Vec3d wo = s.wo();
        Rgbd f = brdf::eval_model(diffuse_only, wi, wo);
        for (std::size_t l = 0; l < model.lobes.size(); ++l) {
            const Rgbd lobe = brdf::eval_lobe(model.lobes[l], wi, wo);
            f += lobe;
            lobe_sum[l] += s.weight * lobe.mean();
        }
        total += s.weight * f.mean();
    }
    for (double& v : lobe_sum) {
        // A zero model (all-zero data): every lobe has vanished.
        v = total > 0 ? v / total : 0.0;
    }
    return lobe_sum;
}

namespace {

const char* const kChannelNames[3] = {"r", "g", "b"};

/// The state of one finding and the worst of several.
Verdict worse(Verdict a, Verdict b) {
    return static_cast<int>(a) > static_cast<int>(b) ? a : b;
}

/// A finding of the judgement: its state, the channel it concerns (-1: all) and its words.
struct Finding {
    Verdict state = Verdict::kRepresents;
    int channel = -1;
    std::string figure;   ///< "median relative error 0.091 above 0.05"
    std::string warning;  ///< the warning line of the report
};

/// A figure against its two limits: a visible misfit above `warn`, no representation above `bad`
/// (or when not finite).
Verdict grade(double v, double warn, double bad) {
    if (!std::isfinite(v) || v > bad) {
        return Verdict::kDoesNotRepresent;
    }
    return v > warn ? Verdict::kVisibleMisfit : Verdict::kRepresents;
}

std::string fmt(const char* format, double a, double b) {
    char buf[96];
    std::snprintf(buf, sizeof buf, format, a, b);
    return buf;
}

void channel_findings(const Metrics& m, std::vector<Finding>& out) {
    for (int c = 0; c < 3; ++c) {
        const double v = m.log_rmse[c];
        const Verdict g = grade(v, kLogRmseWarn, kLogRmseUnusable);
        if (g != Verdict::kRepresents) {
            const double limit = g == Verdict::kVisibleMisfit ? kLogRmseWarn : kLogRmseUnusable;
            const std::string figure = fmt("log RMSE %.3g above %.2g", v, limit);
            out.push_back(
                {g,
                 c,
                 figure,
                 std::string("log RMSE of channel ") + kChannelNames[c] + " = " +
                     fmt("%.3g above %.2g", v, limit) +
                     (g == Verdict::kVisibleMisfit ? ": a visible misfit"
                                                   : ": the model does not represent these data")});
        }
    }
    for (int c = 0; c < 3; ++c) {
        // The relative error of f itself: sees a dark channel that log(1 + f cos) cannot.
        const double v = m.median_rel[c];
        const Verdict g = grade(v, kMedianRelWarn, kMedianRelUnusable);
        if (g != Verdict::kRepresents) {
            const double limit = g == Verdict::kVisibleMisfit ? kMedianRelWarn : kMedianRelUnusable;
            out.push_back({g,
                           c,
                           fmt("median relative error %.3g above %.2g", v, limit),
                           std::string("median relative error |m - d| / d of channel ") +
                               kChannelNames[c] + " = " + fmt("%.3g above %.2g", v, limit) +
                               (g == Verdict::kVisibleMisfit
                                    ? ": a visible misfit in this channel"
                                    : ": the model does not represent this channel")});
        }
    }
}

void band_findings(const Metrics& m, std::size_t valid, std::vector<Finding>& out) {
    char buf[256];
    for (const BandResidual& b : m.bands) {
        // Bands with under 1 % of the samples do not decide.
        if (b.count * 100 < valid) {
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            const double bias = b.mean_log[c];
            const Verdict g = grade(std::abs(bias), kBandBiasWarn, kBandBiasUnusable);
            if (g == Verdict::kRepresents) {
                continue;
            }
            const double limit = g == Verdict::kVisibleMisfit ? kBandBiasWarn : kBandBiasUnusable;
            std::snprintf(buf,
                          sizeof buf,
                          "theta_h in [%g, %g) deg: mean log residual of channel %s = %+.3g "
                          "(the model is %s there; limit +-%.2g)",
                          b.theta_h_lo_deg,
                          b.theta_h_hi_deg,
                          kChannelNames[c],
                          bias,
                          bias > 0 ? "too bright" : "too dark",
                          limit);
            char figure[128];
            std::snprintf(figure,
                          sizeof figure,
                          "mean log residual %+.3g at theta_h %g-%g deg, limit +-%.2g",
                          bias,
                          b.theta_h_lo_deg,
                          b.theta_h_hi_deg,
                          limit);
            out.push_back({g, c, figure, buf});
        }
    }
}

void chi_square_findings(std::optional<double> chi2,
                         double worst_log_rmse,
                         std::vector<Finding>& out) {
    if (!chi2) {
        return;
    }
    char buf[256];
    if (std::isfinite(*chi2) && *chi2 > kChi2Unusable && worst_log_rmse <= kLogRmsePractical) {
        std::snprintf(buf,
                      sizeof buf,
                      "reduced chi-square = %.3g above %g, but the worst log RMSE is only "
                      "%.3g (limit %.2g): the stated sigmas are far smaller than the "
                      "systematic errors of the data or the model",
                      *chi2,
                      kChi2Unusable,
                      worst_log_rmse,
                      kLogRmsePractical);
        out.push_back({Verdict::kRepresents, -1, "", buf});
    } else if (!std::isfinite(*chi2) || *chi2 > kChi2Unusable) {
        std::snprintf(buf,
                      sizeof buf,
                      "reduced chi-square = %.3g above %g: the misfit is far beyond the "
                      "stated sigmas",
                      *chi2,
                      kChi2Unusable);
        out.push_back({Verdict::kDoesNotRepresent,
                       -1,
                       fmt("reduced chi-square %.3g above %g", *chi2, kChi2Unusable),
                       buf});
    } else if (*chi2 > kChi2Warn) {
        std::snprintf(buf,
                      sizeof buf,
                      "reduced chi-square = %.3g above %g: misfit beyond the stated sigmas "
                      "(or sigmas too small)",
                      *chi2,
                      kChi2Warn);
        out.push_back({Verdict::kVisibleMisfit,
                       -1,
                       fmt("reduced chi-square %.3g above %g", *chi2, kChi2Warn),
                       buf});
    }
}

/// "channel b (median relative error 0.091 above 0.05)": the findings of the headline's state,
/// the first figure of each channel.
std::string named_findings(const std::vector<Finding>& findings, Verdict state) {
    std::string s;
    bool seen[4] = {false, false, false, false};
    for (const Finding& f : findings) {
        if (f.state != state || seen[f.channel + 1]) {
            continue;
        }
        seen[f.channel + 1] = true;
        s += s.empty() ? "" : "; ";
        s += f.channel >= 0
                 ? std::string("channel ") + kChannelNames[f.channel] + " (" + f.figure + ")"
                 : f.figure;
    }
    return s;
}

}  // namespace

/// Goodness of fit from the metrics (and the reduced chi-square when the data carry sigmas).
GoodnessOfFit judge(const Metrics& m,
                    std::optional<double> chi2,
                    std::size_t valid,
                    const ModelD& fitted,
                    bool f0_per_channel) {
    GoodnessOfFit g;
    g.reduced_chi_square = chi2;
    std::vector<Finding> findings;
    channel_findings(m, findings);
    band_findings(m, valid, findings);
    chi_square_findings(chi2, m.log_rmse.maxCoeff(), findings);
    for (const Finding& f : findings) {
        g.verdict = worse(g.verdict, f.state);
        g.warnings.push_back(f.warning);
    }
    g.represents = g.verdict != Verdict::kDoesNotRepresent;
    g.headline = headline_of(g.verdict, named_findings(findings, g.verdict));
    if (g.verdict != Verdict::kRepresents) {
        // (A warning that leaves the fit representing its data, such as a chi-square inflated by
        // sigmas smaller than the systematic errors, asks for no other model.)
        g.suggestion = suggest_after(fitted, f0_per_channel, false);
    }
    return g;
}

namespace {

/// lobe_shares from the prepared samples `ps` of the same samples: the diffuse term's and each
/// lobe's values from its geometry, added in the same order, a run of samples at a time (no
/// buffer that grows with the samples).
std::vector<double> lobe_shares(const ModelD& model,
                                const std::vector<Sample>& samples,
                                const PreparedSamples& ps) {
    constexpr std::size_t kRun = 256;
    ModelD diffuse_only = model;
    diffuse_only.lobes.clear();
    std::vector<ModelD> lobe_only(model.lobes.size(), diffuse_only);
    for (std::size_t l = 0; l < model.lobes.size(); ++l) {
        lobe_only[l].has_diffuse = false;
        lobe_only[l].lobes.assign(1, model.lobes[l]);
    }
    std::vector<double> lobe_sum(model.lobes.size(), 0.0);
    double total = 0;
    std::array<Rgbd, kRun> f, lobe;
    for (std::size_t b = 0; b < samples.size(); b += kRun) {
        const std::size_t e = std::min(samples.size(), b + kRun);
        ps.model_values(diffuse_only, b, e, f.data());
        for (std::size_t l = 0; l < model.lobes.size(); ++l) {
            ps.model_values(lobe_only[l], b, e, lobe.data());
            for (std::size_t i = b; i < e; ++i) {
                f[i - b] += lobe[i - b];
                lobe_sum[l] += samples[i].weight * lobe[i - b].mean();
            }
        }
        for (std::size_t i = b; i < e; ++i) {
            total += samples[i].weight * f[i - b].mean();
        }
    }
    for (double& v : lobe_sum) {
        v = total > 0 ? v / total : 0.0;
    }
    return lobe_sum;
}

}  // namespace

std::vector<std::string> vanished_lobes(const ModelD& model,
                                        const std::vector<Sample>& samples,
                                        const PreparedSamples* ps) {
    std::vector<std::string> out;
    if (model.lobes.empty()) {
        return out;
    }
    const std::vector<double> share = ps != nullptr && ps->size() == samples.size()
                                          ? lobe_shares(model, samples, *ps)
                                          : lobe_shares(model, samples);
    for (std::size_t l = 0; l < share.size(); ++l) {
        if (!(share[l] >= kVanishedShare)) {
            out.push_back("lobes[" + std::to_string(l) + "]");
        }
    }
    return out;
}

}  // namespace detail

std::string suggest_after(const ModelD& fitted, bool f0_per_channel, bool auto_tried) {
    if (auto_tried) {
        // Every family was ranked: none of the options below is left untried.
        return {};
    }
    if (fitted.lobes.empty()) {
        return "try a specular lobe (`--lobes 1`) or `--model auto` (ranks ggx, beckmann, "
               "student-t, blinn-phong, two lobes, v-groove shadowing and a tabulated distribution "
               "by BIC)";
    }
    const brdf::Lobe<double>& lobe = fitted.lobes[0];
    const std::string dist = brdf::to_string(lobe.distribution);
    std::vector<std::string> tries = {
        "`--model auto` (ranks ggx, beckmann, student-t, blinn-phong, two lobes, v-groove "
        "shadowing and a tabulated distribution by BIC)"};
    if (fitted.lobes.size() < 2) {
        tries.push_back("a second lobe (`--lobes 2`)");
    }
    if (dist != "student-t") {
        tries.push_back("a distribution with a tail parameter (`--model student-t`)");
    }
    if (dist != "beckmann") {
        tries.push_back("`--model beckmann`");
    }
    if (!f0_per_channel) {
        tries.push_back("`--fresnel schlick-rgb`");
    }
    if (!lobe.rgb_roughness && !lobe.anisotropic &&
        (dist == "ggx" || dist == "beckmann" || dist == "student-t")) {
        tries.push_back("`--roughness rgb`");
    }
    std::string s = "try " + tries[0];
    for (std::size_t k = 1; k < tries.size(); ++k) {
        s += (k + 1 == tries.size() ? " or " : ", ") + tries[k];
    }
    return s;
}

std::string headline_of(Verdict v, const std::string& named) {
    switch (v) {
        case Verdict::kRepresents:
            return "represents these data";
        case Verdict::kVisibleMisfit:
            return "usable, with a visible misfit: " + named;
        case Verdict::kDoesNotRepresent:
            return "MISFIT: does not represent these data: " + named;
    }
    return "";
}

const char* to_string(Verdict v) {
    switch (v) {
        case Verdict::kRepresents:
            return "represents";
        case Verdict::kVisibleMisfit:
            return "visible-misfit";
        case Verdict::kDoesNotRepresent:
            return "does-not-represent";
    }
    return "does-not-represent";
}

Expected<Verdict> parse_verdict(const std::string& name) {
    for (Verdict v : {Verdict::kRepresents, Verdict::kVisibleMisfit, Verdict::kDoesNotRepresent}) {
        if (name == to_string(v)) {
            return v;
        }
    }
    return make_error("verdict \"" + name +
                      "\" (expected represents, visible-misfit or does-not-represent)");
}

}  // namespace gonio::fitting
