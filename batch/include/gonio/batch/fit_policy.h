#pragma once

// What a finished fit means to whoever asked for it, decided once for `gonio fit`, manifests and
// gonio.fit(): the exit status (with and without --strict), the message of a misfit, the ranking
// of `--compare`, and the suggestion left when no analytic family represents the data (the
// measurement itself as a table, with that table's own error).

#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/batch/fit_request.h"
#include "gonio/brdf/dataset.h"
#include "gonio/fitting/fit.h"

namespace gonio::batch {

/// Exit status of one fit: 1 when it did not converge, or with `strict` when its verdict is
/// kDoesNotRepresent; 0 otherwise (a converged misfit is a finding, written with its verdict).
int exit_status(const fitting::FitResult& result, bool strict);

/// The misfit in one line, for stderr and Python's warning: "<headline>; <suggestion>" (empty for
/// a fit that represents its data).
std::string misfit_message(const fitting::FitResult& result);

/// One model of a comparison.
struct ComparedFit {
    std::string model;
    fitting::FitResult result;
};

/// `--compare`: the converged fits ranked by their channel-mean log RMSE (misfits ranked with the
/// others: their figures are what that model can do), and the ones that did not converge.
struct Comparison {
    std::vector<ComparedFit> ranked;
    std::vector<std::string> not_converged;  ///< "beckmann: NO_CONVERGENCE (...)"
};

/// Fits each request on `data` and ranks them; an error when one cannot run (naming its model).
Expected<Comparison> compare_fits(const brdf::Dataset& data,
                                  const std::vector<FitRequest>& requests);

/// 1 when a model did not converge, or with `strict` when a ranked model does not represent the
/// data; else 0.
int exit_status(const Comparison& comparison, bool strict);

/// The measurement itself as a table, for when no analytic family represents it: the data
/// resampled to a (theta_h, theta_d, phi_d) table of 32 x 16 x 8 bins and that table's log RMSE
/// (channel mean) against the data, as a suggestion naming the command that writes it ("render the
/// measurement itself: `gonio convert DATA table.binary` (MERL) ...; a 32 x 16 x 8 table of these
/// data has a log RMSE of 0.031"). `data_name`: the data as the user named them.
std::string table_alternative(const brdf::Dataset& data, const std::string& data_name);

}  // namespace gonio::batch
