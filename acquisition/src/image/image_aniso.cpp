#include "gonio/acquisition/image/image_aniso.h"

#include <algorithm>
#include <cmath>

#include "bin_groups.h"
#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"

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
        e.wi[k] = static_cast<float>(a[k]);
        e.wo[k] = static_cast<float>(b[k]);
    }
    samples_.push_back(e);
}

std::vector<AnisoBinAggregate> AnisoFrameBins::aggregates() const {
    std::vector<AnisoBinAggregate> out;
    detail::for_each_bin_group(
        samples_, [&](std::uint32_t bin, const std::uint32_t* first, const std::uint32_t* last) {
            detail::ChannelWelford w;
            double wi[3] = {0, 0, 0};
            double wo[3] = {0, 0, 0};
            for (const std::uint32_t* k = first; k != last; ++k) {
                const Entry& e = samples_[*k];
                w.add(e.value, e.model_var);
                for (int c = 0; c < 3; ++c) {
                    wi[c] += (e.wi[c] - wi[c]) / w.n;
                    wo[c] += (e.wo[c] - wo[c]) / w.n;
                }
            }
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
            AnisoBinAggregate a;
            a.bin = bin;
            a.count = w.n;
            for (int c = 0; c < 3; ++c) {
                a.mean[c] = static_cast<float>(w.mean[c]);
                a.m2[c] = static_cast<float>(w.m2[c]);
                a.model_var[c] = static_cast<float>(w.model_var[c]);
                a.wi[c] = static_cast<float>(wi[c]);
                a.wo[c] = static_cast<float>(wo[c]);
                a.rep_wi[c] = rep->wi[c];
                a.rep_wo[c] = rep->wo[c];
                a.rep_value[c] = static_cast<float>(rep->value[c]);
            }
            out.push_back(a);
        });
    return out;
}

AnisoTable::AnisoTable(AnisoLayout layout)
    : layout_(layout),
      count_(layout.size(), 0),
      mean_(3 * layout.size(), 0.0),
      m2_(3 * layout.size(), 0.0),
      model_var_(3 * layout.size(), 0.0f),
      dirs_(6 * layout.size(), 0.0f),
      rep_(9 * layout.size(), 0.0f) {
    GONIO_CHECK_MSG(layout.sane(), layout.describe());
}

void AnisoTable::merge(const AnisoBinAggregate& a) {
    GONIO_CHECK_MSG(a.bin < count_.size(), "bin " << a.bin << " of " << count_.size());
    if (a.count == 0) {
        // An empty group adds nothing.
        return;
    }
    const std::size_t b = a.bin;
    const double na = count_[b];
    const double nb = a.count;
    const double n = na + nb;
    for (int c = 0; c < 3; ++c) {
        GONIO_CHECK_MSG(std::isfinite(a.mean[c]) && std::isfinite(a.m2[c]) &&
                            std::isfinite(a.model_var[c]) && std::isfinite(a.wi[c]) &&
                            std::isfinite(a.wo[c]),
                        "bin " << b << " component " << c);
        double& mean = mean_[3 * b + c];
        const double delta = a.mean[c] - mean;
        mean += delta * nb / n;
        m2_[3 * b + c] += a.m2[c] + delta * delta * na * nb / n;
        float& mv = model_var_[3 * b + c];
        mv = static_cast<float>((na * mv + nb * a.model_var[c]) / n);
        float& wi = dirs_[6 * b + c];
        wi = static_cast<float>((na * wi + nb * a.wi[c]) / n);
        float& wo = dirs_[6 * b + 3 + c];
        wo = static_cast<float>((na * wo + nb * a.wo[c]) / n);
        GONIO_CHECK_MSG(std::isfinite(a.rep_wi[c]) && std::isfinite(a.rep_wo[c]) &&
                            std::isfinite(a.rep_value[c]),
                        "bin " << b << " representative component " << c);
    }
    // The representative closer to the merged mean, in units of the noise (the first group's
    // when the bin was empty).
    const auto distance = [&](const float* value) {
        double d = 0;
        for (int c = 0; c < 3; ++c) {
            const double r = value[c] - mean_[3 * b + c];
            d += r * r / (static_cast<double>(model_var_[3 * b + c]) + 1e-300);
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
    count_[b] += a.count;
    total_ += a.count;
}

brdf::Rgbd AnisoTable::mean(std::size_t bin) const {
    return {mean_[3 * bin], mean_[3 * bin + 1], mean_[3 * bin + 2]};
}

brdf::Rgbd AnisoTable::sample_variance(std::size_t bin) const {
    const std::uint32_t n = count_[bin];
    if (n < 2) {
        // One sample has no spread.
        return brdf::Rgbd::Zero();
    }
    return brdf::Rgbd(m2_[3 * bin], m2_[3 * bin + 1], m2_[3 * bin + 2]) / (n - 1.0);
}

brdf::Rgbd AnisoTable::standard_error(std::size_t bin) const {
    const double n = std::max<std::uint32_t>(count_[bin], 1);
    brdf::Rgbd out;
    const brdf::Rgbd s2 = sample_variance(bin);
    for (int c = 0; c < 3; ++c) {
        const double model = std::sqrt(std::max(0.0f, model_var_[3 * bin + c]) / n);
        const double empirical = count_[bin] >= 2 ? std::sqrt(std::max(0.0, s2[c]) / n) : 0.0;
        out[c] = std::max(model, empirical);
    }
    return out;
}

std::pair<brdf::Vec3d, brdf::Vec3d> AnisoTable::mean_directions(std::size_t bin) const {
    brdf::Vec3d wi(dirs_[6 * bin], dirs_[6 * bin + 1], dirs_[6 * bin + 2]);
    brdf::Vec3d wo(dirs_[6 * bin + 3], dirs_[6 * bin + 4], dirs_[6 * bin + 5]);
    const double ni = wi.norm();
    const double no = wo.norm();
    if (count_[bin] == 0 || !(ni > 0) || !(no > 0)) {
        // Empty bin (or directions that cancel, impossible within one bin): no direction.
        return {brdf::Vec3d::Zero(), brdf::Vec3d::Zero()};
    }
    return {wi / ni, wo / no};
}

std::pair<brdf::Vec3d, brdf::Vec3d> AnisoTable::representative_directions(std::size_t bin) const {
    const float* r = &rep_[9 * bin];
    const brdf::Vec3d wi(r[0], r[1], r[2]);
    const brdf::Vec3d wo(r[3], r[4], r[5]);
    if (count_[bin] == 0 || !(wi.norm() > 0) || !(wo.norm() > 0)) {
        // Empty bin: no representative.
        return {brdf::Vec3d::Zero(), brdf::Vec3d::Zero()};
    }
    return {wi.normalized(), wo.normalized()};
}

brdf::Rgbd AnisoTable::representative_value(std::size_t bin) const {
    const float* r = &rep_[9 * bin + 6];
    return {r[0], r[1], r[2]};
}

brdf::Rgbd AnisoTable::model_variance(std::size_t bin) const {
    const float* v = &model_var_[3 * bin];
    return brdf::Rgbd(v[0], v[1], v[2]).max(0.0);
}

brdf::Rgbd AnisoTable::dataset_sigma(std::size_t bin) const {
    const brdf::Rgbd se = standard_error(bin);
    const brdf::Rgbd var = model_variance(bin);
    const brdf::Rgbd off = representative_value(bin) - mean(bin);
    return (se.square() + var + off.square()).sqrt();
}

std::size_t AnisoTable::filled_bins(std::uint32_t min_count) const {
    const std::uint32_t m = std::max<std::uint32_t>(min_count, 1);
    return static_cast<std::size_t>(
        std::count_if(count_.begin(), count_.end(), [m](std::uint32_t c) { return c >= m; }));
}

brdf::Dataset AnisoTable::to_dataset(const std::string& source,
                                     std::uint32_t min_count,
                                     bool hdr) const {
    brdf::Dataset d;
    d.source = source;
    d.has_sigma = true;
    d.has_flags = true;
    for (std::size_t b = 0; b < count_.size(); ++b) {
        if (count_[b] < std::max<std::uint32_t>(min_count, 1)) {
            continue;
        }
        const auto [wi, wo] = representative_directions(b);
        if (!(wi.z() > 0 && wo.z() > 0)) {
            // A pixel's directions are above the horizon (the exclusion rules); rounding to single
            // precision at a grazing limit could not be read back: not written.
            continue;
        }
        const brdf::Spherical<double> si = brdf::cartesian_to_spherical(wi);
        const brdf::Spherical<double> so = brdf::cartesian_to_spherical(wo);
        brdf::Sample s;
        s.theta_i = si.theta;
        s.phi_i = si.phi;
        s.theta_o = so.theta;
        s.phi_o = so.phi;
        s.value = mean(b).max(0.0);
        s.sigma = dataset_sigma(b);
        s.flags = hdr ? brdf::kFlagHdr : 0u;
        d.samples.push_back(s);
    }
    return d;
}

AnisoCoverage::AnisoCoverage(const AnisoLayout& layout)
    : layout_(layout), valid_(layout.size(), 0), covered_(layout.size(), 0) {
    const TableLayout iso = layout.iso();
    for (std::size_t i = 0; i < iso.size(); ++i) {
        if (!bin_valid(iso, i)) {
            continue;
        }
        for (int p = 0; p < layout.n_phi_h; ++p) {
            valid_[layout.index(i, p)] = 1;
        }
        valid_count_ += static_cast<std::size_t>(layout.n_phi_h);
    }
}

double AnisoCoverage::fraction() const {
    if (valid_count_ == 0) {
        // No valid bin (never with positive counts): nothing to cover.
        return 1.0;
    }
    return static_cast<double>(covered_count_) / static_cast<double>(valid_count_);
}

void AnisoCoverage::cover(std::size_t bin) {
    GONIO_CHECK(bin < covered_.size());
    if (valid_[bin] && !covered_[bin]) {
        covered_[bin] = 1;
        ++covered_count_;
    }
}

void AnisoCoverage::cover_from(const AnisoTable& table, std::uint32_t min_count) {
    const std::uint32_t m = std::max<std::uint32_t>(min_count, 1);
    for (std::size_t b = 0; b < table.size(); ++b) {
        if (table.count(b) >= m) {
            cover(b);
        }
    }
}

std::size_t AnisoCoverage::gain(const std::vector<std::uint32_t>& bins) const {
    std::size_t g = 0;
    for (std::uint32_t b : bins) {
        g += valid_[b] && !covered_[b] ? 1 : 0;
    }
    return g;
}

std::vector<double> AnisoCoverage::cells() const {
    const TableLayout iso = layout_.iso();
    std::vector<double> out(static_cast<std::size_t>(iso.n_theta_h) * iso.n_theta_d, -1.0);
    for (int i_d = 0; i_d < iso.n_theta_d; ++i_d) {
        for (int i_h = 0; i_h < iso.n_theta_h; ++i_h) {
            std::size_t valid = 0;
            std::size_t covered = 0;
            for (int i_p = 0; i_p < iso.n_phi_d; ++i_p) {
                const std::size_t ib = iso.index(i_h, i_d, i_p);
                for (int p = 0; p < layout_.n_phi_h; ++p) {
                    const std::size_t b = layout_.index(ib, p);
                    valid += valid_[b];
                    covered += covered_[b];
                }
            }
            if (valid > 0) {
                out[static_cast<std::size_t>(i_d) * iso.n_theta_h + i_h] =
                    static_cast<double>(covered) / static_cast<double>(valid);
            }
        }
    }
    return out;
}

CoverageMap AnisoCoverage::isotropic() const {
    CoverageMap m(layout_.iso());
    for (std::size_t b = 0; b < covered_.size(); ++b) {
        if (covered_[b]) {
            m.cover(layout_.iso_bin(b));
        }
    }
    return m;
}

std::vector<double> spin_positions(const SpinRange& r) {
    GONIO_CHECK(r.step_rad > 0 && r.max_rad >= r.min_rad);
    std::vector<double> out;
    const bool full_turn = r.max_rad - r.min_rad >= 2 * brdf::kPi - 1e-9;
    const int steps = static_cast<int>(std::floor((r.max_rad - r.min_rad) / r.step_rad + 1e-9));
    for (int k = 0; k <= steps; ++k) {
        const double s = r.min_rad + k * r.step_rad;
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
    std::vector<SpherePixel> pixels = sphere_pixels(camera, sphere, rules, nullptr);
    if (pixel_stride > 1) {
        pixels.erase(std::remove_if(pixels.begin(),
                                    pixels.end(),
                                    [&](const SpherePixel& p) {
                                        return p.x % pixel_stride != 0 || p.y % pixel_stride != 0;
                                    }),
                     pixels.end());
    }
    const double cos_max_i = std::cos(rules.max_theta_i);
    const AnisoCoverage valid(layout);
    std::vector<double> light_positions;
    const int steps =
        static_cast<int>(std::floor((lights.max_rad - lights.min_rad) / lights.step_rad + 1e-9));
    for (int k = 0; k <= steps; ++k) {
        const double a = lights.min_rad + k * lights.step_rad;
        if (brdf::arm_separation(a, detector_arm_rad) >= lights.blind_zone_rad) {
            light_positions.push_back(a);
        }
    }
    std::vector<PoseCandidate> out;
    for (const double s : spin_positions(spins)) {
        const brdf::Vec3d axis = lathe_axis_world(0, s);
        std::vector<brdf::Vec3d> tangents(pixels.size());
        for (std::size_t i = 0; i < pixels.size(); ++i) {
            tangents[i] = lathe_tangent(pixels[i].normal, axis, pole_rad);
        }
        for (const double a : light_positions) {
            const brdf::Vec3d l = brdf::arm_direction(a);
            PoseCandidate c;
            c.light_arm_rad = a;
            c.spin_rad = s;
            for (std::size_t i = 0; i < pixels.size(); ++i) {
                if (tangents[i] == brdf::Vec3d::Zero()) {
                    // Inside a pole cap: no tangent.
                    continue;
                }
                const auto [wi, wo] = local_directions(pixels[i], tangents[i], l);
                if (wi.z() < cos_max_i) {
                    // Shadowed or grazing light: no sample from this pixel.
                    continue;
                }
                const std::size_t b = aniso_bin(layout, wi, wo);
                if (valid.valid(b)) {
                    c.bins.push_back(static_cast<std::uint32_t>(b));
                }
            }
            std::sort(c.bins.begin(), c.bins.end());
            c.bins.erase(std::unique(c.bins.begin(), c.bins.end()), c.bins.end());
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
    GONIO_CHECK(gains.size() == candidates.size());
    const std::size_t best = gains.empty() ? 0 : *std::max_element(gains.begin(), gains.end());
    if (best == 0) {
        return -1;
    }
    const double f = std::clamp(gain_fraction, 1e-9, 1.0);
    int chosen = -1;
    double chosen_move = 0;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        if (static_cast<double>(gains[k]) < f * static_cast<double>(best)) {
            continue;
        }
        const double move = std::abs(candidates[k].light_arm_rad - current_light_rad) +
                            std::abs(candidates[k].spin_rad - current_spin_rad);
        if (chosen < 0 || move < chosen_move ||
            (move == chosen_move && gains[k] > gains[static_cast<std::size_t>(chosen)])) {
            chosen = static_cast<int>(k);
            chosen_move = move;
        }
    }
    return chosen;
}

}  // namespace gonio::acquisition
