#include "gonio/brdf/resample.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gonio/base/check.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/limits.h"
#include "gonio/base/thread_pool.h"
#include "gonio/brdf/brdf.h"

namespace gonio::brdf {
namespace {

/// Rows of theta_h per chunk of the pool: a MERL row is 16,200 bins.
constexpr std::size_t kRowGrain = 1;

/// Adds what a line store did to a chunk's report.
void count_line(const LineStoreCounts& c, std::size_t bins, TabulateReport& r) {
    r.bins += bins;
    r.valid_bins += c.valid;
    r.below_horizon += c.no_reflection;
    r.non_finite += c.non_finite;
    r.out_of_range += c.out_of_range;
}

/// Any Brdf, one bin at a time, stored a phi_d line at a time.
void tabulate_rows(const Brdf& brdf,
                   const TableGrid& grid,
                   TabulatedBrdf& table,
                   std::size_t row_begin,
                   std::size_t row_end,
                   TabulateReport& r) {
    const std::size_t np = static_cast<std::size_t>(grid.n_phi_d);
    std::vector<double> buf(3 * np);
    std::vector<std::uint8_t> reflects(np);
    const double* const values[3] = {buf.data(), buf.data() + np, buf.data() + 2 * np};
    for (int ih = static_cast<int>(row_begin); ih < static_cast<int>(row_end); ++ih) {
        for (int id = 0; id < grid.n_theta_d; ++id) {
            for (int ip = 0; ip < grid.n_phi_d; ++ip) {
                const auto [wi, wo] = grid.centre_directions(ih, id, ip);
                const std::size_t k = static_cast<std::size_t>(ip);
                // A pair below the horizon is not a reflection configuration: no BRDF value.
                reflects[k] = (wi.z() > 0) && (wo.z() > 0);
                const Rgbd f = reflects[k] ? brdf.eval(wi, wo) : Rgbd::Zero();
                buf[k] = f[0];
                buf[np + k] = f[1];
                buf[2 * np + k] = f[2];
            }
            count_line(table.set_line(grid.index(ih, id, 0), np, values, reflects.data()), np, r);
        }
    }
}

/// The centre directions of the phi_d bins of the line (theta_h, theta_d), given by their sines and
/// cosines, as structure of arrays wi = (w0, w1, w2), wo = (w3, w4, w5), and whether each pair is a
/// reflection configuration. The arrays do not overlap (restrict: the loop runs on the vector
/// unit).
void line_directions(std::size_t np,
                     double cos_h,
                     double sin_h,
                     double sin_d,
                     double cos_d,
                     const double* __restrict cos_p,
                     const double* __restrict sin_p,
                     double* __restrict w0,
                     double* __restrict w1,
                     double* __restrict w2,
                     double* __restrict w3,
                     double* __restrict w4,
                     double* __restrict w5,
                     std::uint8_t* __restrict reflects) {
    for (std::size_t ip = 0; ip < np; ++ip) {
        // d = (sin theta_d cos phi_d, sin theta_d sin phi_d, cos theta_d); wi = R_y(theta_h) d;
        // h = (sin theta_h, 0, cos theta_h); wo = 2 (wi . h) h - wi.
        const double dx = sin_d * cos_p[ip];
        const double dy = sin_d * sin_p[ip];
        const double dz = cos_d;
        const double ix = cos_h * dx + sin_h * dz;
        const double iz = -sin_h * dx + cos_h * dz;
        const double two_dot = 2 * (ix * sin_h + iz * cos_h);
        w0[ip] = ix;
        w1[ip] = dy;
        w2[ip] = iz;
        w3[ip] = two_dot * sin_h - ix;
        w4[ip] = -dy;
        w5[ip] = two_dot * cos_h - iz;
    }
    for (std::size_t ip = 0; ip < np; ++ip) {
        reflects[ip] = static_cast<std::uint8_t>((w2[ip] > 0) & (w5[ip] > 0));
    }
}

/// A BRDF that evaluates on packets (Brdf::evaluates_packets, an analytic model): the directions of
/// a (theta_h, theta_d) line of phi_d bins as structure of arrays, evaluated together
/// (Brdf::eval_many) over the bins of the line that are reflection configurations, and stored
/// with one set_line(). The centre directions are those of
/// TableGrid::centre_directions (from_half_diff with phi_h = 0), with the sines and cosines of the
/// centre angles computed once per axis.
class PacketRows {
  public:
    PacketRows(const Brdf& brdf, const TableGrid& grid) : brdf_(brdf), grid_(grid) {
        auto sincos = [](int n, auto centre, std::vector<double>& s, std::vector<double>& c) {
            s.resize(n);
            c.resize(n);
            for (int k = 0; k < n; ++k) {
                s[k] = std::sin(centre(k));
                c[k] = std::cos(centre(k));
            }
        };
        sincos(
            grid.n_theta_h, [&](int k) { return grid.theta_h_centre(k); }, sin_h_, cos_h_);
        sincos(
            grid.n_theta_d, [&](int k) { return grid.theta_d_centre(k); }, sin_d_, cos_d_);
        sincos(
            grid.n_phi_d, [&](int k) { return grid.phi_d_centre(k); }, sin_p_, cos_p_);
    }

    void run(TabulatedBrdf& table,
             std::size_t row_begin,
             std::size_t row_end,
             TabulateReport& r) const {
        const std::size_t np = static_cast<std::size_t>(grid_.n_phi_d);
        std::vector<double> buf(9 * np);
        std::vector<std::uint8_t> reflects(np);
        double* w[6];
        for (int k = 0; k < 6; ++k) {
            w[k] = buf.data() + k * np;
        }
        double* const out[3] = {buf.data() + 6 * np, buf.data() + 7 * np, buf.data() + 8 * np};
        for (int ih = static_cast<int>(row_begin); ih < static_cast<int>(row_end); ++ih) {
            const double c = cos_h_[ih];
            const double s = sin_h_[ih];
            for (int id = 0; id < grid_.n_theta_d; ++id) {
                line_directions(np,
                                c,
                                s,
                                sin_d_[id],
                                cos_d_[id],
                                cos_p_.data(),
                                sin_p_.data(),
                                w[0],
                                w[1],
                                w[2],
                                w[3],
                                w[4],
                                w[5],
                                reflects.data());
                // The reflection configurations of a line are one run of phi_d: wi_z grows with
                // phi_d and wo_z = 2 cos theta_d cos theta_h - wi_z falls. Only that run is
                // evaluated; the flags decide what is stored, so a rounding at the run's ends
                // cannot store a value of a pair below the horizon.
                std::size_t lo = 0;
                std::size_t hi = np;
                while (lo < hi && reflects[lo] == 0) {
                    ++lo;
                }
                while (hi > lo && reflects[hi - 1] == 0) {
                    --hi;
                }
                if (hi > lo) {
                    const DirectionPairs dirs{
                        w[0] + lo, w[1] + lo, w[2] + lo, w[3] + lo, w[4] + lo, w[5] + lo};
                    double* const part[3] = {out[0] + lo, out[1] + lo, out[2] + lo};
                    brdf_.eval_many(hi - lo, dirs, part);
                }
                count_line(table.set_line(grid_.index(ih, id, 0), np, out, reflects.data()), np, r);
            }
        }
    }

  private:
    const Brdf& brdf_;
    const TableGrid& grid_;
    std::vector<double> sin_h_, cos_h_, sin_d_, cos_d_, sin_p_, cos_p_;
};

}  // namespace

TabulatedBrdf tabulate(const Brdf& brdf, const TabulateOptions& options, TabulateReport* report) {
    const TableGrid& grid = options.grid;
    // Every bin is written once by the rows below (a value or "not measured").
    TabulatedBrdf table = TabulatedBrdf::unwritten(grid, options.scale, brdf.describe());
    const std::size_t rows = static_cast<std::size_t>(grid.n_theta_h);
    const Chunking chunks = chunking(rows, kRowGrain);
    // One report per chunk, added in chunk order: the counts do not depend on the thread count.
    std::vector<TabulateReport> partial(chunks.count);
    if (brdf.evaluates_packets()) {
        const PacketRows packet_rows(brdf, grid);
        parallel_for(rows,
                     kRowGrain,
                     static_cast<int>(options.threads),
                     [&](std::size_t chunk, std::size_t b, std::size_t e) {
                         packet_rows.run(table, b, e, partial[chunk]);
                     });
    } else {
        parallel_for(rows,
                     kRowGrain,
                     static_cast<int>(options.threads),
                     [&](std::size_t chunk, std::size_t b, std::size_t e) {
                         tabulate_rows(brdf, grid, table, b, e, partial[chunk]);
                     });
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
    // At most one sample per bin: one allocation, advised for huge pages.
    reserve_huge(data.samples, grid.size());
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

namespace {

/// What resample_dataset refuses before any work: the radius, no samples, a
/// table beyond the memory budget, a value above what a table stores.
Expected<void> check_resample_input(const Dataset& data, const ResampleOptions& options) {
    const double r = options.radius_bins;
    if (!(r > 0 && r <= 16)) {
        return make_error("resample: radius = " + std::to_string(r) + " bins, must be in (0, 16]");
    }
    if (data.samples.empty()) {
        return make_error(data.source + ": no valid samples to resample");
    }
    const TableGrid& grid = options.grid;
    // sum and weight here, raw values and validity flags in the table.
    if (auto ok = check_memory(static_cast<double>(grid.size()) * (4 * 8 + 3 * 8 + 1),
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
    return {};
}

/// Where each sample falls on the grid: its continuous index coordinates u, the
/// first theta_h row its kernel reaches (-1 for a sample that is not used), and
/// the used samples ordered by that row (stable: file order within a row), so
/// that the samples reaching a band of rows are one contiguous run.
struct SamplePlaces {
    std::vector<std::array<double, 3>> u;
    std::vector<int> first_row;
    std::vector<std::size_t> order;
};

/// Pass 1, over the samples.
SamplePlaces place_samples(const Dataset& data, const TableGrid& grid, double r) {
    const std::size_t ns = data.samples.size();
    SamplePlaces p;
    p.u.resize(ns);
    p.first_row.assign(ns, -1);
    parallel_for(ns, 4096, 0, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) {
            const Sample& s = data.samples[k];
            const Vec3d wi = s.wi();
            const Vec3d wo = s.wo();
            if (!(wi.z() > 0) || !(wo.z() > 0) || !s.value.isFinite().all()) {
                // read_dataset_csv already rejects these; a hand-made dataset might
                // not.
                continue;
            }
            const HalfDiff<double> hd = to_half_diff(wi, wo);
            p.u[k] = grid.continuous_index(hd.theta_h, hd.theta_d, hd.phi_d);
            p.first_row[k] = std::max(0, static_cast<int>(std::ceil(p.u[k][0] - r)));
        }
    });
    p.order.reserve(ns);
    for (std::size_t k = 0; k < ns; ++k) {
        if (p.first_row[k] >= 0) {
            p.order.push_back(k);
        }
    }
    std::stable_sort(p.order.begin(), p.order.end(), [&](std::size_t a, std::size_t b) {
        return p.first_row[a] < p.first_row[b];
    });
    return p;
}

/// The weighted sums of the bins: value sums per channel (c * n + flat) and
/// kernel weights.
struct BinSums {
    std::vector<double> sum;
    std::vector<double> weight;
};

/// Adds one sample's kernel (weight (1 - d^2 / r^2)^2 within radius r, d in
/// bins) to the bins of theta_h rows [row_b, row_e).
void add_kernel(const Sample& s,
                const std::array<double, 3>& uk,
                const TableGrid& grid,
                double r,
                int row_b,
                int row_e,
                BinSums& bins) {
    const std::size_t n = grid.size();
    const double r2 = r * r;
    const int np = grid.n_phi_d;
    const int h0 = std::max(row_b, static_cast<int>(std::ceil(uk[0] - r)));
    const int h1 =
        std::min({grid.n_theta_h - 1, row_e - 1, static_cast<int>(std::floor(uk[0] + r))});
    const int d0 = std::max(0, static_cast<int>(std::ceil(uk[1] - r)));
    const int d1 = std::min(grid.n_theta_d - 1, static_cast<int>(std::floor(uk[1] + r)));
    // phi_d is periodic: visit each bin once, at its nearest periodic image.
    int p0 = static_cast<int>(std::ceil(uk[2] - r));
    int p1 = static_cast<int>(std::floor(uk[2] + r));
    if (p1 - p0 + 1 >= np) {
        p0 = 0;
        p1 = np - 1;
    }
    for (int ih = h0; ih <= h1; ++ih) {
        const double dh = uk[0] - ih;
        for (int id = d0; id <= d1; ++id) {
            const double dd = uk[1] - id;
            for (int k = p0; k <= p1; ++k) {
                const int ip = ((k % np) + np) % np;
                double dp = uk[2] - ip;
                dp -= np * std::round(dp / np);
                const double dist2 = dh * dh + dd * dd + dp * dp;
                if (dist2 >= r2) {
                    continue;
                }
                const double q = 1 - dist2 / r2;
                const double w = q * q;
                const std::size_t flat = grid.index(ih, id, ip);
                bins.weight[flat] += w;
                for (int c = 0; c < 3; ++c) {
                    bins.sum[c * n + flat] += w * s.value[c];
                }
            }
        }
    }
}

/// Pass 2, over bands of theta_h rows: each band gathers the samples whose
/// kernel reaches it and adds them to its own bins only, in the order of the
/// places, so that every bin's sum is the same for any number of threads.
BinSums sum_kernels(const Dataset& data, const TableGrid& grid, double r, const SamplePlaces& p) {
    BinSums bins{std::vector<double>(3 * grid.size(), 0.0), std::vector<double>(grid.size(), 0.0)};
    const int reach = static_cast<int>(std::ceil(2 * r)) + 1;
    const auto& order = p.order;
    const auto& first_row = p.first_row;
    parallel_for(static_cast<std::size_t>(grid.n_theta_h),
                 1,
                 0,
                 [&](std::size_t, std::size_t rb, std::size_t re) {
                     const int row_b = static_cast<int>(rb);
                     const int row_e = static_cast<int>(re);
                     // Samples starting at rows in [row_b - reach, row_e) can reach [row_b,
                     // row_e).
                     const auto before = [&](std::size_t k, int row) { return first_row[k] < row; };
                     const auto lo =
                         std::lower_bound(order.begin(), order.end(), row_b - reach, before);
                     const auto hi = std::lower_bound(lo, order.end(), row_e, before);
                     for (auto it = lo; it != hi; ++it) {
                         add_kernel(data.samples[*it], p.u[*it], grid, r, row_b, row_e, bins);
                     }
                 });
    return bins;
}

/// Pass 3, over the bins: the weighted means into a table, counts per chunk
/// added in chunk order.
TabulatedBrdf weighted_means(const BinSums& bins,
                             const ResampleOptions& options,
                             const std::string& source,
                             ResampleReport& rep) {
    const TableGrid& grid = options.grid;
    const std::size_t n = grid.size();
    TabulatedBrdf table = TabulatedBrdf::empty(grid, options.scale, source);
    rep.bins = n;
    const Chunking bin_chunks = chunking(n, 16384);
    std::vector<ResampleReport> partial(bin_chunks.count);
    parallel_for(n, 16384, 0, [&](std::size_t chunk, std::size_t b, std::size_t e) {
        ResampleReport& pr = partial[chunk];
        for (std::size_t flat = b; flat < e; ++flat) {
            const std::array<int, 3> bin = grid.unflatten(flat);
            const auto [wi, wo] = grid.centre_directions(bin[0], bin[1], bin[2]);
            if (!(wi.z() > 0) || !(wo.z() > 0)) {
                // Not a reflection configuration: stays invalid whatever the
                // samples near it.
                ++pr.below_horizon;
                continue;
            }
            const double w = bins.weight[flat];
            if (!(w > 0)) {
                // No sample within the radius: no data, left invalid and counted.
                ++pr.empty_bins;
                continue;
            }
            const Rgbd v(bins.sum[flat] / w, bins.sum[n + flat] / w, bins.sum[2 * n + flat] / w);
            table.set_bin(flat, v.max(0.0));
            ++pr.filled_bins;
        }
    });
    for (const ResampleReport& pr : partial) {
        rep.below_horizon += pr.below_horizon;
        rep.empty_bins += pr.empty_bins;
        rep.filled_bins += pr.filled_bins;
    }
    return table;
}

}  // namespace

Expected<TabulatedBrdf> resample_dataset(const Dataset& data,
                                         const ResampleOptions& options,
                                         ResampleReport* report) {
    if (auto ok = check_resample_input(data, options); !ok) {
        return tl::unexpected(ok.error());
    }
    const SamplePlaces places = place_samples(data, options.grid, options.radius_bins);
    ResampleReport rep;
    rep.samples_used = places.order.size();
    const BinSums bins = sum_kernels(data, options.grid, options.radius_bins, places);
    TabulatedBrdf table = weighted_means(bins, options, data.source, rep);
    if (report != nullptr) {
        *report = rep;
    }
    return table;
}

}  // namespace gonio::brdf
