// Samples prepared once for many evaluations: geometry in double, parameters in Jets.

#include "gonio/fitting/prepared_samples.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "gonio/base/check.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/instruction_set.h"
#include "gonio/base/thread_pool.h"
#include "gonio/brdf/blinn_phong.h"
#include "gonio/brdf/fresnel.h"
#include "gonio/brdf/lobe_body.h"
#include "gonio/brdf/math.h"
#include "gonio/brdf/microfacet.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/student_t.h"
#include "gonio/fitting/lobe_shape_packets.h"
#include "gonio/fitting/vector_log.h"

namespace gonio::fitting {

namespace {

constexpr double kCbrtOffset = 1e-6;
// Samples per block of a reduction: the partition that fixes the order of every sum.
constexpr std::size_t kBlock = 4096;
// Items of an element-wise pass (preparation, model values, validation) up to which it stays on
// the calling thread. Handing work to the pool's worker costs one wake-up (a few microseconds,
// tens when the machine is loaded); these passes cost 10-40 ns per item, so at 16384 items the
// hand-off is under a tenth of the pass's time.
constexpr std::size_t kParallelMin = 16384;
// Blocks of a reduction up to which it stays on the calling thread: a block is 4096 samples of
// 60-400 ns each (0.25-1.6 ms), far more than a wake-up, so two blocks already go to two threads.
constexpr std::size_t kParallelMinBlocks = 1;
// Samples whose logarithms go to the packets together (a divisor of kBlock).
constexpr std::size_t kRun = 64;

}  // namespace

void parallel_ranges(std::size_t n,
                     int threads,
                     const std::function<void(std::size_t, std::size_t, std::size_t)>& body) {
    gonio::parallel_for(n, kParallelMin, threads, body);
}

std::size_t block_count(std::size_t n) {
    return (n + kBlock - 1) / kBlock;
}

void parallel_blocks(std::size_t n,
                     int threads,
                     const std::function<void(std::size_t, std::size_t, std::size_t)>& body) {
    // The pool's chunks are runs of whole blocks: the blocks, hence every per-block sum, are
    // the same whatever the pool does with the runs.
    gonio::parallel_for(block_count(n),
                        kParallelMinBlocks,
                        threads,
                        [&](std::size_t, std::size_t k0, std::size_t k1) {
                            for (std::size_t k = k0; k < k1; ++k) {
                                body(k, k * kBlock, std::min(n, (k + 1) * kBlock));
                            }
                        });
}

/// The per-sample arrays a model's structure needs (the others stay empty).
struct PreparedSamples::GeometryNeeds {
    bool lobes = false;    ///< 1 / (4 cos_i cos_o): any lobe.
    bool h = false;        ///< Squares of h: a lobe other than Blinn-Phong.
    bool bp = false;       ///< log cos theta_h: a Blinn-Phong lobe.
    bool smith = false;    ///< Squared slopes of wi and wo: Smith shadowing.
    bool vgroove = false;  ///< The V-groove G.
    bool schlick = false;  ///< (1 - cos_d)^5: Schlick's Fresnel term.
    bool exact_f = false;  ///< cos_d: a dielectric or conductor Fresnel term.
};

PreparedSamples::PreparedSamples(std::shared_ptr<const ParameterMap> map,
                                 const std::vector<brdf::Sample>& samples,
                                 const CostOptions& o)
    : map_(std::move(map)), form_(o.residual), n_(samples.size()) {
    const GeometryNeeds need = read_structure();
    assign_slots();
    choose_passes(samples);
    allocate(need);
    parallel_ranges(n_, 0, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            prepare_geometry(i, samples[i], need);
            prepare_residual(i, samples[i], o);
        }
    });
}

PreparedSamples::GeometryNeeds PreparedSamples::read_structure() {
    GeometryNeeds need;
    const brdf::ModelD& base = map_->base();
    need.lobes = !base.lobes.empty();
    for (const brdf::Lobe<double>& l : base.lobes) {
        anisotropic_ =
            anisotropic_ || (l.anisotropic && l.distribution != brdf::Distribution::kBlinnPhong);
        tabulated_ = tabulated_ || l.distribution == brdf::Distribution::kTabulated;
        if (l.distribution == brdf::Distribution::kBlinnPhong) {
            need.bp = true;
        } else {
            need.h = true;
        }
        if (l.shadowing == brdf::Shadowing::kSmithCorrelated ||
            l.shadowing == brdf::Shadowing::kSmithSeparable) {
            need.smith = true;
        } else if (l.shadowing == brdf::Shadowing::kVGroove) {
            need.vgroove = true;
        }
        if (l.fresnel.type == brdf::FresnelType::kSchlick) {
            need.schlick = true;
        } else if (l.fresnel.type != brdf::FresnelType::kNone) {
            need.exact_f = true;
        }
    }
    return need;
}

void PreparedSamples::assign_slots() {
    // A scalar or shared parameter has its own slot; the three channels of a per-channel field
    // share one, since channel c of the model depends on such a field through its component c
    // alone (every RGB field enters the model element-wise).
    const int np = map_->size();
    slot_.assign(np, -1);
    channel_.assign(np, -1);
    for (int k = 0; k < np; ++k) {
        const ScalarParam& s = map_->scalars()[map_->free()[k]];
        channel_[k] = s.channel;
        if (s.channel >= 0) {
            for (int j = 0; j < k; ++j) {
                const ScalarParam& p = map_->scalars()[map_->free()[j]];
                if (p.channel >= 0 && p.field == s.field && p.lobe == s.lobe) {
                    slot_[k] = slot_[j];
                    break;
                }
            }
        }
        if (slot_[k] < 0) {
            slot_[k] = slots_++;
        }
    }
    GONIO_CHECK(slots_ <= 32);
    slot_field_.assign(slots_, Field::kDiffuse);
    slot_lobe_.assign(slots_, -1);
    for (int k = 0; k < np; ++k) {
        const ScalarParam& sp = map_->scalars()[map_->free()[k]];
        slot_field_[slot_[k]] = sp.field;
        slot_lobe_[slot_[k]] = sp.lobe;
    }
}

void PreparedSamples::choose_passes(const std::vector<brdf::Sample>& samples) {
    const brdf::ModelD& base = map_->base();
    // Analytic derivatives (analytic_sample) cover isotropic lobes with a Schlick or no Fresnel
    // term and the fields diffuse, alpha_x, exponent, gamma (Student-t), scale and f0; other
    // structures use Jets over the derivative slots.
    analytic_ = base.lobes.size() <= 8;
    for (const brdf::Lobe<double>& l : base.lobes) {
        analytic_ = analytic_ && l.distribution != brdf::Distribution::kTabulated &&
                    !l.rgb_roughness &&
                    !(l.anisotropic && l.distribution != brdf::Distribution::kBlinnPhong) &&
                    (l.fresnel.type == brdf::FresnelType::kSchlick ||
                     l.fresnel.type == brdf::FresnelType::kNone);
    }
    for (const Field f : slot_field_) {
        analytic_ =
            analytic_ && (f == Field::kDiffuse || f == Field::kAlphaX || f == Field::kExponent ||
                          f == Field::kGamma || f == Field::kScale || f == Field::kF0);
    }
    // The fused packet passes (normal_equation_packets.h) take the log residual of isotropic GGX
    // and Beckmann lobes with no or Smith shadowing, in the closed form. They read each sample's
    // lobe geometry, which a model without lobes (Lambert only) does not prepare: it takes the
    // per-sample path, as does a build without packet kernels (gonio/base/instruction_set.h).
    packets_ = packet_isa() != Isa::kScalar && analytic_ && !base.lobes.empty() &&
               form_ == ResidualForm::kLog && !anisotropic_ && slots_ <= 16 &&
               base.lobes.size() <= static_cast<std::size_t>(PacketModel::kMaxLobes);
    for (const brdf::Lobe<double>& l : base.lobes) {
        packets_ = packets_ &&
                   (l.distribution == brdf::Distribution::kGgx ||
                    l.distribution == brdf::Distribution::kBeckmann) &&
                   (l.shadowing == brdf::Shadowing::kNone ||
                    l.shadowing == brdf::Shadowing::kSmithCorrelated ||
                    l.shadowing == brdf::Shadowing::kSmithSeparable);
    }
    for (const Field f : slot_field_) {
        packets_ = packets_ && (f == Field::kDiffuse || f == Field::kAlphaX || f == Field::kScale ||
                                f == Field::kF0);
    }
    paths_ = ExposurePaths::of(samples);
    if (paths_) {
        // A swept sample's model value is a mean over its path (exposure_paths.h), which the
        // closed-form derivatives and the packet passes do not take.
        analytic_ = packets_ = false;
    }
}

void PreparedSamples::allocate(const GeometryNeeds& need) {
    auto alloc = [&](std::vector<double>& v, bool needed) {
        if (needed) {
            resize_huge(v, n_);
        }
    };
    alloc(cos_i_, true);
    alloc(inv_4cc_, need.lobes);
    alloc(hx2_, need.h);
    alloc(hy2_, need.h && anisotropic_);
    alloc(hz2_, need.h);
    alloc(log_cos_h_, need.bp);
    alloc(ti_x_, need.smith);
    alloc(to_x_, need.smith);
    alloc(ti_y_, need.smith && anisotropic_);
    alloc(to_y_, need.smith && anisotropic_);
    alloc(hxy_, need.h && anisotropic_);
    alloc(ti_xy_, need.smith && anisotropic_);
    alloc(to_xy_, need.smith && anisotropic_);
    alloc(cos_d_, need.exact_f);
    alloc(x5_, need.schlick);
    alloc(g_vgroove_, need.vgroove);
    for (int c = 0; c < 3; ++c) {
        resize_huge(g_d_[c], n_);
        resize_huge(s_[c], n_);
    }
}

void PreparedSamples::prepare_geometry(std::size_t i,
                                       const brdf::Sample& smp,
                                       const GeometryNeeds& need) {
    const brdf::Vec3d wi = smp.wi();
    const brdf::Vec3d wo = smp.wo();
    const double ci = wi.z();
    const double co = wo.z();
    cos_i_[i] = ci;
    if (!need.lobes) {
        return;
    }
    // Callers pass samples above the horizon only (fit() validates them).
    inv_4cc_[i] = 1 / (4 * ci * co);
    const brdf::Vec3d sum = wi + wo;
    const double len = sum.norm();
    const brdf::Vec3d h = sum / len;
    const double cos_d = std::min(len / 2, 1.0);
    if (need.h) {
        if (anisotropic_) {
            hx2_[i] = h.x() * h.x();
            hy2_[i] = h.y() * h.y();
            hxy_[i] = h.x() * h.y();
        } else {
            hx2_[i] = h.x() * h.x() + h.y() * h.y();
        }
        hz2_[i] = h.z() * h.z();
    }
    if (need.bp) {
        log_cos_h_[i] = brdf::log_cos_theta_h(h.x() * h.x() + h.y() * h.y(), h.z());
    }
    if (need.smith) {
        const double ci2 = ci * ci;
        const double co2 = co * co;
        if (anisotropic_) {
            ti_x_[i] = wi.x() * wi.x() / ci2;
            ti_y_[i] = wi.y() * wi.y() / ci2;
            to_x_[i] = wo.x() * wo.x() / co2;
            to_y_[i] = wo.y() * wo.y() / co2;
            ti_xy_[i] = wi.x() * wi.y() / ci2;
            to_xy_[i] = wo.x() * wo.y() / co2;
        } else {
            ti_x_[i] = (wi.x() * wi.x() + wi.y() * wi.y()) / ci2;
            to_x_[i] = (wo.x() * wo.x() + wo.y() * wo.y()) / co2;
        }
    }
    if (need.exact_f) {
        cos_d_[i] = cos_d;
    }
    if (need.schlick) {
        // 1 - cos_d without cancellation (brdf/model_eval.h half_geometry).
        const double omc_d = (wi - wo).squaredNorm() / (4 * (1 + cos_d));
        x5_[i] = brdf::pow5(std::clamp(omc_d, 0.0, 1.0));
    }
    if (need.vgroove) {
        g_vgroove_[i] = brdf::G_vgroove(wi, wo, h);
    }
}

void PreparedSamples::prepare_residual(std::size_t i,
                                       const brdf::Sample& smp,
                                       const CostOptions& o) {
    const double ci = cos_i_[i];
    const double sqrt_w = std::sqrt(smp.weight);
    for (int c = 0; c < 3; ++c) {
        const double d = smp.value[c];
        double g_d = d;
        double dg = 1;  // g'(d)
        double s = 1;
        switch (form_) {
            case ResidualForm::kAbsolute:
                break;
            case ResidualForm::kRelative:
                // (A value below zero within its noise: zero in the denominator.)
                s = 1 / (std::max(d, 0.0) + o.relative_floor);
                break;
            case ResidualForm::kLog:
                g_d = std::log1p(d * ci);
                dg = ci / (1 + d * ci);
                break;
            case ResidualForm::kCosine:
                s = ci;
                break;
            case ResidualForm::kCubeRoot:
                g_d = std::cbrt(d + kCbrtOffset);
                dg = 1 / (3 * g_d * g_d);
                break;
        }
        if (o.use_sigma && smp.sigma[c] > 0) {
            // Normalised deviation: the residual's first-order standard deviation is g'(d) sigma
            // (times s, which cancels).
            s = 1 / (dg * smp.sigma[c]);
        }
        g_d_[c][i] = g_d;
        s_[c][i] = s * sqrt_w;
    }
}

/// Sample i's geometry in the form of the lobe body (brdf/lobe_body.h): the stored squares and
/// squared slopes (tangents), turned into a lobe's frame when it has one.
class PreparedSamples::SampleSquares {
  public:
    SampleSquares(const PreparedSamples& p, std::size_t i) : p_(p), i_(i) {}

    /// In the sample's frame (an isotropic structure holds the sums in the x parts).
    brdf::LobeSquares<double> squares() const {
        const std::size_t i = i_;
        brdf::LobeSquares<double> g;
        g.isotropic = !p_.anisotropic_;
        g.hx2 = at(p_.hx2_);
        g.hy2 = at(p_.hy2_);
        g.hz2 = at(p_.hz2_);
        g.log_cos_h = at(p_.log_cos_h_);
        g.wi = {at(p_.ti_x_), at(p_.ti_y_), 1.0, 0.0};
        g.wo = {at(p_.to_x_), at(p_.to_y_), 1.0, 0.0};
        if (p_.tabulated_) {
            // A tabulated lobe looks its D and Lambda up by cosine.
            g.cos_h = std::sqrt(g.hz2);
            g.wi.cos_theta = 1.0 / std::sqrt(1.0 + (g.wi.x2 + g.wi.y2));
            g.wo.cos_theta = 1.0 / std::sqrt(1.0 + (g.wo.x2 + g.wo.y2));
        }
        g.g_vgroove = at(p_.g_vgroove_);
        g.inv_4cc = p_.inv_4cc_[i];
        return g;
    }

    /// In the frame of a lobe turned by r: the sample-frame squares and cross products turned
    /// (brdf/lobe_orientation.h); an anisotropic structure only.
    template <class T>
    brdf::LobeSquares<T> turned(const brdf::LobeRotation<T>& r) const {
        const std::size_t i = i_;
        brdf::LobeSquares<T> g;
        g.isotropic = false;
        if (!p_.hx2_.empty()) {
            brdf::lobe_frame_squares(T(p_.hx2_[i]), T(p_.hy2_[i]), T(p_.hxy_[i]), r, g.hx2, g.hy2);
            g.hz2 = T(p_.hz2_[i]);
        }
        if (!p_.ti_x_.empty()) {
            brdf::lobe_frame_squares(
                T(p_.ti_x_[i]), T(p_.ti_y_[i]), T(p_.ti_xy_[i]), r, g.wi.x2, g.wi.y2);
            brdf::lobe_frame_squares(
                T(p_.to_x_[i]), T(p_.to_y_[i]), T(p_.to_xy_[i]), r, g.wo.x2, g.wo.y2);
        }
        g.g_vgroove = T(at(p_.g_vgroove_));
        g.inv_4cc = T(p_.inv_4cc_[i]);
        return g;
    }

    brdf::FresnelGeometry<double> fresnel() const {
        brdf::FresnelGeometry<double> g;
        g.x5 = at(p_.x5_);
        g.cos_d = at(p_.cos_d_);
        return g;
    }

  private:
    /// Sample i of an array the structure needs (0 for one it does not).
    double at(const std::vector<double>& v) const { return v.empty() ? 0.0 : v[i_]; }

    const PreparedSamples& p_;
    std::size_t i_;
};

template <class T>
brdf::Rgb<T> PreparedSamples::eval(const brdf::Model<T>& m, std::size_t i) const {
    if (paths_ && paths_->swept(i)) {
        return paths_->mean(m, i);
    }
    T f[3];
    for (int c = 0; c < 3; ++c) {
        f[c] = m.has_diffuse ? T(m.diffuse[c] * T(brdf::kInvPi)) : T(0);
    }
    const brdf::Lobe<T>* lobes = m.lobes.data();
    brdf::add_lobes<brdf::SquaresForm::kTangents>(
        lobes, lobes + m.lobes.size(), SampleSquares(*this, i), f);
    return brdf::Rgb<T>(f[0], f[1], f[2]);
}

double PreparedSamples::g_prime(double m, std::size_t i) const {
    switch (form_) {
        case ResidualForm::kLog:
            return cos_i_[i] / (1 + m * cos_i_[i]);
        case ResidualForm::kCubeRoot: {
            const double gm = std::cbrt(m + kCbrtOffset);
            return 1 / (3 * gm * gm);
        }
        default:
            return 1;
    }
}

struct PreparedSamples::RunShapes {
    static constexpr int kMaxLobes = 8;
    /// Lobe l's shapes are here (else computed sample by sample).
    bool packed[kMaxLobes] = {};
    double S[kMaxLobes][kRun];
    double dS[kMaxLobes][kRun];
};

void PreparedSamples::analytic_parts(const brdf::ModelD& m,
                                     std::size_t i,
                                     double f[3],
                                     double* d,
                                     const RunShapes* run,
                                     std::size_t j) const {
    // Per lobe: the shape S = D G / (4 cos_i cos_o) and dS/d(width) through a one-slot Jet (only
    // the width enters it; a Student-t lobe's shape also takes its tail gamma: a two-slot Jet),
    // and F = f0 + (1 - f0) x5 (Schlick) or 1.
    using J1 = ceres::Jet<double, 1>;
    using J2 = ceres::Jet<double, 2>;
    constexpr int kMaxLobes = 8;
    double S[kMaxLobes], dS[kMaxLobes], dS_gamma[kMaxLobes];
    brdf::Rgbd F[kMaxLobes];
    brdf::Rgbd fm = m.has_diffuse ? brdf::Rgbd(m.diffuse * brdf::kInvPi) : brdf::Rgbd::Zero();
    const int nl = static_cast<int>(m.lobes.size());
    for (int l = 0; l < nl; ++l) {
        const brdf::Lobe<double>& lobe = m.lobes[l];
        dS_gamma[l] = 0;
        if (run != nullptr && run->packed[l]) {
            S[l] = run->S[l][j];
            dS[l] = run->dS[l][j];
        } else if (lobe.distribution == brdf::Distribution::kStudentT) {
            const J2 a(lobe.alpha_x, 0);
            const J2 g(lobe.gamma, 1);
            const J2 e(lobe.exponent);
            const J2 s2 = brdf::lobe_shape<false, brdf::SquaresForm::kTangents, J2>(
                brdf::LobeShapeParams<J2>{lobe.distribution, lobe.shadowing, a, a, e, g, nullptr},
                SampleSquares(*this, i).squares());
            S[l] = s2.a;
            dS[l] = s2.v[0];
            dS_gamma[l] = s2.v[1];
        } else {
            // The width's slot: alpha, or a Blinn-Phong lobe's exponent.
            const bool bp = lobe.distribution == brdf::Distribution::kBlinnPhong;
            const J1 a(lobe.alpha_x, 0);
            const J1 e = bp ? J1(lobe.exponent, 0) : J1(lobe.exponent);
            const J1 g(lobe.gamma);
            const J1 s = brdf::lobe_shape<false, brdf::SquaresForm::kTangents, J1>(
                brdf::LobeShapeParams<J1>{
                    lobe.distribution, lobe.shadowing, a, a, e, g, lobe.table.get()},
                SampleSquares(*this, i).squares());
            S[l] = s.a;
            dS[l] = s.v[0];
        }
        const brdf::FresnelGeometry<double> fg = SampleSquares(*this, i).fresnel();
        for (int c = 0; c < 3; ++c) {
            F[l][c] = brdf::lobe_F<double>(lobe.fresnel, c, fg);
        }
        fm += lobe.scale * F[l] * S[l];
    }
    for (int c = 0; c < 3; ++c) {
        f[c] = fm[c];
        double* dc = d + c * slots_;
        for (int k = 0; k < slots_; ++k) {
            const int l = slot_lobe_[k];
            double v = 0;
            switch (slot_field_[k]) {
                case Field::kDiffuse:
                    v = brdf::kInvPi;
                    break;
                case Field::kAlphaX:
                case Field::kExponent:
                    v = m.lobes[l].scale[c] * F[l][c] * dS[l];
                    break;
                case Field::kGamma:
                    v = m.lobes[l].scale[c] * F[l][c] * dS_gamma[l];
                    break;
                case Field::kScale:
                    v = F[l][c] * S[l];
                    break;
                case Field::kF0:
                    v = m.lobes[l].scale[c] * (1 - x5_[i]) * S[l];
                    break;
                default:
                    break;
            }
            dc[k] = v;
        }
    }
}

bool PreparedSamples::analytic_sample(const brdf::ModelD& m,
                                      std::size_t i,
                                      double r[3],
                                      double* v) const {
    double f[3];
    analytic_parts(m, i, f, v);
    for (int c = 0; c < 3; ++c) {
        r[c] = s_[c][i] * (g_of(f[c], i) - g_d_[c][i]);
        const double dr = s_[c][i] * g_prime(f[c], i);
        double* vc = v + c * slots_;
        for (int k = 0; k < slots_; ++k) {
            vc[k] *= dr;
        }
    }
    return std::isfinite(r[0]) && std::isfinite(r[1]) && std::isfinite(r[2]);
}

void PreparedSamples::pack_run_shapes(const brdf::ModelD& m,
                                      std::size_t begin,
                                      std::size_t n,
                                      RunShapes& shapes) const {
    const int nl = static_cast<int>(m.lobes.size());
    for (int l = 0; l < nl && !anisotropic_; ++l) {
        const brdf::Lobe<double>& lobe = m.lobes[l];
        const bool smith = lobe.shadowing == brdf::Shadowing::kSmithCorrelated ||
                           lobe.shadowing == brdf::Shadowing::kSmithSeparable;
        if ((lobe.distribution != brdf::Distribution::kGgx &&
             lobe.distribution != brdf::Distribution::kBeckmann) ||
            (!smith && lobe.shadowing != brdf::Shadowing::kNone)) {
            continue;
        }
        LobeShapeKind kind;
        kind.beckmann = lobe.distribution == brdf::Distribution::kBeckmann;
        kind.smith = !smith ? 0 : lobe.shadowing == brdf::Shadowing::kSmithCorrelated ? 1 : 2;
        LobeShapeInputs in;
        in.hxy2 = hx2_.data() + begin;
        in.hz2 = hz2_.data() + begin;
        in.inv_4cc = inv_4cc_.data() + begin;
        if (smith) {
            in.tan2_i = ti_x_.data() + begin;
            in.tan2_o = to_x_.data() + begin;
        }
        lobe_shape_packets(kind, lobe.alpha_x, in, n, shapes.S[l], shapes.dS[l]);
        shapes.packed[l] = true;
    }
}

void PreparedSamples::combine_packed_run(const brdf::ModelD& m,
                                         std::size_t begin,
                                         std::size_t n,
                                         const RunShapes& shapes,
                                         double* arg,
                                         double* v) const {
    // The combination of analytic_parts a channel and a slot at a time over the run (the same
    // operations in the same order, so the same values), in loops the compiler turns into
    // packets.
    const double* x5 = x5_.empty() ? nullptr : x5_.data() + begin;
    const double* ci = cos_i_.data() + begin;
    const int nl = static_cast<int>(m.lobes.size());
    for (int c = 0; c < 3; ++c) {
        double fc[kRun];
        const double base = m.has_diffuse ? m.diffuse[c] * brdf::kInvPi : 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            fc[j] = base;
        }
        for (int l = 0; l < nl; ++l) {
            const brdf::Lobe<double>& lobe = m.lobes[l];
            const double sc = lobe.scale[c];
            const double* S = shapes.S[l];
            if (lobe.fresnel.type == brdf::FresnelType::kSchlick) {
                const double f0 = lobe.fresnel.f0[c];
                for (std::size_t j = 0; j < n; ++j) {
                    fc[j] += sc * brdf::fresnel_schlick_from_pow5(x5[j], f0) * S[j];
                }
            } else {
                for (std::size_t j = 0; j < n; ++j) {
                    fc[j] += sc * 1.0 * S[j];
                }
            }
        }
        for (std::size_t j = 0; j < n; ++j) {
            arg[3 * j + c] = fc[j] * ci[j];
        }
        for (int k = 0; k < slots_; ++k) {
            packed_slot_derivatives(m, c, k, begin, n, shapes, v + c * slots_ + k);
        }
    }
}

void PreparedSamples::packed_slot_derivatives(const brdf::ModelD& m,
                                              int c,
                                              int k,
                                              std::size_t begin,
                                              std::size_t n,
                                              const RunShapes& shapes,
                                              double* out) const {
    // df_c/d(slot k) (analytic_parts' table), before the factor dr_c/df_c; sample j's at
    // out[j * 3 slots].
    const double* x5 = x5_.empty() ? nullptr : x5_.data() + begin;
    const int l = slot_lobe_[k];
    const std::size_t stride = 3 * slots_;
    const Field field = slot_field_[k];
    if (field == Field::kDiffuse) {
        for (std::size_t j = 0; j < n; ++j) {
            out[j * stride] = brdf::kInvPi;
        }
        return;
    }
    const bool lobe_field = field == Field::kAlphaX || field == Field::kExponent ||
                            field == Field::kScale || (field == Field::kF0 && x5 != nullptr);
    if (l < 0 || !lobe_field) {
        for (std::size_t j = 0; j < n; ++j) {
            out[j * stride] = 0;
        }
        return;
    }
    const brdf::Lobe<double>& lobe = m.lobes[l];
    const bool schlick = lobe.fresnel.type == brdf::FresnelType::kSchlick;
    const double sc = lobe.scale[c];
    const double f0 = schlick ? lobe.fresnel.f0[c] : 1.0;
    const double* S = shapes.S[l];
    const double* dS = shapes.dS[l];
    for (std::size_t j = 0; j < n; ++j) {
        const double F = schlick ? brdf::fresnel_schlick_from_pow5(x5[j], f0) : 1.0;
        double d = 0;
        switch (field) {
            case Field::kAlphaX:
            case Field::kExponent:
                d = sc * F * dS[j];
                break;
            case Field::kScale:
                d = F * S[j];
                break;
            default:  // Field::kF0
                d = sc * (1 - x5[j]) * S[j];
                break;
        }
        out[j * stride] = d;
    }
}

bool PreparedSamples::analytic_log_run(
    const brdf::ModelD& m, std::size_t begin, std::size_t end, double* r, double* v) const {
    // Model values and their derivatives per sample, then the logarithms of the run on packets,
    // then the residuals r = s (log(1 + f cos_i) - g(d)) and dr/df = s cos_i / (1 + f cos_i).
    double arg[3 * kRun] = {};
    double lg[3 * kRun];
    const std::size_t n = end - begin;
    // The shapes of the isotropic GGX and Beckmann lobes with no or Smith shadowing for the whole
    // run on packets (lobe_shape_packets.h); the other lobes sample by sample.
    RunShapes shapes;
    pack_run_shapes(m, begin, n, shapes);
    bool all_packed = true;
    for (std::size_t l = 0; l < m.lobes.size(); ++l) {
        all_packed = all_packed && shapes.packed[l];
    }
    if (all_packed) {
        combine_packed_run(m, begin, n, shapes, arg, v);
    } else {
        for (std::size_t j = 0; j < n; ++j) {
            const std::size_t i = begin + j;
            double f[3];
            analytic_parts(m, i, f, v + j * 3 * slots_, &shapes, j);
            for (int c = 0; c < 3; ++c) {
                arg[3 * j + c] = f[c] * cos_i_[i];
            }
        }
    }
    log1p_packets(arg, lg, 3 * n);
    bool finite = true;
    for (std::size_t j = 0; j < n; ++j) {
        const std::size_t i = begin + j;
        for (int c = 0; c < 3; ++c) {
            const double rc = s_[c][i] * (lg[3 * j + c] - g_d_[c][i]);
            const double dr = s_[c][i] * cos_i_[i] / (1 + arg[3 * j + c]);
            r[3 * j + c] = rc;
            finite = finite && std::isfinite(rc);
            double* vc = v + (3 * j + c) * slots_;
            for (int k = 0; k < slots_; ++k) {
                vc[k] *= dr;
            }
        }
    }
    return finite;
}

void PreparedSamples::packet_setup(const brdf::ModelD& m, PacketModel& pm, PacketInputs& in) const {
    pm.lobes = static_cast<int>(m.lobes.size());
    for (int l = 0; l < pm.lobes; ++l) {
        const brdf::Lobe<double>& lobe = m.lobes[l];
        pm.kind[l].beckmann = lobe.distribution == brdf::Distribution::kBeckmann;
        pm.kind[l].smith = lobe.shadowing == brdf::Shadowing::kSmithCorrelated  ? 1
                           : lobe.shadowing == brdf::Shadowing::kSmithSeparable ? 2
                                                                                : 0;
        pm.alpha[l] = lobe.alpha_x;
        pm.fresnel[l] = lobe.fresnel;
        for (int c = 0; c < 3; ++c) {
            pm.scale[l][c] = lobe.scale[c];
        }
    }
    for (int c = 0; c < 3; ++c) {
        pm.diffuse[c] = m.has_diffuse ? m.diffuse[c] * brdf::kInvPi : 0.0;
    }
    pm.slots = slots_;
    for (int k = 0; k < PacketModel::kMaxSlots; ++k) {
        pm.slot[k] = PacketSlot::kZero;
        pm.slot_lobe[k] = 0;
    }
    for (int k = 0; k < slots_; ++k) {
        // The table of analytic_parts: a lobe field of no lobe, or f0 without (1 - cos_d)^5,
        // has no derivative.
        const int l = slot_lobe_[k];
        switch (slot_field_[k]) {
            case Field::kDiffuse:
                pm.slot[k] = PacketSlot::kDiffuse;
                break;
            case Field::kAlphaX:
                pm.slot[k] = l >= 0 ? PacketSlot::kWidth : PacketSlot::kZero;
                break;
            case Field::kScale:
                pm.slot[k] = l >= 0 ? PacketSlot::kScale : PacketSlot::kZero;
                break;
            case Field::kF0:
                pm.slot[k] = l >= 0 && !x5_.empty() ? PacketSlot::kF0 : PacketSlot::kZero;
                break;
            default:
                break;
        }
        pm.slot_lobe[k] = std::max(l, 0);
    }
    in.hxy2 = hx2_.empty() ? nullptr : hx2_.data();
    in.hz2 = hz2_.empty() ? nullptr : hz2_.data();
    in.tan2_i = ti_x_.empty() ? nullptr : ti_x_.data();
    in.tan2_o = to_x_.empty() ? nullptr : to_x_.data();
    in.inv_4cc = inv_4cc_.empty() ? nullptr : inv_4cc_.data();
    in.x5 = x5_.empty() ? nullptr : x5_.data();
    in.cos_i = cos_i_.data();
    for (int c = 0; c < 3; ++c) {
        in.g_d[c] = g_d_[c].data();
        in.s[c] = s_[c].data();
    }
}

template <class T>
T PreparedSamples::g_of(const T& m, std::size_t i) const {
    using std::cbrt;
    using std::log;
    switch (form_) {
        case ResidualForm::kLog:
            // log(1 + m cos_i); m >= 0 and cos_i > 0 keep the argument >= 1.
            return log(T(1) + m * cos_i_[i]);
        case ResidualForm::kCubeRoot:
            return cbrt(m + kCbrtOffset);
        default:
            return m;
    }
}

bool PreparedSamples::sum_of_squares(const double* x, double* out, int threads) const {
    const brdf::ModelD m = map_->model<double>(x);
    std::vector<double>& partial = block_scratch(1);
    const bool runs = form_ == ResidualForm::kLog;
    const bool fused = packets();
    PacketModel pm;
    PacketInputs pin;
    if (fused) {
        packet_setup(m, pm, pin);
    }
    parallel_blocks(n_, threads, [&](std::size_t k, std::size_t b, std::size_t e) {
        if (fused) {
            partial[k] = cost_packets(pm, pin, b, e);
            return;
        }
        double acc = 0;
        // Log residual: the logarithms of a run of samples on packets.
        double arg[3 * kRun] = {};
        double lg[3 * kRun];
        for (std::size_t i = b; i < e; ++i) {
            double s2 = 0;
            if (runs) {
                const std::size_t j = (i - b) % kRun;
                if (j == 0) {
                    const std::size_t n = std::min(e - i, kRun);
                    for (std::size_t q = 0; q < n; ++q) {
                        const brdf::Rgbd f = eval(m, i + q);
                        for (int c = 0; c < 3; ++c) {
                            arg[3 * q + c] = f[c] * cos_i_[i + q];
                        }
                    }
                    log1p_packets(arg, lg, 3 * n);
                }
                for (int c = 0; c < 3; ++c) {
                    const double r = s_[c][i] * (lg[3 * j + c] - g_d_[c][i]);
                    s2 += r * r;
                }
            } else {
                const brdf::Rgbd f = eval(m, i);
                for (int c = 0; c < 3; ++c) {
                    const double r = s_[c][i] * (g_of(f[c], i) - g_d_[c][i]);
                    s2 += r * r;
                }
            }
            if (loss_) {
                double rho[3];
                loss_->Evaluate(s2, rho);
                s2 = rho[0];
            }
            acc += s2;
        }
        partial[k] = acc;
    });
    // Block sums added in block order: the same total for every thread count.
    double total = 0;
    for (std::size_t k = 0; k < block_count(n_); ++k) {
        total += partial[k];
    }
    if (!std::isfinite(total)) {
        return false;
    }
    *out = total;
    return true;
}

std::vector<double>& PreparedSamples::block_scratch(std::size_t stride) const {
    const std::size_t size = block_count(n_) * stride;
    if (scratch_.size() < size) {
        scratch_.resize(size);
    }
    return scratch_;
}

template <int K>
brdf::Model<ceres::Jet<double, K>> PreparedSamples::jet_model(const double* x) const {
    using J = ceres::Jet<double, K>;
    std::vector<J> xj(map_->size());
    for (std::size_t k = 0; k < xj.size(); ++k) {
        xj[k] = J(x[k], slot_[k]);
    }
    return map_->model<J>(xj.data());
}

template <int K>
bool PreparedSamples::normal_equations_k(const double* x, NormalEquations& out, int threads) const {
    using J = ceres::Jet<double, K>;
    // The Jet model only where the Jet path runs (no allocation per pass otherwise).
    const brdf::Model<J> m = analytic_ ? brdf::Model<J>{} : jet_model<K>(x);
    const brdf::ModelD md = map_->model<double>(x);
    // Per block: a[3] (K x K), b[3] (K), the cost, and whether all is finite.
    constexpr std::size_t kStride = 3 * K * K + 3 * K + 2;
    std::vector<double>& partial = block_scratch(kStride);
    const bool fused = packets();
    PacketModel pm;
    PacketInputs pin;
    if (fused) {
        packet_setup(md, pm, pin);
    }
    parallel_blocks(n_, threads, [&](std::size_t blk, std::size_t b, std::size_t e) {
        double* dst = partial.data() + blk * kStride;
        if (!fused) {
            block_normal_equations<K>(m, md, b, e, dst);
            return;
        }
        // The whole block on packets (normal_equation_packets.h).
        normal_equation_packets(pm, pin, b, e, K, dst, dst + 3 * K * K, dst + kStride - 2);
        bool finite = std::isfinite(dst[kStride - 2]);
        for (std::size_t q = 0; q + 2 < kStride; ++q) {
            finite = finite && std::isfinite(dst[q]);
        }
        dst[kStride - 1] = finite ? 1.0 : 0.0;
    });
    return add_block_sums<K>(partial, out);
}

template <int K>
void PreparedSamples::block_normal_equations(const brdf::Model<ceres::Jet<double, K>>& m,
                                             const brdf::ModelD& md,
                                             std::size_t b,
                                             std::size_t e,
                                             double* dst) const {
    using J = ceres::Jet<double, K>;
    using MatK = Eigen::Matrix<double, K, K>;
    using VecK = Eigen::Matrix<double, K, 1>;
    MatK a[3];
    VecK bv[3];
    for (int c = 0; c < 3; ++c) {
        a[c].setZero();
        bv[c].setZero();
    }
    double cost = 0;
    // Closed-form derivatives of the log residual: a run of samples at a time, its logarithms on
    // packets.
    const bool runs = analytic_ && form_ == ResidualForm::kLog;
    double ra[3 * kRun];
    double va[3 * kRun * 32];
    for (std::size_t i = b; i < e; ++i) {
        J r[3];
        if (!sample_residuals<K>(m, md, i, b, e, runs, ra, va, r)) {
            cost = std::numeric_limits<double>::infinity();
            break;
        }
        double s2 = 0;
        for (int c = 0; c < 3; ++c) {
            s2 += r[c].a * r[c].a;
        }
        double w = 1;
        if (loss_) {
            double rho[3];
            loss_->Evaluate(s2, rho);
            w = rho[1];
            s2 = rho[0];
        }
        cost += s2;
        for (int c = 0; c < 3; ++c) {
            // Upper triangle of w v v^T over the slots in use (Eigen's general rank update is
            // slow for these small fixed sizes). (Over all K slots: those beyond slots_ hold
            // zeros, and a fixed bound lets the compiler unroll.)
            for (int q = 0; q < K; ++q) {
                const double wv = w * r[c].v[q];
                for (int p = 0; p <= q; ++p) {
                    a[c](p, q) += wv * r[c].v[p];
                }
            }
            bv[c].noalias() += (w * r[c].a) * r[c].v;
        }
    }
    constexpr std::size_t kStride = 3 * K * K + 3 * K + 2;
    for (int c = 0; c < 3; ++c) {
        Eigen::Map<MatK>(dst + c * K * K) = a[c];
        Eigen::Map<VecK>(dst + 3 * K * K + c * K) = bv[c];
    }
    dst[kStride - 2] = cost;
    dst[kStride - 1] = std::isfinite(cost) && a[0].allFinite() && a[1].allFinite() &&
                               a[2].allFinite() && bv[0].allFinite() && bv[1].allFinite() &&
                               bv[2].allFinite()
                           ? 1.0
                           : 0.0;
}

template <int K>
bool PreparedSamples::sample_residuals(const brdf::Model<ceres::Jet<double, K>>& m,
                                       const brdf::ModelD& md,
                                       std::size_t i,
                                       std::size_t b,
                                       std::size_t e,
                                       bool runs,
                                       double* ra,
                                       double* va,
                                       ceres::Jet<double, K> r[3]) const {
    using J = ceres::Jet<double, K>;
    if (runs) {
        const std::size_t j = (i - b) % kRun;
        if (j == 0 && !analytic_log_run(md, i, std::min(e, i + kRun), ra, va)) {
            return false;
        }
        for (int c = 0; c < 3; ++c) {
            r[c].a = ra[3 * j + c];
            const double* vc = va + (3 * j + c) * slots_;
            for (int k = 0; k < K; ++k) {
                r[c].v[k] = k < slots_ ? vc[k] : 0.0;
            }
        }
        return true;
    }
    if (analytic_) {
        if (!analytic_sample(md, i, ra, va)) {
            return false;
        }
        for (int c = 0; c < 3; ++c) {
            r[c].a = ra[c];
            for (int k = 0; k < K; ++k) {
                r[c].v[k] = k < slots_ ? va[c * slots_ + k] : 0.0;
            }
        }
        return true;
    }
    const brdf::Rgb<J> f = eval(m, i);
    for (int c = 0; c < 3; ++c) {
        r[c] = J(s_[c][i]) * (g_of(f[c], i) - J(g_d_[c][i]));
    }
    return true;
}

template <int K>
bool PreparedSamples::add_block_sums(const std::vector<double>& partial,
                                     NormalEquations& out) const {
    using MatK = Eigen::Matrix<double, K, K>;
    using VecK = Eigen::Matrix<double, K, 1>;
    constexpr std::size_t kStride = 3 * K * K + 3 * K + 2;
    const int np = map_->size();
    // Block sums added in block order: the same normal equations for every thread count.
    MatK a[3];
    VecK bv[3];
    for (int c = 0; c < 3; ++c) {
        a[c].setZero();
        bv[c].setZero();
    }
    out.cost_sum = 0;
    for (std::size_t blk = 0; blk < block_count(n_); ++blk) {
        const double* src = partial.data() + blk * kStride;
        if (src[kStride - 1] == 0.0) {
            return false;
        }
        for (int c = 0; c < 3; ++c) {
            a[c] += Eigen::Map<const MatK>(src + c * K * K);
            bv[c] += Eigen::Map<const VecK>(src + 3 * K * K + c * K);
        }
        out.cost_sum += src[kStride - 2];
    }
    for (int c = 0; c < 3; ++c) {
        a[c] = a[c].template selfadjointView<Eigen::Upper>();
    }
    // The slots' sums to the parameters: a parameter of one channel takes that channel's sums.
    out.jtj = Eigen::MatrixXd::Zero(np, np);
    out.jtr = Eigen::VectorXd::Zero(np);
    for (int c = 0; c < 3; ++c) {
        for (int k = 0; k < np; ++k) {
            if (channel_[k] >= 0 && channel_[k] != c) {
                continue;
            }
            out.jtr[k] += bv[c][slot_[k]];
            for (int l = 0; l < np; ++l) {
                if (channel_[l] >= 0 && channel_[l] != c) {
                    continue;
                }
                out.jtj(k, l) += a[c](slot_[k], slot_[l]);
            }
        }
    }
    return true;
}

bool PreparedSamples::normal_equations(const double* x, NormalEquations& out, int threads) const {
    if (slots_ <= 4) {
        return normal_equations_k<4>(x, out, threads);
    }
    if (slots_ <= 8) {
        return normal_equations_k<8>(x, out, threads);
    }
    if (slots_ <= 16) {
        return normal_equations_k<16>(x, out, threads);
    }
    return normal_equations_k<32>(x, out, threads);
}

bool PreparedSamples::analytic_score_products(const brdf::ModelD& md,
                                              std::size_t begin,
                                              std::size_t end,
                                              Eigen::MatrixXd& outer) const {
    const int np = map_->size();
    // g = sum over channels of r_c dr_c/dx straight from the run's derivatives (a parameter
    // of one channel takes that channel's term only); a non-finite derivative makes g
    // non-finite.
    double rr[3 * kRun];
    double vr[3 * kRun * 32];
    double gs[3 * 32];  // np <= 3 slots_ (a slot holds at most the three channels)
    for (std::size_t i = begin; i < end; ++i) {
        const std::size_t j = (i - begin) % kRun;
        if (j == 0 && !analytic_log_run(md, i, std::min(end, i + kRun), rr, vr)) {
            return false;
        }
        bool finite = true;
        for (int k = 0; k < np; ++k) {
            double sum = 0;
            for (int c = 0; c < 3; ++c) {
                if (channel_[k] < 0 || channel_[k] == c) {
                    sum += rr[3 * j + c] * vr[(3 * j + c) * slots_ + slot_[k]];
                }
            }
            gs[k] = sum;
            finite = finite && std::isfinite(sum);
        }
        if (!finite) {
            return false;
        }
        for (int l = 0; l < np; ++l) {
            for (int k = 0; k <= l; ++k) {
                outer(k, l) += gs[k] * gs[l];
            }
        }
    }
    return true;
}

template <int K>
bool PreparedSamples::jets_k(const double* x,
                             std::size_t begin,
                             std::size_t end,
                             double* residuals,
                             double* jacobian,
                             Eigen::MatrixXd* outer) const {
    using J = ceres::Jet<double, K>;
    const int np = map_->size();
    // The Jet model only where the Jet path runs (no allocation per pass otherwise).
    const brdf::Model<J> m = analytic_ ? brdf::Model<J>{} : jet_model<K>(x);
    const brdf::ModelD md = map_->model<double>(x);
    Eigen::VectorXd g(np);
    // The score products alone (no residuals or Jacobian asked for) with closed-form derivatives
    // of the log residual: a run of samples at a time, its logarithms (and the shapes of GGX and
    // Beckmann lobes) on packets, as in the normal-equation pass.
    if (analytic_ && form_ == ResidualForm::kLog && outer != nullptr && residuals == nullptr &&
        jacobian == nullptr) {
        return analytic_score_products(md, begin, end, *outer);
    }
    double ra[3];
    double va[3 * 32] = {};
    for (std::size_t i = begin; i < end; ++i) {
        brdf::Rgb<J> f;
        if (analytic_) {
            if (!analytic_sample(md, i, ra, va)) {
                return false;
            }
        } else {
            f = eval(m, i);
        }
        g.setZero();
        for (int c = 0; c < 3; ++c) {
            J r;
            if (analytic_) {
                r.a = ra[c];
                for (int k = 0; k < K; ++k) {
                    r.v[k] = k < slots_ ? va[c * slots_ + k] : 0.0;
                }
            } else {
                r = J(s_[c][i]) * (g_of(f[c], i) - J(g_d_[c][i]));
            }
            if (!std::isfinite(r.a)) {
                return false;
            }
            const std::size_t row = 3 * (i - begin) + c;
            if (residuals != nullptr) {
                residuals[row] = r.a;
            }
            for (int k = 0; k < np; ++k) {
                const double v = channel_[k] < 0 || channel_[k] == c ? r.v[slot_[k]] : 0.0;
                if (!std::isfinite(v)) {
                    return false;
                }
                if (jacobian != nullptr) {
                    jacobian[row * np + k] = v;
                }
                g[k] += r.a * v;
            }
        }
        if (outer != nullptr) {
            // Upper triangle of g g^T (a loop: Eigen's general rank update costs more per sample
            // for these 4-32 parameters).
            for (int l = 0; l < np; ++l) {
                for (int k = 0; k <= l; ++k) {
                    (*outer)(k, l) += g[k] * g[l];
                }
            }
        }
    }
    return true;
}

bool PreparedSamples::evaluate(const double* x,
                               std::size_t begin,
                               std::size_t end,
                               double* residuals,
                               double* jacobian) const {
    if (jacobian == nullptr) {
        const brdf::ModelD m = map_->model<double>(x);
        for (std::size_t i = begin; i < end; ++i) {
            const brdf::Rgbd f = eval(m, i);
            for (int c = 0; c < 3; ++c) {
                const double r = s_[c][i] * (g_of(f[c], i) - g_d_[c][i]);
                if (!std::isfinite(r)) {
                    return false;
                }
                residuals[3 * (i - begin) + c] = r;
            }
        }
        return true;
    }
    if (slots_ <= 4) {
        return jets_k<4>(x, begin, end, residuals, jacobian, nullptr);
    }
    if (slots_ <= 8) {
        return jets_k<8>(x, begin, end, residuals, jacobian, nullptr);
    }
    if (slots_ <= 16) {
        return jets_k<16>(x, begin, end, residuals, jacobian, nullptr);
    }
    return jets_k<32>(x, begin, end, residuals, jacobian, nullptr);
}

bool PreparedSamples::score_outer_products(const double* x,
                                           Eigen::MatrixXd& out,
                                           int threads) const {
    const int np = map_->size();
    // Per block: the np x np sum and whether it is finite; added in block order.
    const std::size_t stride = static_cast<std::size_t>(np) * np + 1;
    std::vector<double>& partial = block_scratch(stride);
    parallel_blocks(n_, threads, [&](std::size_t blk, std::size_t b, std::size_t e) {
        Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(np, np);
        bool good;
        if (slots_ <= 4) {
            good = jets_k<4>(x, b, e, nullptr, nullptr, &sum);
        } else if (slots_ <= 8) {
            good = jets_k<8>(x, b, e, nullptr, nullptr, &sum);
        } else if (slots_ <= 16) {
            good = jets_k<16>(x, b, e, nullptr, nullptr, &sum);
        } else {
            good = jets_k<32>(x, b, e, nullptr, nullptr, &sum);
        }
        double* dst = partial.data() + blk * stride;
        Eigen::Map<Eigen::MatrixXd>(dst, np, np) = sum;
        dst[stride - 1] = good ? 1.0 : 0.0;
    });
    out = Eigen::MatrixXd::Zero(np, np);
    for (std::size_t blk = 0; blk < block_count(n_); ++blk) {
        const double* src = partial.data() + blk * stride;
        if (src[stride - 1] == 0.0) {
            return false;
        }
        out += Eigen::Map<const Eigen::MatrixXd>(src, np, np);
    }
    out = Eigen::MatrixXd(out.selfadjointView<Eigen::Upper>());
    return out.allFinite();
}

void PreparedSamples::model_values(const brdf::ModelD& m,
                                   std::vector<brdf::Rgbd>& out,
                                   int threads) const {
    resize_huge(out, n_, brdf::Rgbd(brdf::Rgbd::Zero()));
    parallel_ranges(n_, threads, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            out[i] = eval(m, i);
        }
    });
}

void PreparedSamples::model_values(const brdf::ModelD& m,
                                   std::size_t begin,
                                   std::size_t end,
                                   brdf::Rgbd* out) const {
    GONIO_CHECK(begin <= end && end <= n_);
    for (std::size_t i = begin; i < end; ++i) {
        out[i - begin] = eval(m, i);
    }
}

void PreparedSamples::reweight_relative(const std::vector<brdf::Sample>& samples,
                                        const std::vector<brdf::Rgbd>& model) {
    GONIO_CHECK(samples.size() == n_ && model.size() == n_);
    for (std::size_t i = 0; i < n_; ++i) {
        const double sqrt_w = std::sqrt(samples[i].weight);
        const double ci = cos_i_[i];
        for (int c = 0; c < 3; ++c) {
            const double d = samples[i].value[c];
            const double sigma = samples[i].sigma[c];
            const double m = model[i][c];
            if (!(d > 0) || !(sigma > 0) || !(m > 0) || !std::isfinite(m)) {
                continue;
            }
            const double rel = sigma / d;
            double dg = 1;  // g'(m)
            if (form_ == ResidualForm::kLog) {
                dg = ci / (1 + m * ci);
            } else if (form_ == ResidualForm::kCubeRoot) {
                const double gm = std::cbrt(m + kCbrtOffset);
                dg = 1 / (3 * gm * gm);
            }
            s_[c][i] = sqrt_w / (dg * rel * m);
        }
    }
}

NormalEquationCost::NormalEquationCost(std::shared_ptr<const PreparedSamples> samples, int threads)
    : samples_(std::move(samples)), threads_(threads) {
    // Ceres' own threads do not enter here: one residual block, evaluated from one thread.
    const int n = samples_->map().size();
    set_num_residuals(n + 1);
    mutable_parameter_block_sizes()->push_back(n);
}

bool NormalEquationCost::Evaluate(double const* const* parameters,
                                  double* residuals,
                                  double** jacobians) const {
    const int n = samples_->map().size();
    const double* x = parameters[0];
    // One fused pass gives the cost and the normal equations together (the derivatives cost
    // little beyond the values, whose logarithms dominate). Levenberg-Marquardt evaluates the
    // cost at a candidate and, when it accepts the step, the Jacobian at the same point: the
    // cached pass answers the second call, so an iteration is one pass over the samples.
    const bool cached = cache_valid_ && std::equal(x, x + n, cache_x_.begin());
    if (!cached) {
        cache_valid_ = false;
        if (!samples_->normal_equations(x, cache_, threads_)) {
            return false;
        }
        ++passes_;
        cache_x_.assign(x, x + n);
        cache_valid_ = true;
    }
    const NormalEquations& ne = cache_;
    if (jacobians == nullptr || jacobians[0] == nullptr) {
        residuals[0] = std::sqrt(ne.cost_sum);
        for (int k = 1; k <= n; ++k) {
            residuals[k] = 0;
        }
        return std::isfinite(residuals[0]);
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(ne.jtj);
    const Eigen::VectorXd lam = es.eigenvalues();
    const Eigen::MatrixXd& v = es.eigenvectors();
    const double lmax = std::max(lam.maxCoeff(), 0.0);
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
        jacobians[0], n + 1, n);
    double projected = 0;
    for (int e = 0; e < n; ++e) {
        const double l = std::max(lam[e], 0.0);
        const double sq = std::sqrt(l);
        jac.row(e) = sq * v.col(e).transpose();
        // On a null direction of J^T J the gradient has no component (g lies in the range of
        // J^T), so the residual there is 0.
        const double r = l > 1e-15 * lmax && l > 0 ? v.col(e).dot(ne.jtr) / sq : 0.0;
        residuals[e] = r;
        projected += r * r;
    }
    jac.row(n).setZero();
    residuals[n] = std::sqrt(std::max(0.0, ne.cost_sum - projected));
    return std::isfinite(residuals[n]) && jac.allFinite();
}

}  // namespace gonio::fitting
