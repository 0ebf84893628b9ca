#pragma once

// Isotropic RGB material files of the RGL database (".bsdf"): J. Dupuy and W. Jakob, "An Adaptive
// Parameterization for Efficient Material Acquisition and Rendering", ACM TOG 37(6), SIGGRAPH Asia
// 2018 (sections 4-6). docs/file-formats-tables.md describes the fields.
//
// The parameterisation. Directions are written in unit coordinates u = (sqrt(theta / (pi/2)),
// (phi + pi) / (2 pi)), a change of variables with Jacobian |d omega / d u| = 2 pi^2 u_x
// sin(theta). The file holds, for an isotropic material (one phi_i node, phi measured relative to
// phi_i):
//   ndf, sigma      the NDF D(theta_m) and the projected area sigma(theta_i) = int D(m) <wi, m>+ dm
//                   on a grid over u (normalised so that sigma(normal) = int D cos = 1),
//   vndf            per theta_i node, the visible NDF D(m) <wi, m>+ (times the Jacobian) over u_m,
//                   whose marginal-conditional warp (warp2d.h) maps a uniform square of "sample"
//                   coordinates onto the half vectors,
//   rgb             per theta_i node and channel, N x N values at the nodes of the sample square:
//                   f_r(wi, wo) cos(theta_o) 4 sigma(wi) / D(m), with m the warped node and wo the
//                   reflection of wi about m (section 6: the BRDF divided by the warp's density),
//   luminance       their luminance (0.2126 R + 0.7152 G + 0.0722 B), used by renderers to sample,
//   jacobian        1 when rgb is stored divided by D / (4 sigma) as above (Mitsuba's flag),
//   valid           one bit per rgb node (theta_i, row, column; the first node in the highest bit
//                   of the first byte). Neither RGL's reader nor Mitsuba uses it, and the published
//                   files disagree on its polarity (in the felt file a set bit is a node above the
//                   horizon, in the paper and satin files a node below it), so gonio reads it for
//                   statistics only and selects nodes by geometry; gonio writes 1 = measured.
// Evaluation (section 6): m = normalize(wi + wo); the VNDF warp inverted at u_m gives the sample
// coordinates; the rgb grid, bilinear there and linear between theta_i nodes, times
// D(u_m) / (4 sigma(u_wi)) is f_r cos(theta_o).
//
// An anisotropic file (section 4.3 of the paper) has phi_i nodes over a full turn [-pi, pi] (the
// last one the first a full turn on), an NDF and sigma over the whole unit square, and vndf,
// luminance and rgb per (phi_i, theta_i) node; there the half vector's azimuth is measured from
// the sample's x axis, not from phi_i, and every table is interpolated linearly in phi_i as in
// theta_i (the slices' order of RGL's reference reader and Mitsuba 3).
//
// Supported: RGB files ("rgb" field), isotropic (one phi_i node, as RGL publishes for every
// material and Mitsuba 3 renders in its RGB variants) and anisotropic (at least 3 phi_i nodes
// spanning a full turn: files reduced by a symmetry are refused, as the readers of the format do).
// Spectral-only files ("spectra" and "wavelengths" without "rgb") are refused with a message
// saying so.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/tensor_file.h"
#include "gonio/brdf/warp2d.h"

namespace gonio::brdf {

/// True for the RGL material extension ".bsdf".
bool is_rgl_path(const std::string& path);

/// Unit coordinates of the parameterisation (see the file comment).
double rgl_theta_to_u(double theta);
double rgl_u_to_theta(double u);
double rgl_phi_to_u(double phi);
double rgl_u_to_phi(double u);

/// One stored node of an RGL file: where it sits in the file and the direction pair it stands for.
struct RglNode {
    std::size_t phi_index = 0;    ///< index into the phi_i nodes (0 in an isotropic file)
    std::size_t theta_index = 0;  ///< index into the theta_i nodes
    std::size_t row = 0;          ///< row of the sample square (y, the azimuth of m)
    std::size_t column = 0;       ///< column of the sample square (x, the elevation of m)
    Vec3d wi = Vec3d::UnitZ();
    Vec3d wo = Vec3d::UnitZ();
    Point2 u_m = {0, 0};  ///< the half vector in unit coordinates
    /// D(u_m) / (4 sigma(u_wi)) from the file's tables: stored rgb * factor = f_r cos(theta_o).
    double factor = 0;
};

/// An RGB RGL material (isotropic or anisotropic), evaluated at any direction pair through its VNDF
/// warp.
class RglBsdf : public Brdf {
  public:
    /// Checks the fields (presence, type, shapes that agree, finite values, theta_i nodes
    /// increasing in [0, pi/2]) and builds the interpolants; errors start with `label`.
    static Expected<RglBsdf> from_tensor(const TensorFile& file, const std::string& label);

    /// f_r in 1/sr; negative values (colours outside the RGB gamut) clipped to 0, as RGL's reader
    /// does by default. Zero at or below the horizon.
    Rgbd eval(const Vec3d& wi, const Vec3d& wo) const override;
    /// f_r in 1/sr without clipping (what RGL's reader gives with clipping off).
    Rgbd eval_unclipped(const Vec3d& wi, const Vec3d& wo) const;
    bool isotropic() const override { return isotropic_; }
    std::string describe() const override;
    std::string statistics() const override;

    /// Every stored node with its direction pair (rows 0 .. N-2: the last row is the first one's
    /// azimuth again; in column 0 row 0 only: the others are the same normal half vector; in an
    /// anisotropic file every phi_i node but the last, which is the first a full turn on).
    std::vector<RglNode> nodes() const;
    /// The stored value of a node, per channel (warped domain, see the file comment).
    Rgbd stored(const RglNode& node) const;
    /// The node's bit in the "valid" field (true when the file has none; see the file comment).
    bool node_valid(const RglNode& node) const;

    const std::string& label() const { return label_; }
    const std::string& description() const { return description_; }
    const std::vector<float>& theta_i() const { return theta_i_; }
    /// One node (0) in an isotropic file; over [-pi, pi] in an anisotropic one.
    const std::vector<float>& phi_i() const { return phi_i_; }
    std::size_t resolution() const { return n_; }
    bool jacobian() const { return jacobian_; }

  private:
    std::string label_;
    std::string description_;
    std::vector<float> theta_i_;
    std::vector<float> phi_i_;
    bool isotropic_ = true;
    std::size_t n_ = 0;  // rgb grid: n_ x n_ per theta_i node and channel
    bool jacobian_ = true;
    BilinearGrid ndf_, sigma_, rgb_;
    Warp2D vndf_;
    std::vector<std::uint8_t> valid_;  // one bit per node; empty: all valid
};

/// Reads a .bsdf file (read_tensor_file() then RglBsdf::from_tensor()).
Expected<RglBsdf> read_rgl_bsdf(const std::string& path);

/// The measured nodes as samples: one per distinct node with theta_i below 89 degrees and
/// theta_o above the horizon by at least 1e-3 in cosine, at its (wi, wo) (phi_i = 0 in an
/// isotropic file, the node's azimuth in an anisotropic one)
/// with value f_r = stored * factor / cos(theta_o) (clipped at 0). No resampling: a fit of the
/// file uses exactly these values. Dataset::rejected counts nothing; the source is the label.
Dataset rgl_nodes_to_dataset(const RglBsdf& bsdf);

// ---------------------------------------------------------------------------------------------
// Writing (rgl_writer.cpp).

/// Resolution of a written file.
struct RglWriteOptions {
    std::size_t theta_i_count = 16;    ///< theta_i nodes, uniform in theta over [0, pi/2]
    std::size_t ndf_resolution = 128;  ///< nodes per axis of ndf, sigma (x) and vndf
    std::size_t rgb_resolution = 32;   ///< nodes per axis of rgb and luminance
    int power_iterations = 64;         ///< most iterations of the NDF power iteration
    double ndf_floor = 1e-4;           ///< D kept >= floor * max(D) (see rgl_ndf_power_iteration)
    /// Largest elevation of wi at which a theta_i node is evaluated (or measured): a node above it
    /// (the pi/2 node always) takes the values of this elevation, the limit a reader only
    /// interpolates towards. Radians, in (0, pi/2).
    double max_theta_i = (90.0 - 0.5) * kPi / 180.0;
    /// Incident azimuths. 0: as the BRDF needs (write_rgl_bsdf: an isotropic file for an isotropic
    /// BRDF, 16 azimuths for an anisotropic one); 1: an isotropic file; P >= 2: an anisotropic
    /// file with P + 1 phi_i nodes over [-pi, pi] and an ndf_resolution^2 NDF grid (at most 128;
    /// write_rgl_bsdf lowers the default 128 to 64 there: the 2-D power iteration costs
    /// ndf_resolution^4 per step). The layout functions below take 0 and 1 alike as isotropic.
    std::size_t phi_i_count = 0;
    std::string description;  ///< the file's description field
};

/// The azimuth count write_rgl_bsdf uses for this BRDF (options.phi_i_count resolved).
std::size_t rgl_phi_i_count(const Brdf& brdf, const RglWriteOptions& options);

/// The NDF of a BRDF by power iteration (J. Dupuy, E. Heitz, J.-C. Iehl, P. Poulin, V.
/// Ostromoukhov, "Extracting Microfacet-based BRDF Parameters from Arbitrary Materials with Power
/// Iterations", EGSR 2015; used for acquisition in Dupuy and Jakob 2018, section 4). For a
/// microfacet BRDF with Smith's height-correlated masking, the retro-reflection is
/// f(w, w) = F D(w) / (4 cos(theta) sigma(w)), so D is the fixed point of
///   D_{k+1}(w) = f(w, w) cos(theta) sigma_k(w),  sigma_k(w) = int D_k(m) <w, m>+ dm,
/// each iterate normalised to int D cos = 1; the luminance of f is used. Isotropic: D on
/// `resolution` nodes over u_x = sqrt(theta_m / (pi/2)), linear between nodes in u_x; sigma by
/// quadrature (closed-form azimuthal integral). A floor of ndf_floor * max keeps every half
/// vector reachable by the warp (a diffuse part under a sharp peak keeps nodes). Returns D at the
/// nodes; iterations stops at a relative change below 1e-6 or power_iterations.
/// Anisotropic layouts (phi_i_count >= 2): D on the ndf_resolution^2 nodes of the unit square
/// (rows: u_y, the azimuth; columns: u_x), sigma by the trapezoidal rule over the same nodes,
/// retro_cos given row-major on them.
struct RglNdf {
    std::vector<double> d;      ///< D at u_x = k / (resolution - 1) (rows x resolution), 1/sr
    std::vector<double> sigma;  ///< sigma at the same nodes
    std::size_t rows = 1;       ///< 1 (isotropic) or resolution (anisotropic)
    int iterations = 0;
    double change = 0;  ///< relative change of the last iteration (max norm)
};
Expected<RglNdf> rgl_ndf_power_iteration(const Brdf& brdf, const RglWriteOptions& options);

/// The same power iteration from retro-reflection already known (measured): retro_cos[j] is the
/// luminance of f(w, w) times cos(theta) at theta = rgl_u_to_theta(j / (n - 1)), n =
/// options.ndf_resolution values, each finite and >= 0 (0 at the horizon node).
Expected<RglNdf> rgl_ndf_from_retro(const std::vector<double>& retro_cos,
                                    const RglWriteOptions& options);

/// The parameterisation of a file before any value is known: theta_i nodes, NDF and sigma grids,
/// the VNDF warp and every rgb node's direction pair. An acquisition plan measures at
/// nodes[k].wi, nodes[k].wo; rgl_tensor() stores what was measured there.
struct RglLayout {
    RglWriteOptions options;
    std::vector<float> theta_i;
    std::vector<float> phi_i;  ///< {0} (isotropic) or P + 1 nodes over [-pi, pi]
    std::vector<float> ndf;    ///< rows x ndf_resolution values (an isotropic file repeats its row)
    std::vector<float> sigma;  ///< the same nodes
    /// phi_i * theta_i * ndf_resolution^2 (phi_m rows, theta_m columns)
    std::vector<float> vndf;
    Warp2D vndf_warp;
    /// phi_i * theta_i * rgb_resolution^2 nodes in file order (phi_i, theta_i, row, column):
    /// every node, also the duplicates and those whose wo is below the horizon.
    std::vector<RglNode> nodes;
};
Expected<RglLayout> rgl_layout(const RglNdf& ndf, const RglWriteOptions& options);

/// The tensor file of a layout and the f_r values [1/sr] at its nodes (same order; NaN or a
/// negative value marks a node that was not measured: stored as 0, valid bit clear). Nodes whose
/// wo is at or below the horizon store 0 (f_r cos(theta_o) vanishes there) with the bit clear.
Expected<TensorFile> rgl_tensor(const RglLayout& layout, const std::vector<Rgbd>& f_r);

/// What write_rgl_bsdf() did.
struct RglWriteReport {
    RglNdf ndf;
    std::size_t nodes = 0;          ///< rgb nodes in the file
    std::size_t below_horizon = 0;  ///< of which wo at or below the horizon (stored 0)
    std::size_t bytes = 0;
};

/// Builds the NDF by power iteration on `brdf` (model or table), the layout, f_r at every node
/// and writes the file through gonio::AtomicFile. An anisotropic BRDF gets an anisotropic file
/// (refused when the options ask for one azimuth); non-finite values at the nodes are refused
/// (naming the first).
Expected<RglWriteReport> write_rgl_bsdf(const std::string& path,
                                        const Brdf& brdf,
                                        const RglWriteOptions& options = {});

}  // namespace gonio::brdf
