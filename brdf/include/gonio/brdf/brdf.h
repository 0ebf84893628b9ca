#pragma once

// A BRDF of any kind (analytic model, tabulated measurement) behind one interface, so that `gonio
// eval`, `gonio check`, the simulator and the previews take either.

#include <cstddef>
#include <memory>
#include <string>

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// n direction pairs as structure of arrays: wi = (wi_x[k], wi_y[k], wi_z[k]), likewise wo. Unit
/// vectors in the local frame (z = normal).
struct DirectionPairs {
    const double* wi_x = nullptr;
    const double* wi_y = nullptr;
    const double* wi_z = nullptr;
    const double* wo_x = nullptr;
    const double* wo_y = nullptr;
    const double* wo_z = nullptr;
};

class Brdf {
  public:
    virtual ~Brdf() = default;
    /// f(wi, wo) in 1/sr per RGB channel; wi toward the light, wo toward the camera, unit vectors
    /// in the local frame. Zero when either direction is at or below the horizon. Never NaN or Inf.
    virtual Rgbd eval(const Vec3d& wi, const Vec3d& wo) const = 0;
    /// f for n pairs at once: out[c][k] is channel c of f(wi_k, wo_k), the value of eval() (an
    /// analytic model on SIMD packets: equal up to the agreement of packets and scalars stated in
    /// tests/brdf/unit_packet_formulas_test.cpp). A value may be non-finite where the formulas
    /// overflow: the caller checks. This default calls eval() pair by pair.
    virtual void eval_many(std::size_t n, const DirectionPairs& dirs, double* const out[3]) const;
    /// True when eval_many is faster than eval() pair by pair (an analytic model: packets), so
    /// that a caller that can lay its directions out as arrays gains by doing so.
    virtual bool evaluates_packets() const { return false; }
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
