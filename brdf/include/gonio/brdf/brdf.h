#pragma once

// A BRDF of any kind (analytic model, tabulated measurement) behind one interface, so that `gonio
// eval`, `gonio check`, the simulator and the previews take either.

#include <memory>
#include <string>

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::brdf {

class Brdf {
  public:
    virtual ~Brdf() = default;
    /// f(wi, wo) in 1/sr per RGB channel; wi toward the light, wo toward the camera, unit vectors
    /// in the local frame. Zero when either direction is at or below the horizon. Never NaN or Inf.
    virtual Rgbd eval(const Vec3d& wi, const Vec3d& wo) const = 0;
    /// True when the BRDF depends on phi_i, phi_o only through phi_o - phi_i.
    virtual bool isotropic() const = 0;
    /// One line saying what this is (model summary or table path and resolution).
    virtual std::string describe() const = 0;
    /// Extra lines for `gonio check` (a table's valid-bin count and per-channel min/max/mean); may
    /// be empty.
    virtual std::string statistics() const { return {}; }
};

/// Loads a BRDF from a path: a model JSON (*.json) or a tabulated file (MERL *.binary and the table
/// formats of table.h). The error names the file and the problem.
Expected<std::unique_ptr<Brdf>> load_brdf(const std::string& path);

}  // namespace gonio::brdf
