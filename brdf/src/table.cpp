#include "gonio/brdf/table.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "gonio/base/check.h"
#include "gonio/base/huge_pages.h"

namespace gonio::brdf {
namespace {

constexpr double kHalfPi = kPi / 2;

// floor(x) clamped into [0, n - 1]; NaN and negatives give 0.
int clamp_bin(double x, int n) {
    if (!(x > 0)) {
        // x <= 0, or NaN: first bin.
        return 0;
    }
    if (x >= static_cast<double>(n - 1)) {
        return n - 1;
    }
    return static_cast<int>(x);
}

// Half/difference angles (theta_h, theta_d, phi_d) of a pair above the horizon, as to_half_diff()
// in coords.h but with the rotation by -phi_h, -theta_h built from the components of h instead of
// trigonometric calls: cos phi_h = h_x / rho, sin phi_h = h_y / rho, cos theta_h = h_z,
// sin theta_h = rho, rho = |h_xy|.
std::array<double, 3> half_diff_angles(const Vec3d& wi, const Vec3d& wo) {
    Vec3d h = wi + wo;
    const double norm = h.norm();
    if (!(norm > 0)) {
        // wi = -wo cannot happen above the horizon; keep to_half_diff's convention (h = z).
        h = Vec3d(0, 0, 1);
    } else {
        h /= norm;
    }
    const double rho = std::hypot(h.x(), h.y());
    double cp = 1;
    double sp = 0;
    if (rho > 0) {
        cp = h.x() / rho;
        sp = h.y() / rho;
    }
    // R_z(-phi_h) wi, then R_y(-theta_h).
    const double x1 = cp * wi.x() + sp * wi.y();
    const double y1 = -sp * wi.x() + cp * wi.y();
    const double z1 = wi.z();
    const double ct = h.z();
    const double st = rho;
    const Vec3d d(ct * x1 - st * z1, y1, st * x1 + ct * z1);
    const double theta_h = std::atan2(rho, h.z());
    const double d_rho = std::hypot(d.x(), d.y());
    const double theta_d = std::atan2(d_rho, d.z());
    // At the pole of d (d = z) the azimuth is 0 by convention, as in cartesian_to_spherical().
    const double phi_d = d_rho > 0 ? std::atan2(d.y(), d.x()) : 0.0;
    return {theta_h, theta_d, phi_d};
}

std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

/// out[k] = keep[k] != 0 ? max(v[k], 0) / s : -1 for k in [0, m). The table's values go to a
/// buffer far larger than the caches that is not read again by this pass: where the processor has
/// them (SSE2), streaming stores write each line without reading it first, half the memory traffic
/// of plain stores. (SSE2 intrinsics: xsimd 8.1 has no streaming store.) max(v, 0) maps -0 to +0,
/// the same number.
void store_selected(const double* v, const double* keep, std::size_t m, double s, double* out) {
    std::size_t k = 0;
#if defined(__SSE2__)
    if ((reinterpret_cast<std::uintptr_t>(out) & 15) != 0 && m > 0) {
        // One value to the 16-byte boundary the streaming stores need.
        out[0] = keep[0] != 0 ? std::max(v[0], 0.0) / s : -1.0;
        k = 1;
    }
    const __m128d zero = _mm_setzero_pd();
    const __m128d minus_one = _mm_set1_pd(-1.0);
    const __m128d scale = _mm_set1_pd(s);
    for (; k + 2 <= m; k += 2) {
        const __m128d q = _mm_div_pd(_mm_max_pd(_mm_loadu_pd(v + k), zero), scale);
        const __m128d kept = _mm_cmpneq_pd(_mm_loadu_pd(keep + k), zero);
        _mm_stream_pd(out + k, _mm_or_pd(_mm_and_pd(kept, q), _mm_andnot_pd(kept, minus_one)));
    }
#endif
    for (; k < m; ++k) {
        out[k] = keep[k] != 0 ? std::max(v[k], 0.0) / s : -1.0;
    }
}

/// Orders the streaming stores of store_selected before the stores that follow.
void store_fence() {
#if defined(__SSE2__)
    _mm_sfence();
#endif
}

}  // namespace

double fold_phi_d(double phi_d) {
    if (phi_d < 0) {
        // Reciprocity: (theta_d, phi_d) and (theta_d, phi_d + pi) are the same pair with wi and wo
        // swapped.
        phi_d += kPi;
    }
    return phi_d;
}

int TableGrid::theta_h_index(double theta_h) const {
    if (!(theta_h > 0)) {
        // theta_h = 0 (the mirror direction) and rounding noise below it: first bin. Also NaN.
        return 0;
    }
    return clamp_bin(std::sqrt(theta_h / kHalfPi) * n_theta_h, n_theta_h);
}

int TableGrid::theta_d_index(double theta_d) const {
    return clamp_bin(theta_d / kHalfPi * n_theta_d, n_theta_d);
}

int TableGrid::phi_d_index(double phi_d) const {
    return clamp_bin(fold_phi_d(phi_d) / kPi * n_phi_d, n_phi_d);
}

double TableGrid::theta_h_centre(int i_h) const {
    const double u = (i_h + 0.5) / n_theta_h;
    return u * u * kHalfPi;
}

double TableGrid::theta_d_centre(int i_d) const {
    return (i_d + 0.5) / n_theta_d * kHalfPi;
}

double TableGrid::phi_d_centre(int i_p) const {
    return (i_p + 0.5) / n_phi_d * kPi;
}

std::array<double, 3> TableGrid::continuous_index(double theta_h,
                                                  double theta_d,
                                                  double phi_d) const {
    // theta_h below 0 only from rounding noise: treat as 0 so sqrt stays defined.
    const double th = theta_h > 0 ? theta_h : 0.0;
    return {std::sqrt(th / kHalfPi) * n_theta_h - 0.5,
            theta_d / kHalfPi * n_theta_d - 0.5,
            fold_phi_d(phi_d) / kPi * n_phi_d - 0.5};
}

std::pair<Vec3d, Vec3d> TableGrid::centre_directions(int i_h, int i_d, int i_p) const {
    return from_half_diff(
        HalfDiff<double>{theta_h_centre(i_h), 0.0, theta_d_centre(i_d), phi_d_centre(i_p)});
}

TabulatedBrdf::TabulatedBrdf(TableGrid grid,
                             std::array<double, 3> scale,
                             TableValues raw,
                             std::string source)
    : grid_(grid), scale_(scale), raw_(std::move(raw)), source_(std::move(source)) {
    GONIO_CHECK_MSG(grid_.n_theta_h > 0 && grid_.n_theta_d > 0 && grid_.n_phi_d > 0,
                    "grid " << grid_.n_theta_h << "x" << grid_.n_theta_d << "x" << grid_.n_phi_d);
    const std::size_t n = grid_.size();
    GONIO_CHECK_MSG(raw_.size() == 3 * n, "raw has " << raw_.size() << " entries, grid " << 3 * n);
    for (double s : scale_) {
        GONIO_CHECK_MSG(std::isfinite(s) && s > 0, "scale " << s);
    }
    valid_.assign(n, 1);
    for (int c = 0; c < 3; ++c) {
        const double* block = raw_.data() + c * n;
        for (std::size_t k = 0; k < n; ++k) {
            GONIO_CHECK_MSG(std::isfinite(block[k]), "raw[" << c * n + k << "] = " << block[k]);
            if (block[k] < 0) {
                valid_[k] = 0;
            }
        }
    }
}

TabulatedBrdf TabulatedBrdf::empty(TableGrid grid,
                                   std::array<double, 3> scale,
                                   std::string source) {
    return TabulatedBrdf(grid, scale, std::move(source), Storage::kNotMeasured);
}

TabulatedBrdf TabulatedBrdf::unwritten(TableGrid grid,
                                       std::array<double, 3> scale,
                                       std::string source) {
    return TabulatedBrdf(grid, scale, std::move(source), Storage::kUnwritten);
}

TabulatedBrdf::TabulatedBrdf(TableGrid grid,
                             std::array<double, 3> scale,
                             std::string source,
                             Storage storage)
    : grid_(grid), scale_(scale), source_(std::move(source)) {
    GONIO_CHECK_MSG(grid_.n_theta_h > 0 && grid_.n_theta_d > 0 && grid_.n_phi_d > 0,
                    "grid " << grid_.n_theta_h << "x" << grid_.n_theta_d << "x" << grid_.n_phi_d);
    for (double s : scale_) {
        GONIO_CHECK_MSG(std::isfinite(s) && s > 0, "scale " << s);
    }
    if (storage == Storage::kNotMeasured) {
        // Every bin invalid (raw -1) without the check of the public constructor: nothing to check.
        resize_huge(raw_, 3 * grid_.size(), -1.0);
        resize_huge(valid_, grid_.size(), std::uint8_t{0});
    } else {
        // Written by the caller, bin by bin: the pages are first touched there (by the thread that
        // writes them).
        resize_huge_unwritten(raw_, 3 * grid_.size());
        resize_huge_unwritten(valid_, grid_.size());
    }
}

Rgbd TabulatedBrdf::bin_value(std::size_t flat) const {
    const std::size_t n = grid_.size();
    return Rgbd(raw_[flat] * scale_[0], raw_[n + flat] * scale_[1], raw_[2 * n + flat] * scale_[2]);
}

void TabulatedBrdf::set_bin(std::size_t flat, const Rgbd& value) {
    GONIO_CHECK(flat < valid_.size());
    GONIO_CHECK_MSG(value.isFinite().all() && (value >= 0).all(), "value " << value.transpose());
    const std::size_t n = grid_.size();
    for (int c = 0; c < 3; ++c) {
        raw_[c * n + flat] = value[c] / scale_[c];
        GONIO_CHECK_MSG(std::isfinite(raw_[c * n + flat]),
                        "value " << value[c] << " / scale " << scale_[c] << " overflows");
    }
    valid_[flat] = 1;
}

void TabulatedBrdf::set_bin_invalid(std::size_t flat) {
    GONIO_CHECK(flat < valid_.size());
    const std::size_t n = grid_.size();
    for (int c = 0; c < 3; ++c) {
        raw_[c * n + flat] = -1.0;
    }
    valid_[flat] = 0;
}

LineStoreCounts TabulatedBrdf::set_line(std::size_t first,
                                        std::size_t count,
                                        const double* const value[3],
                                        const std::uint8_t* reflects) {
    const std::size_t n = grid_.size();
    GONIO_CHECK(first <= n && count <= n - first);
    LineStoreCounts c;
    // The largest value of each channel that is stored: kMaxTableValue, or less where value /
    // scale would overflow a tiny scale (set_bin refuses those).
    double limit[3];
    for (int ch = 0; ch < 3; ++ch) {
        limit[ch] = std::min(kMaxTableValue,
                             scale_[ch] * (std::numeric_limits<double>::max() * (1 - 0x1p-50)));
    }
    // Which bins are stored, a chunk at a time (kept in the first cache level), branch-free: each
    // case is a flag. x - x is 0 exactly when x is finite.
    constexpr std::size_t kChunk = 256;
    alignas(16) double keep[kChunk];
    for (std::size_t begin = 0; begin < count; begin += kChunk) {
        const std::size_t m = std::min(kChunk, count - begin);
        const double* const r = value[0] + begin;
        const double* const g = value[1] + begin;
        const double* const b = value[2] + begin;
        const std::uint8_t* const reflect = reflects + begin;
        std::uint8_t* const valid = valid_.data() + first + begin;
        std::size_t no_reflection = 0;
        std::size_t non_finite = 0;
        std::size_t out_of_range = 0;
        for (std::size_t k = 0; k < m; ++k) {
            const bool reflection = reflect[k] != 0;
            const bool finite = (r[k] - r[k] == 0) & (g[k] - g[k] == 0) & (b[k] - b[k] == 0);
            const bool small = (r[k] <= limit[0]) & (g[k] <= limit[1]) & (b[k] <= limit[2]);
            const bool kept = reflection & finite & small;
            // Not a reflection configuration: no BRDF value. A value that is not finite breaks
            // the Brdf contract, one above the limit is not storable: both are left not measured
            // and counted, the caller reports them.
            no_reflection += static_cast<std::size_t>(!reflection);
            non_finite += static_cast<std::size_t>(reflection & !finite);
            out_of_range += static_cast<std::size_t>(reflection & finite & !small);
            keep[k] = kept ? 1.0 : 0.0;
            valid[k] = static_cast<std::uint8_t>(kept);
        }
        c.no_reflection += no_reflection;
        c.non_finite += non_finite;
        c.out_of_range += out_of_range;
        c.valid += m - no_reflection - non_finite - out_of_range;
        // The stores, channel by channel, as selects: a kept value over the scale, or -1.
        for (int ch = 0; ch < 3; ++ch) {
            store_selected(
                value[ch] + begin, keep, m, scale_[ch], raw_.data() + ch * n + first + begin);
        }
    }
    // The streaming stores are ordered before whatever follows (another thread's reading).
    store_fence();
    return c;
}

TableLookup TabulatedBrdf::lookup_nearest(double theta_h, double theta_d, double phi_d) const {
    const std::size_t flat = grid_.index(
        grid_.theta_h_index(theta_h), grid_.theta_d_index(theta_d), grid_.phi_d_index(phi_d));
    if (!valid_[flat]) {
        // Not measured: no value, flagged.
        return {};
    }
    return {bin_value(flat), true};
}

TableLookup TabulatedBrdf::lookup_trilinear(double theta_h, double theta_d, double phi_d) const {
    const std::array<double, 3> u = grid_.continuous_index(theta_h, theta_d, phi_d);
    const int n[3] = {grid_.n_theta_h, grid_.n_theta_d, grid_.n_phi_d};
    int lo[3];
    int hi[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        double x = u[a];
        if (!std::isfinite(x)) {
            // Only from non-finite angles: use the first bin.
            x = 0;
        }
        if (a < 2) {
            // theta_h, theta_d: constant beyond the first and last centres.
            x = std::min(std::max(x, 0.0), static_cast<double>(n[a] - 1));
            lo[a] = std::min(static_cast<int>(std::floor(x)), n[a] - 1);
            hi[a] = std::min(lo[a] + 1, n[a] - 1);
            t[a] = x - lo[a];
        } else {
            // phi_d: periodic with period pi, so the last centre neighbours the first.
            const double f = std::floor(x);
            t[a] = x - f;
            int i = static_cast<int>(f) % n[a];
            if (i < 0) {
                i += n[a];
            }
            lo[a] = i;
            hi[a] = (i + 1) % n[a];
        }
    }
    Rgbd sum = Rgbd::Zero();
    double weight = 0;
    for (int corner = 0; corner < 8; ++corner) {
        const int ih = (corner & 1) ? hi[0] : lo[0];
        const int id = (corner & 2) ? hi[1] : lo[1];
        const int ip = (corner & 4) ? hi[2] : lo[2];
        const double w = ((corner & 1) ? t[0] : 1 - t[0]) * ((corner & 2) ? t[1] : 1 - t[1]) *
                         ((corner & 4) ? t[2] : 1 - t[2]);
        const std::size_t flat = grid_.index(ih, id, ip);
        if (w > 0 && valid_[flat]) {
            sum += w * bin_value(flat);
            weight += w;
        }
    }
    if (weight <= 0) {
        // No valid corner with a positive weight: no value, flagged.
        return {};
    }
    return {sum / weight, true};
}

TableLookup TabulatedBrdf::lookup_half_diff(double theta_h, double theta_d, double phi_d) const {
    return interpolation_ == Interpolation::kNearest ? lookup_nearest(theta_h, theta_d, phi_d)
                                                     : lookup_trilinear(theta_h, theta_d, phi_d);
}

TableLookup TabulatedBrdf::lookup(const Vec3d& wi, const Vec3d& wo) const {
    if (!(wi.z() > 0) || !(wo.z() > 0)) {
        // At or below the horizon (or NaN): the BRDF is zero there.
        return {};
    }
    const std::array<double, 3> a = half_diff_angles(wi, wo);
    return lookup_half_diff(a[0], a[1], a[2]);
}

Rgbd TabulatedBrdf::eval(const Vec3d& wi, const Vec3d& wo) const {
    return lookup(wi, wo).value;
}

std::string TabulatedBrdf::describe() const {
    return "table " + source_ + " (" + std::to_string(grid_.n_theta_h) + " x " +
           std::to_string(grid_.n_theta_d) + " x " + std::to_string(grid_.n_phi_d) +
           " theta_h x theta_d x phi_d, " +
           (interpolation_ == Interpolation::kNearest ? "nearest" : "trilinear") + ")";
}

TableStatistics TabulatedBrdf::compute_statistics() const {
    TableStatistics s;
    s.bins = grid_.size();
    s.min = Rgbd::Constant(std::numeric_limits<double>::infinity());
    s.max = Rgbd::Zero();
    for (std::size_t k = 0; k < s.bins; ++k) {
        if (!valid_[k]) {
            continue;
        }
        const Rgbd v = bin_value(k);
        ++s.valid_bins;
        s.min = s.min.min(v);
        s.max = s.max.max(v);
        // Running mean: cannot overflow where a plain sum of huge stored values would.
        s.mean += (v - s.mean) / static_cast<double>(s.valid_bins);
    }
    if (s.valid_bins == 0) {
        // No data at all: report zeros rather than +inf minima.
        s.min = Rgbd::Zero();
    }
    return s;
}

std::string TabulatedBrdf::statistics() const {
    const TableStatistics s = compute_statistics();
    std::string out =
        "valid bins: " + std::to_string(s.valid_bins) + " of " + std::to_string(s.bins) + " (" +
        fmt(100.0 * static_cast<double>(s.valid_bins) / static_cast<double>(s.bins)) + " %)\n";
    const char* names[3] = {"r", "g", "b"};
    for (int c = 0; c < 3; ++c) {
        out += std::string(names[c]) + ": min " + fmt(s.min[c]) + " max " + fmt(s.max[c]) +
               " mean " + fmt(s.mean[c]) + " 1/sr\n";
    }
    return out;
}

}  // namespace gonio::brdf
