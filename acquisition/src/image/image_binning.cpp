#include "gonio/acquisition/image/image_binning.h"

#include <algorithm>
#include <cmath>

#include "bin_groups.h"
#include "gonio/base/check.h"
#include "gonio/brdf/merl.h"

namespace gonio::acquisition {
std::size_t bin_index(const TableLayout& layout, double theta_h, double theta_d, double phi_d) {
    GONIO_CHECK_MSG(std::isfinite(theta_h) && std::isfinite(theta_d) && std::isfinite(phi_d),
                    "theta_h " << theta_h << " theta_d " << theta_d << " phi_d " << phi_d);
    return layout.index(
        layout.theta_h_index(theta_h), layout.theta_d_index(theta_d), layout.phi_d_index(phi_d));
}

brdf::HalfDiff<double> bin_centre(const TableLayout& layout, std::size_t index) {
    const std::array<int, 3> i = layout.unflatten(index);
    brdf::HalfDiff<double> hd;
    hd.theta_h = layout.theta_h_centre(i[0]);
    hd.phi_h = 0;
    hd.theta_d = layout.theta_d_centre(i[1]);
    hd.phi_d = layout.phi_d_centre(i[2]);
    return hd;
}

bool bin_valid(const TableLayout& layout, std::size_t index) {
    const std::array<int, 3> i = layout.unflatten(index);
    const auto [wi, wo] = layout.centre_directions(i[0], i[1], i[2]);
    return wi.z() > 0 && wo.z() > 0;
}

BinnedTable::BinnedTable(TableLayout layout)
    : layout_(layout),
      count_(layout.size(), 0),
      mean_(3 * layout.size(), 0.0),
      m2_(3 * layout.size(), 0.0),
      model_var_(3 * layout.size(), 0.0f),
      position_(3 * layout.size(), 0.0f) {
    GONIO_CHECK(layout.n_theta_h > 0 && layout.n_theta_d > 0 && layout.n_phi_d > 0);
}

void BinnedTable::add(const brdf::Vec3d& wi,
                      const brdf::Vec3d& wo,
                      const brdf::Rgbd& value,
                      const brdf::Rgbd& model_variance) {
    const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
    add_to_bin(bin_index(layout_, hd.theta_h, hd.theta_d, hd.phi_d), hd, value, model_variance);
}

void BinnedTable::add_to_bin(std::size_t bin,
                             const brdf::HalfDiff<double>& hd,
                             const brdf::Rgbd& value,
                             const brdf::Rgbd& model_variance) {
    GONIO_CHECK_MSG(value.allFinite() && model_variance.allFinite() && bin < count_.size(),
                    "bin " << bin << " value " << value.transpose() << " variance "
                           << model_variance.transpose());
    const std::uint32_t n = ++count_[bin];
    const double inv_n = 1.0 / n;
    for (int c = 0; c < 3; ++c) {
        // Welford: delta against the old mean, then against the new one.
        double& mean = mean_[3 * bin + c];
        const double delta = value[c] - mean;
        mean += delta * inv_n;
        m2_[3 * bin + c] += delta * (value[c] - mean);
        float& mv = model_var_[3 * bin + c];
        mv += static_cast<float>((model_variance[c] - mv) * inv_n);
    }
    const double pos[3] = {hd.theta_h, hd.theta_d, brdf::fold_phi_d(hd.phi_d)};
    for (int k = 0; k < 3; ++k) {
        float& p = position_[3 * bin + k];
        p += static_cast<float>((pos[k] - p) * inv_n);
    }
    ++total_;
}

void BinnedTable::merge(const BinAggregate& a) {
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
        GONIO_CHECK_MSG(
            std::isfinite(a.mean[c]) && std::isfinite(a.m2[c]) && std::isfinite(a.model_var[c]),
            "bin " << b << " channel " << c);
        double& mean = mean_[3 * b + c];
        const double delta = a.mean[c] - mean;
        mean += delta * nb / n;
        m2_[3 * b + c] += a.m2[c] + delta * delta * na * nb / n;
        float& mv = model_var_[3 * b + c];
        mv = static_cast<float>((na * mv + nb * a.model_var[c]) / n);
    }
    for (int k = 0; k < 3; ++k) {
        float& p = position_[3 * b + k];
        p = static_cast<float>((na * p + nb * a.position[k]) / n);
    }
    count_[b] += a.count;
    total_ += a.count;
}

void FrameBins::add(const brdf::Vec3d& wi,
                    const brdf::Vec3d& wo,
                    const brdf::Rgbd& value,
                    const brdf::Rgbd& model_variance) {
    GONIO_CHECK_MSG(value.allFinite() && model_variance.allFinite(),
                    "value " << value.transpose() << " variance " << model_variance.transpose());
    const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
    Entry e;
    e.bin = static_cast<std::uint32_t>(bin_index(layout_, hd.theta_h, hd.theta_d, hd.phi_d));
    e.position[0] = static_cast<float>(hd.theta_h);
    e.position[1] = static_cast<float>(hd.theta_d);
    e.position[2] = static_cast<float>(brdf::fold_phi_d(hd.phi_d));
    for (int c = 0; c < 3; ++c) {
        e.value[c] = value[c];
        e.model_var[c] = model_variance[c];
    }
    samples_.push_back(e);
}

std::vector<BinAggregate> FrameBins::aggregates() const {
    std::vector<BinAggregate> out;
    detail::for_each_bin_group(
        samples_, [&](std::uint32_t bin, const std::uint32_t* first, const std::uint32_t* last) {
            detail::ChannelWelford w;
            double pos[3] = {0, 0, 0};
            for (const std::uint32_t* k = first; k != last; ++k) {
                const Entry& e = samples_[*k];
                w.add(e.value, e.model_var);
                for (int c = 0; c < 3; ++c) {
                    pos[c] += (e.position[c] - pos[c]) / w.n;
                }
            }
            BinAggregate a;
            a.bin = bin;
            a.count = w.n;
            for (int c = 0; c < 3; ++c) {
                a.mean[c] = static_cast<float>(w.mean[c]);
                a.m2[c] = static_cast<float>(w.m2[c]);
                a.model_var[c] = static_cast<float>(w.model_var[c]);
                a.position[c] = static_cast<float>(pos[c]);
            }
            out.push_back(a);
        });
    return out;
}

brdf::Rgbd BinnedTable::mean(std::size_t bin) const {
    return brdf::Rgbd(mean_[3 * bin], mean_[3 * bin + 1], mean_[3 * bin + 2]);
}

brdf::Rgbd BinnedTable::sample_variance(std::size_t bin) const {
    const std::uint32_t n = count_[bin];
    if (n < 2) {
        // One sample has no spread.
        return brdf::Rgbd::Zero();
    }
    return brdf::Rgbd(m2_[3 * bin], m2_[3 * bin + 1], m2_[3 * bin + 2]) / (n - 1.0);
}

brdf::Rgbd BinnedTable::model_standard_error(std::size_t bin) const {
    const std::uint32_t n = count_[bin];
    if (n == 0) {
        // Empty bin: no estimate, no error.
        return brdf::Rgbd::Zero();
    }
    brdf::Rgbd v(model_var_[3 * bin], model_var_[3 * bin + 1], model_var_[3 * bin + 2]);
    return (v.max(0.0) / n).sqrt();
}

brdf::Rgbd BinnedTable::standard_error(std::size_t bin) const {
    const std::uint32_t n = count_[bin];
    const brdf::Rgbd model = model_standard_error(bin);
    if (n < 2) {
        return model;
    }
    const brdf::Rgbd empirical = (sample_variance(bin) / n).sqrt();
    return empirical.max(model);
}

brdf::HalfDiff<double> BinnedTable::mean_position(std::size_t bin) const {
    brdf::HalfDiff<double> hd;
    hd.theta_h = position_[3 * bin];
    hd.phi_h = 0;
    hd.theta_d = position_[3 * bin + 1];
    hd.phi_d = position_[3 * bin + 2];
    return hd;
}

std::size_t BinnedTable::filled_bins(std::uint32_t min_count) const {
    return static_cast<std::size_t>(std::count_if(
        count_.begin(), count_.end(), [&](std::uint32_t n) { return n >= min_count; }));
}

brdf::Dataset BinnedTable::to_dataset(const std::string& source,
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
        const auto [wi, wo] = brdf::from_half_diff(mean_position(b));
        if (!(wi.z() > 0 && wo.z() > 0)) {
            // The mean position of a bin straddling the horizon can fall just below it: such a
            // row would be rejected by every reader, so it is not written.
            continue;
        }
        const brdf::Spherical<double> si = brdf::cartesian_to_spherical(wi);
        const brdf::Spherical<double> so = brdf::cartesian_to_spherical(wo);
        brdf::Sample s;
        // Isotropy: rotate the pair so that phi_i = 0.
        s.theta_i = si.theta;
        s.phi_i = 0;
        s.theta_o = so.theta;
        s.phi_o = brdf::wrap_pi(so.phi - si.phi);
        s.value = mean(b).max(0.0);
        s.sigma = standard_error(b);
        s.flags = hdr ? brdf::kFlagHdr : 0u;
        d.samples.push_back(s);
    }
    return d;
}

brdf::TabulatedBrdf to_tabulated(const BinnedTable& table,
                                 std::uint32_t min_count,
                                 const std::string& source) {
    brdf::TabulatedBrdf out = brdf::TabulatedBrdf::empty(table.layout(), brdf::kMerlScale, source);
    for (std::size_t b = 0; b < table.size(); ++b) {
        if (table.count(b) >= std::max<std::uint32_t>(min_count, 1)) {
            // Noise can push a mean of a near-black bin below zero; a BRDF is non-negative.
            out.set_bin(b, table.mean(b).max(0.0));
        }
    }
    return out;
}

std::vector<double> coverage_cells(const BinnedTable& table, std::uint32_t min_count) {
    const TableLayout& l = table.layout();
    std::vector<double> out(static_cast<std::size_t>(l.n_theta_h) * l.n_theta_d, -1.0);
    for (int i_d = 0; i_d < l.n_theta_d; ++i_d) {
        for (int i_h = 0; i_h < l.n_theta_h; ++i_h) {
            int valid = 0;
            int filled = 0;
            for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
                const std::size_t b = l.index(i_h, i_d, i_p);
                if (!bin_valid(l, b)) {
                    continue;
                }
                ++valid;
                filled += table.count(b) >= min_count ? 1 : 0;
            }
            if (valid > 0) {
                out[static_cast<std::size_t>(i_d) * l.n_theta_h + i_h] =
                    static_cast<double>(filled) / valid;
            }
        }
    }
    return out;
}

}  // namespace gonio::acquisition
