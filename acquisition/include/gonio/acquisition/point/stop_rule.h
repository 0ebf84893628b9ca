#pragma once

// A point campaign that stops when its fit is known (`gonio acquire --until sigma=0.01`): between
// batches of measurements a fit of the values measured so far (the front end supplies it, so that
// acquisition needs no fitting library) is checked against the rule, and the campaign stops at the
// first check where both targets hold:
// - sigma: every fitted parameter's relative standard uncertainty is at most this;
// - holdout: the fit predicts the configurations held out of it (every kHoldoutEvery-th
//   measurement in journal order) within the measurement noise: the root mean square of
//   (prediction - value) / sigma over them is at most this.
// The rule is part of the campaign's description (campaign.json "until"), so a resume keeps it.

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"

namespace gonio::acquisition {

/// Every kHoldoutEvery-th measurement (the 5th, 10th, ...) is held out of the fit.
inline constexpr std::size_t kHoldoutEvery = 5;
/// The fewest measurements a check fits.
inline constexpr std::size_t kMinCheckSamples = 12;

struct StopRule {
    double sigma = 0;    ///< Largest relative sigma of a fitted parameter (0: no rule).
    double holdout = 2;  ///< Largest RMS normalised prediction error on the held-out values.
    int every = 0;       ///< Check after every N measurements (0: a tenth of the plan, >= 8).
    bool active() const { return sigma > 0; }
};

/// "sigma=0.01[,holdout=2][,every=N]"; the error names the item and the rule.
Expected<StopRule> parse_stop_rule(const std::string& text);
/// The rule in the syntax parse_stop_rule reads ("" when inactive).
std::string format_stop_rule(const StopRule& rule);

/// What one fit between batches found.
struct FitCheck {
    bool usable = false;       ///< The fit converged.
    double max_rel_sigma = 0;  ///< Largest relative sigma over the free parameters.
    std::string worst;         ///< The parameter that has it.
    double holdout_rms_z = 0;  ///< RMS of (prediction - value) / sigma over held-out values.
    std::size_t fitted = 0;    ///< Values the fit used.
    std::size_t held_out = 0;  ///< Values it predicted.
    std::string parameters;    ///< "name value +- sigma; ..." for the record.
};

/// Fits `fit` and predicts `holdout` (the front end's fitting library). `common_rel_sigma` is the
/// relative uncertainty every value shares (the white reference's, rig_error_budget.h): the fit's
/// amplitudes (diffuse albedo, lobe scales) carry it in full, added to their sigma in quadrature.
/// `anisotropic`: the campaign measures every azimuth, and the model fitted is anisotropic (its
/// slopes and orientation each a parameter of the rule).
using FitCheckFn = std::function<Expected<FitCheck>(const std::vector<brdf::Sample>& fit,
                                                    const std::vector<brdf::Sample>& holdout,
                                                    double common_rel_sigma,
                                                    bool anisotropic)>;

/// Whether the rule holds for a check; `why` receives the targets against the values.
bool rule_holds(const StopRule& rule, const FitCheck& check, std::string* why);

/// Splits samples (journal order) into the fitted and the held-out ones.
void split_holdout(const std::vector<brdf::Sample>& samples,
                   std::vector<brdf::Sample>* fit,
                   std::vector<brdf::Sample>* holdout);

}  // namespace gonio::acquisition
