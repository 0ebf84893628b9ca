#include "gonio/acquisition/image/image_aniso.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "bin_groups.h"
#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"
#include "next_choice.h"

namespace gonio::acquisition {

int AnisoLayout::phi_h_index(double phi_h) const {
    // phi_h from atan2 lies in [-pi, pi]: shift into [0, 2 pi), then clamp rounding at the end.
    double p = phi_h < 0 ? phi_h + 2 * brdf::kPi : phi_h;
    if (!(p >= 0)) {
        // NaN never reaches here (callers check); rounding below zero: the first bin.
        p = 0;
    }
    const int i = static_cast<int>(p / (2 * brdf::kPi) * n_phi_h);
    return std::clamp(i, 0, n_phi_h - 1);
}

bool AnisoLayout::sane() const {
    for (int n : {n_theta_h, n_phi_h, n_theta_d, n_phi_d}) {
        if (n < 1 || n > 720) {
            return false;
        }
    }
    return true;
}

std::string AnisoLayout::describe() const {
    return std::to_string(n_theta_h) + "x" + std::to_string(n_phi_h) + "x" +
           std::to_string(n_theta_d) + "x" + std::to_string(n_phi_d) +
           " (theta_h x phi_h x theta_d x phi_d)";
}

std::size_t aniso_bin(const AnisoLayout& layout,
                      const brdf::Vec3d& wi,
                      const brdf::Vec3d& wo,
                      bool* swapped) {
    GONIO_CHECK_MSG(wi.allFinite() && wo.allFinite(),
                    "wi " << wi.transpose() << " wo " << wo.transpose());
    const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
    if (swapped != nullptr) {
        // fold_phi_d shifts a negative phi_d by pi: the pair with wi and wo exchanged.
        *swapped = hd.phi_d < 0;
    }
    const std::size_t iso = bin_index(layout.iso(), hd.theta_h, hd.theta_d, hd.phi_d);
    return layout.index(iso, layout.phi_h_index(hd.phi_h));
}

bool aniso_bin_valid(const AnisoLayout& layout, std::size_t bin) {
    return bin_valid(layout.iso(), layout.iso_bin(bin));
}

void AnisoFrameBins::add(const brdf::Vec3d& wi,
                         const brdf::Vec3d& wo,
                         const brdf::Rgbd& value,
                         const brdf::Rgbd& model_variance) {
    GONIO_CHECK_MSG(value.allFinite() && model_variance.allFinite(),
                    "value " << value.transpose() << " variance " << model_variance.transpose());
    bool swapped = false;
    Entry e;
    e.bin = static_cast<std::uint32_t>(aniso_bin(layout_, wi, wo, &swapped));
    const brdf::Vec3d& a = swapped ? wo : wi;
    const brdf::Vec3d& b = swapped ? wi : wo;
    for (int k = 0; k < 3; ++k) {
        e.value[k] = value[k];
        e.model_var[k] = model_variance[k];
        e.dirs[k] = static_cast<float>(a[k]);
        e.dirs[3 + k] = static_cast<float>(b[k]);
    }
    samples_.push_back(e);
}

std::vector<AnisoBinAggregate> AnisoFrameBins::aggregates() const {
    std::vector<AnisoBinAggregate> out;
    detail::summarise_bin_groups<6>(
        samples_,
        [](const Entry& e) { return e.dirs; },
        [&](const detail::ChannelWelford& w,
            const double* dirs,
            const std::uint32_t* first,
            const std::uint32_t* last) {
            // The representative: the sample closest to the mean in units of the noise.
            const Entry* rep = &samples_[*first];
            double best_d = 0;
            for (const std::uint32_t* k = first; k != last; ++k) {
                const Entry& e = samples_[*k];
                double d = 0;
                for (int c = 0; c < 3; ++c) {
                    const double r = e.value[c] - w.mean[c];
                    d += r * r / (w.model_var[c] + 1e-300);
                }
                if (k == first || d < best_d) {
                    rep = &e;
                    best_d = d;
                }
            }
            AnisoBinAggregate a = detail::aggregate_of<AnisoBinAggregate>(w);
            for (int c = 0; c < 3; ++c) {
                a.wi[c] = static_cast<float>(dirs[c]);
                a.wo[c] = static_cast<float>(dirs[3 + c]);
                a.rep_wi[c] = rep->dirs[c];
                a.rep_wo[c] = rep->dirs[3 + c];
                a.rep_value[c] = static_cast<float>(rep->value[c]);
            }
            out.push_back(a);
        });
    return out;
}

AnisoTable::AnisoTable(AnisoLayout layout)
    : layout_(layout),
      stats_(layout.size()),
      dirs_(6 * layout.size(), 0.0f),
      rep_(9 * layout.size(), 0.0f) {
    GONIO_CHECK_MSG(layout.sane(), layout.describe());
}

void AnisoTable::merge(const AnisoBinAggregate& a) {
    GONIO_CHECK_MSG(a.bin < stats_.size(), "bin " << a.bin << " of " << stats_.size());
    if (a.count == 0) {
        // An empty group adds nothing.
        return;
    }
    const std::size_t b = a.bin;
    GONIO_CHECK_MSG(detail::all_finite({a.mean.data(),
                                        a.m2.data(),
                                        a.model_var.data(),
                                        a.wi.data(),
                                        a.wo.data(),
                                        a.rep_wi.data(),
                                        a.rep_wo.data(),
                                        a.rep_value.data()}),
                    "bin " << b);
    const double na = stats_.merge(b, a.count, a.mean, a.m2, a.model_var);
    detail::merge_means(&dirs_[6 * b], a.wi.data(), 3, na, a.count);
    detail::merge_means(&dirs_[6 * b + 3], a.wo.data(), 3, na, a.count);
    // The representative closer to the merged mean, in units of the noise (the first group's
    // when the bin was empty).
    const brdf::Rgbd mean = stats_.mean(b);
    const auto distance = [&](const float* value) {
        double d = 0;
        for (int c = 0; c < 3; ++c) {
            const double r = value[c] - mean[c];
            d += r * r / (static_cast<double>(stats_.model_var_data(b)[c]) + 1e-300);
        }
        return d;
    };
    float* rep = &rep_[9 * b];
    if (na == 0 || distance(a.rep_value.data()) < distance(rep + 6)) {
        for (int c = 0; c < 3; ++c) {
            rep[c] = a.rep_wi[c];
            rep[3 + c] = a.rep_wo[c];
            rep[6 + c] = a.rep_value[c];
        }
    }
}

std::pair<brdf::Vec3d, brdf::Vec3d> AnisoTable::mean_directions(std::size_t bin) const {
    brdf::Vec3d wi(dirs_[6 * bin], dirs_[6 * bin + 1], dirs_[6 * bin + 2]);
    brdf::Vec3d wo(dirs_[6 * bin + 3], dirs_[6 * bin + 4], dirs_[6 * bin + 5]);
    const double ni = wi.norm();
    const double no = wo.norm();
    if (stats_.count(bin) == 0 || !(ni > 0) || !(no > 0)) {
        // Empty bin (or directions that cancel, impossible within one bin): no direction.
        return {brdf::Vec3d::Zero(), brdf::Vec3d::Zero()};
    }
    return {wi / ni, wo / no};
}

std::pair<brdf::Vec3d, brdf::Vec3d> AnisoTable::representative_directions(std::size_t bin) const {
    const float* r = &rep_[9 * bin];
    const brdf::Vec3d wi(r[0], r[1], r[2]);
    const brdf::Vec3d wo(r[3], r[4], r[5]);
    if (stats_.count(bin) == 0 || !(wi.norm() > 0) || !(wo.norm() > 0)) {
        // Empty bin: no representative.
        return {brdf::Vec3d::Zero(), brdf::Vec3d::Zero()};
    }
    return {wi.normalized(), wo.normalized()};
}

brdf::Rgbd AnisoTable::representative_value(std::size_t bin) const {
    const float* r = &rep_[9 * bin + 6];
    return {r[0], r[1], r[2]};
}

brdf::Rgbd AnisoTable::dataset_sigma(std::size_t bin) const {
    const brdf::Rgbd se = standard_error(bin);
    const brdf::Rgbd var = model_variance(bin);
    const brdf::Rgbd off = representative_value(bin) - mean(bin);
    return (se.square() + var + off.square()).sqrt();
}

brdf::Dataset AnisoTable::to_dataset(const std::string& source,
                                     std::uint32_t min_count,
                                     bool hdr,
                                     std::vector<std::size_t>* bins) const {
    return detail::bins_to_dataset(
        stats_,
        source,
        min_count,
        hdr,
        [&](std::size_t b, brdf::Sample* s) {
            const auto [wi, wo] = representative_directions(b);
            if (!(wi.z() > 0 && wo.z() > 0)) {
                // A pixel's directions are above the horizon (the exclusion rules); rounding to
                // single precision at a grazing limit could not be read back: not written.
                return false;
            }
            const brdf::Spherical<double> si = brdf::cartesian_to_spherical(wi);
            const brdf::Spherical<double> so = brdf::cartesian_to_spherical(wo);
            s->theta_i = si.theta;
            s->phi_i = si.phi;
            s->theta_o = so.theta;
            s->phi_o = so.phi;
            s->sigma = dataset_sigma(b);
            return true;
        },
        bins);
}

namespace {

/// A 4-D bin is valid when its isotropic part is: every phi_h bin of a valid half/difference bin.
std::vector<std::uint8_t> valid_aniso_bins(const AnisoLayout& layout) {
    std::vector<std::uint8_t> valid(layout.size(), 0);
    const TableLayout iso = layout.iso();
    for (std::size_t i = 0; i < iso.size(); ++i) {
        if (!bin_valid(iso, i)) {
            continue;
        }
        for (int p = 0; p < layout.n_phi_h; ++p) {
            valid[layout.index(i, p)] = 1;
        }
    }
    return valid;
}

}  // namespace

AnisoCoverage::AnisoCoverage(const AnisoLayout& layout)
    : BinCoverage(valid_aniso_bins(layout)), layout_(layout) {}

void AnisoCoverage::cover_from(const AnisoTable& table, std::uint32_t min_count) {
    cover_counts([&](std::size_t b) { return table.count(b); }, min_count);
}

std::vector<double> AnisoCoverage::cells() const {
    return cell_fractions(layout_.iso(),
                          [&](std::size_t iso_bin, std::size_t* n_valid, std::size_t* n_covered) {
                              for (int p = 0; p < layout_.n_phi_h; ++p) {
                                  const std::size_t b = layout_.index(iso_bin, p);
                                  *n_valid += valid(b) ? 1 : 0;
                                  *n_covered += covered(b) ? 1 : 0;
                              }
                          });
}

CoverageMap AnisoCoverage::isotropic() const {
    CoverageMap m(layout_.iso());
    for (std::size_t b = 0; b < size(); ++b) {
        if (covered(b)) {
            m.cover(layout_.iso_bin(b));
        }
    }
    return m;
}

std::vector<double> spin_positions(const SpinRange& r) {
    GONIO_CHECK(r.step_rad > 0 && r.max_rad >= r.min_rad);
    std::vector<double> out;
    const bool full_turn = r.max_rad - r.min_rad >= 2 * brdf::kPi - 1e-9;
    for (const double s : detail::range_steps(r.min_rad, r.max_rad, r.step_rad)) {
        if (full_turn && s >= r.min_rad + 2 * brdf::kPi - 1e-9) {
            // The same position as the start of the turn.
            break;
        }
        out.push_back(s);
    }
    return out;
}

std::vector<PoseCandidate> pose_candidates(const CameraModel& camera,
                                           const SphereGeometry& sphere,
                                           const ExclusionRules& rules,
                                           const AnisoLayout& layout,
                                           double detector_arm_rad,
                                           const LightRange& lights,
                                           const SpinRange& spins,
                                           double pole_rad,
                                           int pixel_stride) {
    GONIO_CHECK(lights.step_rad > 0 && pixel_stride >= 1);
    const std::vector<SpherePixel> pixels =
        detail::strided_pixels(camera, sphere, rules, pixel_stride);
    const double cos_max_i = std::cos(rules.max_theta_i);
    const AnisoCoverage valid(layout);
    const std::vector<double> light_arm_rad = light_positions(lights, detector_arm_rad);
    std::vector<PoseCandidate> out;
    detail::BinMarks marks(layout.size());
    for (const double s : spin_positions(spins)) {
        const brdf::Vec3d axis = lathe_axis_world(0, s);
        std::vector<brdf::Vec3d> tangents(pixels.size());
        for (std::size_t i = 0; i < pixels.size(); ++i) {
            tangents[i] = lathe_tangent(pixels[i].normal, axis, pole_rad);
        }
        for (const double a : light_arm_rad) {
            const brdf::Vec3d l = brdf::arm_direction(a);
            PoseCandidate c;
            c.light_arm_rad = a;
            c.spin_rad = s;
            c.bins = detail::predicted_bins(
                pixels.size(),
                cos_max_i,
                [&](std::size_t i, brdf::Vec3d* wi, brdf::Vec3d* wo) {
                    if (tangents[i] == brdf::Vec3d::Zero()) {
                        // Inside a pole cap: no tangent.
                        return false;
                    }
                    std::tie(*wi, *wo) = local_directions(pixels[i], tangents[i], l);
                    return true;
                },
                [&](const brdf::Vec3d& wi, const brdf::Vec3d& wo) {
                    return aniso_bin(layout, wi, wo);
                },
                [&](std::size_t b) { return valid.valid(b); },
                &marks);
            if (!c.bins.empty()) {
                out.push_back(std::move(c));
            }
        }
    }
    return out;
}

int next_pose(const std::vector<PoseCandidate>& candidates,
              const std::vector<std::size_t>& gains,
              double current_light_rad,
              double current_spin_rad,
              double gain_fraction) {
    return detail::choose_next(
        candidates, gains, std::clamp(gain_fraction, 1e-9, 1.0), [&](const PoseCandidate& c) {
            return std::abs(c.light_arm_rad - current_light_rad) +
                   std::abs(c.spin_rad - current_spin_rad);
        });
}

}  // namespace gonio::acquisition
