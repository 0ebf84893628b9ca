#include "gonio/acquisition/image/image_binning.h"

#include <algorithm>
#include <cmath>

#include "bin_groups.h"
#include "gonio/acquisition/image/bin_coverage.h"
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
    : layout_(layout), stats_(layout.size()), position_(3 * layout.size(), 0.0f) {
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
    GONIO_CHECK_MSG(value.allFinite() && model_variance.allFinite() && bin < stats_.size(),
                    "bin " << bin << " value " << value.transpose() << " variance "
                           << model_variance.transpose());
    const double inv_n = stats_.add(bin, value, model_variance);
    const double pos[3] = {hd.theta_h, hd.theta_d, brdf::fold_phi_d(hd.phi_d)};
    for (int k = 0; k < 3; ++k) {
        float& p = position_[3 * bin + k];
        p += static_cast<float>((pos[k] - p) * inv_n);
    }
}

void BinnedTable::merge(const BinAggregate& a) {
    GONIO_CHECK_MSG(a.bin < stats_.size(), "bin " << a.bin << " of " << stats_.size());
    if (a.count == 0) {
        // An empty group adds nothing.
        return;
    }
    GONIO_CHECK_MSG(detail::all_finite({a.mean.data(), a.m2.data(), a.model_var.data()}),
                    "bin " << a.bin);
    const double na = stats_.merge(a.bin, a.count, a.mean, a.m2, a.model_var);
    detail::merge_means(&position_[3 * a.bin], a.position.data(), 3, na, a.count);
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
    detail::summarise_bin_groups<3>(
        samples_,
        [](const Entry& e) { return e.position; },
        [&](const detail::ChannelWelford& w,
            const double* pos,
            const std::uint32_t*,
            const std::uint32_t*) {
            BinAggregate a = detail::aggregate_of<BinAggregate>(w);
            for (int c = 0; c < 3; ++c) {
                a.position[c] = static_cast<float>(pos[c]);
            }
            out.push_back(a);
        });
    return out;
}

brdf::HalfDiff<double> BinnedTable::mean_position(std::size_t bin) const {
    brdf::HalfDiff<double> hd;
    hd.theta_h = position_[3 * bin];
    hd.phi_h = 0;
    hd.theta_d = position_[3 * bin + 1];
    hd.phi_d = position_[3 * bin + 2];
    return hd;
}

brdf::Dataset BinnedTable::to_dataset(const std::string& source,
                                      std::uint32_t min_count,
                                      bool hdr,
                                      std::vector<std::size_t>* bins) const {
    return detail::bins_to_dataset(
        stats_,
        source,
        min_count,
        hdr,
        [&](std::size_t b, brdf::Sample* s) {
            const auto [wi, wo] = brdf::from_half_diff(mean_position(b));
            if (!(wi.z() > 0 && wo.z() > 0)) {
                // The mean position of a bin straddling the horizon can fall just below it: such
                // a row would be rejected by every reader, so it is not written.
                return false;
            }
            const brdf::Spherical<double> si = brdf::cartesian_to_spherical(wi);
            const brdf::Spherical<double> so = brdf::cartesian_to_spherical(wo);
            // Isotropy: rotate the pair so that phi_i = 0.
            s->theta_i = si.theta;
            s->phi_i = 0;
            s->theta_o = so.theta;
            s->phi_o = brdf::wrap_pi(so.phi - si.phi);
            s->sigma = standard_error(b);
            return true;
        },
        bins);
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
    return cell_fractions(l, [&](std::size_t b, std::size_t* valid, std::size_t* covered) {
        if (bin_valid(l, b)) {
            ++*valid;
            *covered += table.count(b) >= min_count ? 1 : 0;
        }
    });
}

}  // namespace gonio::acquisition
