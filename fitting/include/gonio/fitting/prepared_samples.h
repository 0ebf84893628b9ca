#pragma once

// The samples of a fit prepared once for many evaluations of the model.
//
// Everything that does not depend on the fitted parameters is computed once per sample, in
// double: the cosines, 1 / (4 cos_i cos_o), the squared components of the half vector, the
// squared slopes of wi and wo (tan^2 theta along x and y) for Smith's Lambda, cos_d and
// (1 - cos_d)^5 for Fresnel, the V-groove G, the transformed measured value g(d) and the factor s
// of every residual (fitting/cost.h). Only what depends on the parameters (D, Lambda, F, the sums)
// is then evaluated per sample in the scalar type T (double or a Jet of the derivative slots), so
// that a Jacobian pass costs a few dozen Jet operations per sample instead of the whole geometry.
// The fields are stored as separate arrays (structure of arrays) and only those the model's
// structure needs are filled: a pass streams through memory once, split over the threads.
//
// The formulas are those of brdf/model_eval.h, brdf/microfacet.h, brdf/blinn_phong.h and
// brdf/fresnel.h rewritten on the precomputed quantities; tests check that both agree to rounding
// (tests/fitting/unit_prepared_samples_test.cpp).

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/lobe_orientation.h"
#include "gonio/brdf/model.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/exposure_paths.h"
#include "gonio/fitting/normal_equation_packets.h"

namespace gonio::fitting {

/// J^T J, J^T r and the sum of squares of a set of residuals (optionally under a robust loss).
struct NormalEquations {
    Eigen::MatrixXd jtj;  ///< n x n, sum over residuals of J_k^T J_k (times rho' per sample).
    Eigen::VectorXd jtr;  ///< n, sum of J_k^T r_k (times rho').
    double cost_sum = 0;  ///< sum of r_k^2 (or of rho(sum over a sample's channels of r^2)).
};

class PreparedSamples {
  public:
    /// Prepares `samples` for the model structure of `map`. The residual form, floor and sigma
    /// use come from `options`.
    PreparedSamples(std::shared_ptr<const ParameterMap> map,
                    const std::vector<brdf::Sample>& samples,
                    const CostOptions& options);

    std::size_t size() const { return n_; }
    const ParameterMap& map() const { return *map_; }

    // The passes below split the samples into blocks whose partial sums are added in block order
    // (parallel_blocks): their results do not depend on `threads`. They share one scratch buffer:
    // one pass at a time per object.

    /// Sum of squared residuals at x (robust: sum of rho). False on a non-finite residual.
    bool sum_of_squares(const double* x, double* out, int threads) const;

    /// The normal equations at x (derivatives with Jets over the derivative slots). False on a
    /// non-finite residual or derivative.
    bool normal_equations(const double* x, NormalEquations& out, int threads) const;

    /// The "meat" of the sandwich covariance: sum over samples of g_i g_i^T, g_i = sum over the
    /// sample's channels of r_c J_c (heteroscedasticity-consistent estimator HC0, White 1980).
    bool score_outer_products(const double* x, Eigen::MatrixXd& out, int threads) const;

    /// Residuals (3 per sample, rows [3 begin, 3 end)) and optionally the row-major Jacobian
    /// (3 (end - begin) x n) of samples [begin, end).
    bool evaluate(const double* x,
                  std::size_t begin,
                  std::size_t end,
                  double* residuals,
                  double* jacobian) const;

    /// Model values (RGB, 1/sr) of every sample at the model `m`.
    void model_values(const brdf::ModelD& m, std::vector<brdf::Rgbd>& out, int threads) const;
    /// Model values of samples [begin, end) into out[0, end - begin), on the calling thread.
    void model_values(const brdf::ModelD& m,
                      std::size_t begin,
                      std::size_t end,
                      brdf::Rgbd* out) const;

    /// Iteratively reweighted relative noise: replaces each residual's factor s by the one of a
    /// one-sigma uncertainty rel * m evaluated at the model value m (not at the measured value,
    /// whose own fluctuation would bias the weights): s = 1 / (g'(m) rel m), rel = sigma / d per
    /// channel of the sample. Channels with d = 0 or sigma = 0 keep their factor.
    void reweight_relative(const std::vector<brdf::Sample>& samples,
                           const std::vector<brdf::Rgbd>& model);

    /// cos theta_i of sample i.
    double cos_i(std::size_t i) const { return cos_i_[i]; }
    /// Whether cos_h is kept (the structure has a lobe other than Blinn-Phong).
    bool has_cos_h() const { return hz2_.size() == n_; }
    /// cos theta_h of sample i (h_z of the half vector, positive above the horizon).
    double cos_h(std::size_t i) const { return std::sqrt(hz2_[i]); }

    /// Whether the residual is the log form, whose g(d) = log(1 + d cos_i) is kept per channel.
    bool log_of_data() const { return form_ == ResidualForm::kLog; }
    /// log(1 + d_c cos_i) of channel c of sample i (the log form only).
    double log_of_data(int c, std::size_t i) const { return g_d_[c][i]; }

    /// A robust loss applied per sample to the sum over its channels of r^2 (nullptr: none).
    void set_loss(std::shared_ptr<const ceres::LossFunction> loss) { loss_ = std::move(loss); }

    /// True when the Jacobian comes from the closed-form derivatives (isotropic lobes, Schlick or
    /// no Fresnel, free fields among diffuse, alpha, exponent, gamma, scale, f0), else from Jets.
    bool analytic() const { return analytic_; }
    /// Forces the Jet path (tests compare both).
    void set_analytic(bool on) { analytic_ = on && analytic_; }
    /// True when the cost and normal-equation passes run fused on packets
    /// (normal_equation_packets.h): log residual, no robust loss, closed-form derivatives, every
    /// lobe an isotropic GGX or Beckmann lobe with no or Smith shadowing, at most 16 slots.
    bool packets() const { return packets_ && analytic_ && !loss_; }
    /// Forces the per-sample passes (tests compare both).
    void set_packets(bool on) { packets_ = on && packets_; }

  private:
    /// The per-sample arrays the structure needs: prepared_samples.cpp.
    struct GeometryNeeds;
    // The constructor's stages: the structure's needs (and anisotropic_, tabulated_), the
    // derivative slots, the passes the structure takes (analytic_, packets_, paths_), the arrays,
    // and per sample its geometry and its residual form.
    GeometryNeeds read_structure();
    void assign_slots();
    void choose_passes(const std::vector<brdf::Sample>& samples);
    void allocate(const GeometryNeeds& need);
    void prepare_geometry(std::size_t i, const brdf::Sample& smp, const GeometryNeeds& need);
    void prepare_residual(std::size_t i, const brdf::Sample& smp, const CostOptions& o);

    template <class T>
    brdf::Rgb<T> eval(const brdf::Model<T>& m, std::size_t i) const;
    /// Sample i's geometry as the lobe body takes it (brdf/lobe_body.h): prepared_samples.cpp.
    class SampleSquares;
    /// dg/dm of the residual form at m.
    double g_prime(double m, std::size_t i) const;
    /// Closed-form residuals r[3] and their derivatives v[c * slots + slot] of sample i:
    ///   f_c = rho_c / pi + sum_l scale_lc F_lc S_l,  F = f0 + (1 - f0) x5,
    ///   df_c/drho_c = 1/pi, df_c/dscale_lc = F_lc S_l, df_c/df0_lc = scale_lc (1 - x5) S_l,
    ///   df_c/dalpha_l = scale_lc F_lc dS_l/dalpha (dS/dalpha by a one-slot Jet of the shape;
    ///   a Student-t lobe's dS/dalpha and dS/dgamma by a two-slot Jet),
    /// times dr_c/df_c = s_c g'(f_c).
    bool analytic_sample(const brdf::ModelD& m, std::size_t i, double r[3], double* v) const;
    /// The shapes S_l and dS_l/dalpha of a run of samples for the lobes computed on packets
    /// (isotropic GGX or Beckmann, no or Smith shadowing): prepared_samples.cpp.
    struct RunShapes;
    /// The model values f[3] of sample i and df_c/d(slot) in d[c * slots + slot]; the shapes of
    /// the lobes in `run` (sample i its j-th) are taken from there.
    void analytic_parts(const brdf::ModelD& m,
                        std::size_t i,
                        double f[3],
                        double* d,
                        const RunShapes* run = nullptr,
                        std::size_t j = 0) const;
    /// analytic_sample for the log residual over samples [begin, end) (at most 64), the
    /// logarithms on SIMD packets (vector_log.h): r[3 j + c], v[(3 j + c) slots + slot]. The
    /// shapes of isotropic GGX and Beckmann lobes with no or Smith shadowing and their width
    /// derivatives also run on packets (lobe_shape_packets.h, from closed-form derivatives instead
    /// of the Jet); when every lobe is such, the combination with Fresnel and scale runs over the
    /// whole run too.
    bool analytic_log_run(
        const brdf::ModelD& m, std::size_t begin, std::size_t end, double* r, double* v) const;
    // analytic_log_run's stages: the shapes of its packet lobes over n samples from begin; when
    // every lobe is such, the model values' logarithm arguments arg[3 j + c] and df_c/d(slot) in
    // v (layout of analytic_log_run) over the run, a channel and a slot at a time.
    void pack_run_shapes(const brdf::ModelD& m,
                         std::size_t begin,
                         std::size_t n,
                         RunShapes& shapes) const;
    void combine_packed_run(const brdf::ModelD& m,
                            std::size_t begin,
                            std::size_t n,
                            const RunShapes& shapes,
                            double* arg,
                            double* v) const;
    void packed_slot_derivatives(const brdf::ModelD& m,
                                 int c,
                                 int k,
                                 std::size_t begin,
                                 std::size_t n,
                                 const RunShapes& shapes,
                                 double* out) const;
    template <class T>
    T g_of(const T& m, std::size_t i) const;
    /// The model at its point and the arrays, for the fused packet passes.
    void packet_setup(const brdf::ModelD& m, PacketModel& pm, PacketInputs& in) const;
    /// The model at x with a K-slot Jet per free parameter (its derivative slot seeded).
    template <int K>
    brdf::Model<ceres::Jet<double, K>> jet_model(const double* x) const;
    template <int K>
    bool normal_equations_k(const double* x, NormalEquations& out, int threads) const;
    // normal_equations_k's stages: a block's sums sample by sample into dst (the per-block
    // layout of normal_equations_k), sample i's residuals with their derivatives as Jets (on the
    // run of the log residual in ra, va when `runs`), and the blocks' sums added in block order
    // into `out`.
    template <int K>
    void block_normal_equations(const brdf::Model<ceres::Jet<double, K>>& m,
                                const brdf::ModelD& md,
                                std::size_t b,
                                std::size_t e,
                                double* dst) const;
    template <int K>
    bool sample_residuals(const brdf::Model<ceres::Jet<double, K>>& m,
                          const brdf::ModelD& md,
                          std::size_t i,
                          std::size_t b,
                          std::size_t e,
                          bool runs,
                          double* ra,
                          double* va,
                          ceres::Jet<double, K> r[3]) const;
    template <int K>
    bool add_block_sums(const std::vector<double>& partial, NormalEquations& out) const;
    /// jets_k's score products alone over [begin, end) with closed-form derivatives of the log
    /// residual, a run at a time (analytic_log_run): outer += g g^T per sample.
    bool analytic_score_products(const brdf::ModelD& md,
                                 std::size_t begin,
                                 std::size_t end,
                                 Eigen::MatrixXd& outer) const;
    template <int K>
    bool jets_k(const double* x,
                std::size_t begin,
                std::size_t end,
                double* residuals,
                double* jacobian,
                Eigen::MatrixXd* outer) const;

    std::shared_ptr<const ParameterMap> map_;
    ResidualForm form_;
    std::size_t n_ = 0;
    bool anisotropic_ = false;
    bool tabulated_ = false;  // A tabulated lobe in the structure.
    // Geometry (empty when the structure does not need the field).
    std::vector<double> cos_i_, inv_4cc_;
    std::vector<double> hx2_, hy2_, hz2_;  // hx2_ holds hx^2 + hy^2 for isotropic structures
    std::vector<double> log_cos_h_;        // Blinn-Phong: log(cos theta_h)
    std::vector<double> ti_x_, ti_y_, to_x_,
        to_y_;  // squared slopes; _x holds the sum if isotropic
    // Anisotropic structures: the cross products h_x h_y and the slope products of wi and wo,
    // which turn the squares into a lobe's frame (brdf/lobe_orientation.h).
    std::vector<double> hxy_, ti_xy_, to_xy_;
    std::vector<double> cos_d_, x5_, g_vgroove_;
    // Residual: r_c = s_c (g(m_c) - g_d_c).
    std::vector<double> g_d_[3], s_[3];
    // Derivative slots (see cost.cpp): slot of each free scalar and its channel (-1 = all).
    std::vector<int> slot_, channel_;
    int slots_ = 0;
    std::vector<Field> slot_field_;
    std::vector<int> slot_lobe_;
    bool analytic_ = false;
    bool packets_ = false;
    std::shared_ptr<const ceres::LossFunction> loss_;
    /// Samples measured while the arms moved (exposure_paths.h): their model value is the mean
    /// over their path, on the per-sample Jet passes. Null when no sample has a path.
    std::shared_ptr<const ExposurePaths> paths_;
    /// Per-block partial sums of the passes (kept between passes: no allocation per iteration).
    /// The passes of one PreparedSamples run one at a time.
    mutable std::vector<double> scratch_;
    std::vector<double>& block_scratch(std::size_t stride) const;
};

/// A Ceres cost function of the whole prepared set with n + 1 residuals whose Gauss-Newton
/// quantities equal those of the full problem: at x, with J^T J = V L V^T and g = J^T r,
///   J' = L^(1/2) V^T,  r' = L^(-1/2) V^T g (0 on null eigenvalues),  r'_n = sqrt(S - |r'|^2),
/// so that J'^T J' = J^T J, J'^T r' = g and |r'|^2 = S, the sum of squares. Ceres' trust region
/// (Levenberg-Marquardt with its column scaling) then takes exactly the steps of the full problem
/// while its linear algebra works on n + 1 rows instead of 3 N; one Jacobian evaluation is one
/// streamed pass over the samples on all threads. The extra residual is real: |r'|^2 = g^T (J^T
/// J)^+ g is the squared norm of the projection of r on the range of J, at most S. Each distinct
/// point costs one fused pass (cost and normal equations together), cached for the Jacobian
/// request that follows an accepted step.
class NormalEquationCost final : public ceres::CostFunction {
  public:
    NormalEquationCost(std::shared_ptr<const PreparedSamples> samples, int threads);
    bool Evaluate(double const* const* parameters,
                  double* residuals,
                  double** jacobians) const override;
    /// Passes over the samples so far (one per distinct point evaluated).
    int passes() const { return passes_; }

  private:
    std::shared_ptr<const PreparedSamples> samples_;
    int threads_;
    mutable int passes_ = 0;
    mutable bool cache_valid_ = false;
    mutable std::vector<double> cache_x_;
    mutable NormalEquations cache_;
};

/// Runs body(chunk, begin, end) over [0, n) on up to `threads` threads of the project's pool
/// (gonio/base/thread_pool.h; 0 = all of them); n up to 16384 stays on the calling thread.
void parallel_ranges(std::size_t n,
                     int threads,
                     const std::function<void(std::size_t, std::size_t, std::size_t)>& body);

/// Number of blocks of 4096 items in [0, n).
std::size_t block_count(std::size_t n);

/// Runs body(block, begin, end) over the blocks of 4096 items of [0, n) on up to `threads` threads
/// of the project's pool, which takes runs of whole blocks (a single block stays on the calling
/// thread). The blocks do not depend on the
/// thread count: sums formed per block and added in block order are the same, to the last bit,
/// for every thread count (deterministic reduction).
void parallel_blocks(std::size_t n,
                     int threads,
                     const std::function<void(std::size_t, std::size_t, std::size_t)>& body);

}  // namespace gonio::fitting
