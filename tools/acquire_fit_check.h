#pragma once

// The fit a point campaign runs between batches for its stop rule (`gonio acquire --until`):
// acquisition states what it needs (acquisition/point/stop_rule.h), the fitting library does it.

#include "gonio/acquisition/point/fit_pass.h"
#include "gonio/acquisition/point/stop_rule.h"

namespace gonio::tools {

/// Fits the default model (`gonio fit DATA`'s) to the values so far and predicts the held-out ones.
acquisition::FitCheckFn default_fit_check();

/// The fit the fit-driven plan chooses its batches from (`gonio acquire --plan fit`): the same
/// default model (anisotropic lobes for an anisotropic campaign), its covariance propagated to
/// every candidate through the Jacobian of ln f (central differences of the fitted model).
acquisition::PlanFitFn default_plan_fit();

}  // namespace gonio::tools
