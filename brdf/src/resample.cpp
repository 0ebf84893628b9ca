#include "gonio/brdf/resample.h"

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "gonio/base/check.h"
#include "gonio/base/limits.h"

namespace gonio::brdf {
namespace {

unsigned resolve_threads(unsigned requested, int rows) {
    unsigned n = requested != 0 ? requested : std::thread::hardware_concurrency();
    if (n == 0) {
        // hardware_concurrency() may not know: one thread.
        n = 1;
    }
    return std::min<unsigned>(n, static_cast<unsigned>(std::max(rows, 1)));
}

}  // namespace

TabulatedBrdf tabulate(const Brdf& brdf, const TabulateOptions& options, TabulateReport* report) {
    const TableGrid& grid = options.grid;
    TabulatedBrdf table = TabulatedBrdf::empty(grid, options.scale, brdf.describe());
    const unsigned threads = resolve_threads(options.threads, grid.n_theta_h);
    std::vector<TabulateReport> partial(threads);
    auto work = [&](unsigned t) {
        TabulateReport& r = partial[t];
        // Rows of theta_h interleaved over threads: cost per row is uniform.
        for (int ih = static_cast<int>(t); ih < grid.n_theta_h; ih += static_cast<int>(threads)) {
            for (int id = 0; id < grid.n_theta_d; ++id) {
                for (int ip = 0; ip < grid.n_phi_d; ++ip) {
                    const std::size_t flat = grid.index(ih, id, ip);
                    const auto [wi, wo] = grid.centre_directions(ih, id, ip);
                    ++r.bins;
                    if (!(wi.z() > 0) || !(wo.z() > 0)) {
                        // The pair is not a reflection configuration: no BRDF value.
                        ++r.below_horizon;
                        continue;
                    }
                    const Rgbd f = brdf.eval(wi, wo);
                    if (!f.isFinite().all()) {
                        // Breaks the Brdf contract: keep the bin invalid and count it.
                        ++r.non_finite;
                        continue;
                    }
                    if ((f > kMaxTableValue).any()) {
                        // Not storable: left invalid and counted, the caller reports it.
                        ++r.out_of_range;
                        continue;
                    }
                    // Rounding can make a tiny negative value in a model; zero is the BRDF's floor.
                    table.set_bin(flat, f.max(0.0));
                    ++r.valid_bins;
                }
            }
        }
    };
    if (threads == 1) {
        work(0);
    } else {
        std::vector<std::thread> pool;
        for (unsigned t = 0; t < threads; ++t) {
            pool.emplace_back(work, t);
        }
        for (std::thread& th : pool) {
            th.join();
        }
    }
    if (report != nullptr) {
        *report = {};
        for (const TabulateReport& r : partial) {
            report->bins += r.bins;
            report->valid_bins += r.valid_bins;
            report->below_horizon += r.below_horizon;
            report->non_finite += r.non_finite;
            report->out_of_range += r.out_of_range;
        }
    }
    return table;
}

Dataset table_to_dataset(const TabulatedBrdf& table) {
    Dataset data;
    data.source = table.source();
    const TableGrid& grid = table.grid();
    for (std::size_t flat = 0; flat < grid.size(); ++flat) {
        if (!table.bin_valid(flat)) {
            continue;
        }
        const std::array<int, 3> b = grid.unflatten(flat);
        const auto [wi, wo] = grid.centre_directions(b[0], b[1], b[2]);
        if (!(wi.z() > 0) || !(wo.z() > 0)) {
            // A stored value for a pair below the horizon is not a reflection sample.
            continue;
        }
        const Spherical<double> si = cartesian_to_spherical(wi);
        const Spherical<double> so = cartesian_to_spherical(wo);
        Sample s;
        s.theta_i = si.theta;
        s.phi_i = si.phi;
        s.theta_o = so.theta;
        s.phi_o = so.phi;
        s.value = table.bin_value(flat);
        if (!validate_sample(s).empty()) {
            // Only a centre within rounding of the horizon can fail (theta = pi/2): skip it.
            continue;
        }
        data.samples.push_back(s);
    }
    return data;
}

Expected<TabulatedBrdf> resample_dataset(const Dataset& data,
                                         const ResampleOptions& options,
                                         ResampleReport* report) {
    const double r = options.radius_bins;
    if (!(r > 0 && r <= 16)) {
        return make_error("resample: radius = " + std::to_string(r) + " bins, must be in (0, 16]");
    }
    if (data.samples.empty()) {
        return make_error(data.source + ": no valid samples to resample");
    }
    const TableGrid& grid = options.grid;
    const std::size_t n = grid.size();
    // sum and weight here, raw values and validity flags in the table.
    if (auto ok = check_memory(static_cast<double>(n) * (4 * 8 + 3 * 8 + 1),
                               "resampling onto a " + std::to_string(grid.n_theta_h) + "x" +
                                   std::to_string(grid.n_theta_d) + "x" +
                                   std::to_string(grid.n_phi_d) + " table");
        !ok) {
        return tl::unexpected(ok.error());
    }
    for (std::size_t k = 0; k < data.samples.size(); ++k) {
        const Rgbd& v = data.samples[k].value;
        if ((v.abs() > kMaxTableValue).any()) {
            return make_error(data.source + ": sample " + std::to_string(k + 1) + ": value " +
                              show_number(v.abs().maxCoeff()) +
                              " 1/sr is above the largest value a table stores (" +
                              show_number(kMaxTableValue) + " 1/sr)");
        }
    }
    std::vector<double> sum(3 * n, 0.0);
    std::vector<double> weight(n, 0.0);
    const double r2 = r * r;
    const int np = grid.n_phi_d;
    ResampleReport rep;
    for (const Sample& s : data.samples) {
        const Vec3d wi = s.wi();
        const Vec3d wo = s.wo();
        if (!(wi.z() > 0) || !(wo.z() > 0) || !s.value.isFinite().all()) {
            // read_dataset_csv already rejects these; a hand-made dataset might not.
            continue;
        }
        ++rep.samples_used;
        const HalfDiff<double> hd = to_half_diff(wi, wo);
        const std::array<double, 3> u = grid.continuous_index(hd.theta_h, hd.theta_d, hd.phi_d);
        const int h0 = std::max(0, static_cast<int>(std::ceil(u[0] - r)));
        const int h1 = std::min(grid.n_theta_h - 1, static_cast<int>(std::floor(u[0] + r)));
        const int d0 = std::max(0, static_cast<int>(std::ceil(u[1] - r)));
        const int d1 = std::min(grid.n_theta_d - 1, static_cast<int>(std::floor(u[1] + r)));
        // phi_d is periodic: visit each bin once, at its nearest periodic image.
        int p0 = static_cast<int>(std::ceil(u[2] - r));
        int p1 = static_cast<int>(std::floor(u[2] + r));
        if (p1 - p0 + 1 >= np) {
            p0 = 0;
            p1 = np - 1;
        }
        for (int ih = h0; ih <= h1; ++ih) {
            const double dh = u[0] - ih;
            for (int id = d0; id <= d1; ++id) {
                const double dd = u[1] - id;
                for (int k = p0; k <= p1; ++k) {
                    const int ip = ((k % np) + np) % np;
                    double dp = u[2] - ip;
                    dp -= np * std::round(dp / np);
                    const double dist2 = dh * dh + dd * dd + dp * dp;
                    if (dist2 >= r2) {
                        continue;
                    }
                    const double q = 1 - dist2 / r2;
                    const double w = q * q;
                    const std::size_t flat = grid.index(ih, id, ip);
                    weight[flat] += w;
                    for (int c = 0; c < 3; ++c) {
                        sum[c * n + flat] += w * s.value[c];
                    }
                }
            }
        }
    }
    TabulatedBrdf table = TabulatedBrdf::empty(grid, options.scale, data.source);
    rep.bins = n;
    for (std::size_t flat = 0; flat < n; ++flat) {
        const std::array<int, 3> b = grid.unflatten(flat);
        const auto [wi, wo] = grid.centre_directions(b[0], b[1], b[2]);
        if (!(wi.z() > 0) || !(wo.z() > 0)) {
            // Not a reflection configuration: stays invalid whatever the samples near it.
            ++rep.below_horizon;
            continue;
        }
        if (!(weight[flat] > 0)) {
            // No sample within the radius: no data, left invalid and counted.
            ++rep.empty_bins;
            continue;
        }
        const Rgbd v(sum[flat] / weight[flat],
                     sum[n + flat] / weight[flat],
                     sum[2 * n + flat] / weight[flat]);
        table.set_bin(flat, v.max(0.0));
        ++rep.filled_bins;
    }
    if (report != nullptr) {
        *report = rep;
    }
    return table;
}

}  // namespace gonio::brdf
