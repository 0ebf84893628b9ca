// Piecewise-bilinear densities and their marginal-conditional warps (see warp2d.h).

#include "gonio/brdf/warp2d.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace gonio::brdf {

namespace {

// The root f in [0, 1] of f (a + f (b - a) / 2) = t: the inverse of the integral of a density that
// is linear from a (at 0) to b (at 1). Written as 2 t / (a + sqrt(a^2 + 2 t (b - a))), which has no
// cancellation and also holds for a == b (f = t / a).
double invert_linear(double a, double b, double t) {
    const double disc = std::max(0.0, a * a + 2.0 * t * (b - a));
    const double denom = a + std::sqrt(disc);
    // Degenerate patch: no mass on its left edge and nothing to invert.
    if (!(denom > 0.0)) {
        return 0.0;
    }
    return std::clamp(2.0 * t / denom, 0.0, 1.0);
}

std::size_t clamp_index(double scaled, std::size_t n_patches) {
    if (!(scaled > 0.0)) {
        return 0;
    }
    const auto i = static_cast<std::size_t>(scaled);
    return std::min(i, n_patches - 1);
}

double clamp01(double v) {
    // NaN goes to 0: a direction that could not be converted never indexes outside the tables.
    return v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
}

}  // namespace

ParamWeight param_weight(const std::vector<float>& nodes, double value) {
    ParamWeight w;
    if (nodes.size() < 2) {
        return w;
    }
    // The last node at or below value, kept in [0, n - 2] so that index + 1 exists.
    const auto it = std::upper_bound(nodes.begin(), nodes.end(), value, [](double v, float node) {
        return v < static_cast<double>(node);
    });
    std::size_t k = it == nodes.begin() ? 0 : static_cast<std::size_t>(it - nodes.begin()) - 1;
    k = std::min(k, nodes.size() - 2);
    const double p0 = nodes[k];
    const double p1 = nodes[k + 1];
    w.index = k;
    w.w1 = std::clamp((value - p0) / (p1 - p0), 0.0, 1.0);
    if (std::isnan(w.w1)) {
        w.w1 = 0.0;
    }
    return w;
}

SliceWeights slice_weights(const std::vector<float>& outer_nodes,
                           const std::vector<float>& inner_nodes,
                           double outer,
                           double inner) {
    SliceWeights w;
    const std::size_t n_inner = std::max<std::size_t>(inner_nodes.size(), 1);
    const ParamWeight o = param_weight(outer_nodes, outer);
    const ParamWeight i = param_weight(inner_nodes, inner);
    w.base = o.index * n_inner + i.index;
    w.inner_step = inner_nodes.size() >= 2 ? 1 : 0;
    w.outer_step = outer_nodes.size() >= 2 ? n_inner : 0;
    w.inner_w1 = i.w1;
    w.outer_w1 = o.w1;
    return w;
}

namespace {

// One parameter's node and weights in single precision, as the format's readers compute them.
void weight_f(
    const std::vector<float>& nodes, float value, std::size_t* index, float* w0, float* w1) {
    *index = 0;
    *w1 = 0.0f;
    if (nodes.size() >= 2) {
        *index = param_weight(nodes, value).index;
        const float p0 = nodes[*index], p1 = nodes[*index + 1];
        *w1 = std::min(std::max((value - p0) / (p1 - p0), 0.0f), 1.0f);
        if (std::isnan(*w1)) {
            *w1 = 0.0f;
        }
    }
    *w0 = 1.0f - *w1;
}

}  // namespace

SliceWeightsF slice_weights_f(const std::vector<float>& outer_nodes,
                              const std::vector<float>& inner_nodes,
                              float outer,
                              float inner) {
    SliceWeightsF w;
    const std::size_t n_inner = std::max<std::size_t>(inner_nodes.size(), 1);
    std::size_t oi = 0, ii = 0;
    weight_f(outer_nodes, outer, &oi, &w.outer_w0, &w.outer_w1);
    weight_f(inner_nodes, inner, &ii, &w.inner_w0, &w.inner_w1);
    w.base = oi * n_inner + ii;
    w.inner_step = inner_nodes.size() >= 2 ? 1 : 0;
    w.outer_step = outer_nodes.size() >= 2 ? n_inner : 0;
    return w;
}

namespace {

// A table value between the slices of `w`: linear along the inner parameter at each of the outer
// one's two nodes, then along the outer one (in double the order changes only the rounding).
double lerp_slices(const float* table,
                   std::size_t slice_size,
                   std::size_t index,
                   const SliceWeights& w,
                   std::size_t scale,
                   std::size_t offset) {
    auto inner = [&](std::size_t s) {
        const double v0 = table[(s * scale + offset) * slice_size + index];
        if (w.inner_w1 == 0.0) {
            return v0;
        }
        return (1 - w.inner_w1) * v0 +
               w.inner_w1 * table[((s + w.inner_step) * scale + offset) * slice_size + index];
    };
    const double v0 = inner(w.base);
    if (w.outer_w1 == 0.0) {
        return v0;
    }
    return (1 - w.outer_w1) * v0 + w.outer_w1 * inner(w.base + w.outer_step);
}

// The same in single precision, in the readers' order: along the outer parameter (phi_i) at
// each of the inner parameter's two nodes, then along the inner one. A parameter with one node
// takes no fma (x * 1 + y * 0 would be x anyway for a finite y).
float lerp_slices_f(const float* table,
                    std::size_t slice_size,
                    std::size_t index,
                    const SliceWeightsF& w,
                    std::size_t scale,
                    std::size_t offset) {
    auto outer = [&](std::size_t s) {
        const float v0 = table[(s * scale + offset) * slice_size + index];
        if (w.outer_step == 0) {
            return v0;
        }
        return std::fma(
            v0,
            w.outer_w0,
            table[((s + w.outer_step) * scale + offset) * slice_size + index] * w.outer_w1);
    };
    const float a = outer(w.base);
    if (w.inner_step == 0) {
        return a;
    }
    return std::fma(a, w.inner_w0, outer(w.base + w.inner_step) * w.inner_w1);
}

}  // namespace

BilinearGrid::BilinearGrid(std::size_t nx,
                           std::size_t ny,
                           std::size_t slices,
                           std::vector<float> values)
    : nx_(nx), ny_(ny), slices_(slices), values_(std::move(values)) {}

double BilinearGrid::eval(const Point2& p, std::size_t slice) const {
    return eval(p, slice, 0, 0.0);
}

double BilinearGrid::eval(const Point2& p, std::size_t slice, std::size_t stride, double w1) const {
    const double x = clamp01(p[0]) * static_cast<double>(nx_ - 1);
    const double y = clamp01(p[1]) * static_cast<double>(ny_ - 1);
    const std::size_t i = clamp_index(x, nx_ - 1);
    const std::size_t j = clamp_index(y, ny_ - 1);
    const double fx = x - static_cast<double>(i);
    const double fy = y - static_cast<double>(j);
    auto at = [&](std::size_t s, std::size_t ii, std::size_t jj) -> double {
        return values_[(s * ny_ + jj) * nx_ + ii];
    };
    auto bilinear = [&](std::size_t s) {
        return (1 - fy) * ((1 - fx) * at(s, i, j) + fx * at(s, i + 1, j)) +
               fy * ((1 - fx) * at(s, i, j + 1) + fx * at(s, i + 1, j + 1));
    };
    const double v0 = bilinear(slice);
    if (w1 == 0.0) {
        return v0;
    }
    return (1 - w1) * v0 + w1 * bilinear(slice + stride);
}

double BilinearGrid::eval(const Point2& p,
                          const SliceWeights& w,
                          std::size_t scale,
                          std::size_t offset) const {
    const double x = clamp01(p[0]) * static_cast<double>(nx_ - 1);
    const double y = clamp01(p[1]) * static_cast<double>(ny_ - 1);
    const std::size_t i = clamp_index(x, nx_ - 1);
    const std::size_t j = clamp_index(y, ny_ - 1);
    const double fx = x - static_cast<double>(i);
    const double fy = y - static_cast<double>(j);
    const std::size_t n = nx_ * ny_;
    auto at = [&](std::size_t ii, std::size_t jj) {
        return lerp_slices(values_.data(), n, jj * nx_ + ii, w, scale, offset);
    };
    return (1 - fy) * ((1 - fx) * at(i, j) + fx * at(i + 1, j)) +
           fy * ((1 - fx) * at(i, j + 1) + fx * at(i + 1, j + 1));
}

float BilinearGrid::eval_f(
    float x, float y, const SliceWeightsF& w, std::size_t scale, std::size_t offset) const {
    // NaN goes to 0 (clamp01's rule): a lookup never leaves the table.
    x = (x > 0.0f ? std::min(x, 1.0f) : 0.0f) * static_cast<float>(nx_ - 1);
    y = (y > 0.0f ? std::min(y, 1.0f) : 0.0f) * static_cast<float>(ny_ - 1);
    const std::size_t i = std::min(static_cast<std::size_t>(x), nx_ - 2);
    const std::size_t j = std::min(static_cast<std::size_t>(y), ny_ - 2);
    const float x1 = x - static_cast<float>(i), y1 = y - static_cast<float>(j);
    const float x0 = 1.0f - x1, y0 = 1.0f - y1;
    const std::size_t n = nx_ * ny_;
    auto at = [&](std::size_t ii, std::size_t jj) {
        return lerp_slices_f(values_.data(), n, jj * nx_ + ii, w, scale, offset);
    };
    return std::fma(y0,
                    std::fma(x0, at(i, j), x1 * at(i + 1, j)),
                    y1 * std::fma(x0, at(i, j + 1), x1 * at(i + 1, j + 1)));
}

Expected<Warp2D> Warp2D::build(std::size_t nx,
                               std::size_t ny,
                               const std::vector<float>& values,
                               std::vector<float> params,
                               const std::string& label) {
    return build(nx, ny, values, {0.0f}, std::move(params), label);
}

Expected<Warp2D> Warp2D::build(std::size_t nx,
                               std::size_t ny,
                               const std::vector<float>& values,
                               std::vector<float> outer_params,
                               std::vector<float> params,
                               const std::string& label) {
    if (nx < 2 || ny < 2) {
        return make_error(label + ": a " + std::to_string(ny) + " x " + std::to_string(nx) +
                          " grid (a warp needs at least 2 x 2 nodes)");
    }
    if (params.empty()) {
        params.push_back(0.0f);
    }
    if (outer_params.empty()) {
        outer_params.push_back(0.0f);
    }
    const std::size_t slices = outer_params.size() * params.size();
    const std::size_t n = nx * ny;
    if (values.size() != slices * n) {
        return make_error(label + ": " + std::to_string(values.size()) + " values, expected " +
                          std::to_string(slices) + " x " + std::to_string(ny) + " x " +
                          std::to_string(nx));
    }
    for (const std::vector<float>* nodes : {&outer_params, &params}) {
        for (std::size_t k = 0; k < nodes->size(); ++k) {
            const float v = (*nodes)[k];
            if (!std::isfinite(v) || (k > 0 && !(v > (*nodes)[k - 1]))) {
                return make_error(label +
                                  ": parameter nodes must be finite and strictly increasing "
                                  "(node " +
                                  std::to_string(k) + " is " + std::to_string(v) + ")");
            }
        }
    }
    Warp2D w;
    w.nx_ = nx;
    w.ny_ = ny;
    w.outer_params_ = std::move(outer_params);
    w.params_ = std::move(params);
    w.density_.resize(slices * n);
    w.conditional_.resize(slices * n);
    w.marginal_.resize(slices * ny);
    for (std::size_t s = 0; s < slices; ++s) {
        const float* v = values.data() + s * n;
        float* cond = w.conditional_.data() + s * n;
        float* marg = w.marginal_.data() + s * ny;
        for (std::size_t k = 0; k < n; ++k) {
            if (!(v[k] >= 0.0f) || !std::isfinite(v[k])) {
                return make_error(label + ": slice " + std::to_string(s) + " node " +
                                  std::to_string(k) + " = " + std::to_string(v[k]) +
                                  " (a density is finite and >= 0)");
            }
        }
        // Integral along x up to each node (trapezoids in patch units), per row.
        for (std::size_t j = 0; j < ny; ++j) {
            double sum = 0.0;
            cond[j * nx] = 0.0f;
            for (std::size_t i = 0; i + 1 < nx; ++i) {
                sum += 0.5 * (static_cast<double>(v[j * nx + i]) + v[j * nx + i + 1]);
                cond[j * nx + i + 1] = static_cast<float>(sum);
            }
        }
        // Integral along y of the row totals up to each row.
        double sum = 0.0;
        marg[0] = 0.0f;
        for (std::size_t j = 0; j + 1 < ny; ++j) {
            sum += 0.5 * (static_cast<double>(cond[j * nx + nx - 1]) + cond[(j + 1) * nx + nx - 1]);
            marg[j + 1] = static_cast<float>(sum);
        }
        // The arithmetic stays in single precision, as in the format's readers; a total below
        // float's normal range would make 1 / total infinite (and 0 x inf NaN), so it is refused.
        const float norm = 1.0f / marg[ny - 1];
        if (!(marg[ny - 1] > 0.0f) || !std::isfinite(marg[ny - 1]) || !std::isfinite(norm)) {
            return make_error(label + ": slice " + std::to_string(s) +
                              " has no mass (every node is zero), too little to normalise, or "
                              "overflows");
        }
        for (std::size_t k = 0; k < n; ++k) {
            cond[k] *= norm;
            w.density_[s * n + k] = v[k] * norm;
        }
        for (std::size_t j = 0; j < ny; ++j) {
            marg[j] *= norm;
        }
    }
    return w;
}

double Warp2D::lerp(const std::vector<float>& table,
                    std::size_t slice_size,
                    std::size_t index,
                    const SliceWeights& w) const {
    return lerp_slices(table.data(), slice_size, index, w, 1, 0);
}

Point2 Warp2D::sample(const Point2& xi_in, double outer, double param) const {
    const SliceWeights w = slice_weights(outer_params_, params_, outer, param);
    const std::size_t n = nx_ * ny_;
    const double xi_y = clamp01(xi_in[1]);
    double xi_x = clamp01(xi_in[0]);
    // Row: the last row boundary whose marginal is below xi_y.
    std::size_t lo = 0, hi = ny_ - 1;  // invariant: marginal(lo) < xi_y or lo == 0
    while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        if (lerp(marginal_, ny_, mid, w) < xi_y) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    const std::size_t r = lo;
    const double r0 = lerp(conditional_, n, r * nx_ + nx_ - 1, w);
    const double r1 = lerp(conditional_, n, (r + 1) * nx_ + nx_ - 1, w);
    const double fy = invert_linear(r0, r1, xi_y - lerp(marginal_, ny_, r, w));
    // Column, in the row at fy.
    xi_x *= (1 - fy) * r0 + fy * r1;
    auto cond_at = [&](std::size_t c) {
        return (1 - fy) * lerp(conditional_, n, r * nx_ + c, w) +
               fy * lerp(conditional_, n, (r + 1) * nx_ + c, w);
    };
    lo = 0;
    hi = nx_ - 1;
    while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        if (cond_at(mid) < xi_x) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    const std::size_t c = lo;
    const double c0 =
        (1 - fy) * lerp(density_, n, r * nx_ + c, w) + fy * lerp(density_, n, (r + 1) * nx_ + c, w);
    const double c1 = (1 - fy) * lerp(density_, n, r * nx_ + c + 1, w) +
                      fy * lerp(density_, n, (r + 1) * nx_ + c + 1, w);
    const double fx = invert_linear(c0, c1, xi_x - cond_at(c));
    return {(static_cast<double>(c) + fx) / static_cast<double>(nx_ - 1),
            (static_cast<double>(r) + fy) / static_cast<double>(ny_ - 1)};
}

Point2 Warp2D::invert(const Point2& p, double outer, double param) const {
    const SliceWeights w = slice_weights(outer_params_, params_, outer, param);
    const std::size_t n = nx_ * ny_;
    const double x = clamp01(p[0]) * static_cast<double>(nx_ - 1);
    const double y = clamp01(p[1]) * static_cast<double>(ny_ - 1);
    const std::size_t c = clamp_index(x, nx_ - 1);
    const std::size_t r = clamp_index(y, ny_ - 1);
    const double fx = x - static_cast<double>(c);
    const double fy = y - static_cast<double>(r);
    const double c0 =
        (1 - fy) * lerp(density_, n, r * nx_ + c, w) + fy * lerp(density_, n, (r + 1) * nx_ + c, w);
    const double c1 = (1 - fy) * lerp(density_, n, r * nx_ + c + 1, w) +
                      fy * lerp(density_, n, (r + 1) * nx_ + c + 1, w);
    const double cond = (1 - fy) * lerp(conditional_, n, r * nx_ + c, w) +
                        fy * lerp(conditional_, n, (r + 1) * nx_ + c, w);
    const double r0 = lerp(conditional_, n, r * nx_ + nx_ - 1, w);
    const double r1 = lerp(conditional_, n, (r + 1) * nx_ + nx_ - 1, w);
    const double row_mass = (1 - fy) * r0 + fy * r1;
    const double xi_x = row_mass > 0.0 ? (cond + fx * (c0 + 0.5 * fx * (c1 - c0))) / row_mass : 0.0;
    const double xi_y = lerp(marginal_, ny_, r, w) + fy * (r0 + 0.5 * fy * (r1 - r0));
    return {xi_x, xi_y};
}

float Warp2D::lerp_f(const std::vector<float>& table,
                     std::size_t slice_size,
                     std::size_t index,
                     const SliceWeightsF& w) const {
    return lerp_slices_f(table.data(), slice_size, index, w, 1, 0);
}

std::array<float, 2> Warp2D::invert_f(float x, float y, float outer, float param) const {
    // The parameter weights in single precision.
    const SliceWeightsF w = slice_weights_f(outer_params_, params_, outer, param);
    const std::size_t n = nx_ * ny_;
    // NaN goes to 0 (clamp01's rule): a lookup never leaves the table.
    x = (x > 0.0f ? std::min(x, 1.0f) : 0.0f) * static_cast<float>(nx_ - 1);
    y = (y > 0.0f ? std::min(y, 1.0f) : 0.0f) * static_cast<float>(ny_ - 1);
    const std::size_t c = std::min(static_cast<std::size_t>(x), nx_ - 2);
    const std::size_t r = std::min(static_cast<std::size_t>(y), ny_ - 2);
    x -= static_cast<float>(c);
    y -= static_cast<float>(r);
    auto at = [&](const std::vector<float>& t, std::size_t i) { return lerp_f(t, n, i, w); };
    const float v00 = at(density_, r * nx_ + c), v10 = at(density_, r * nx_ + c + 1);
    const float v01 = at(density_, (r + 1) * nx_ + c), v11 = at(density_, (r + 1) * nx_ + c + 1);
    // Density along x in the row at y, linear between c0 and c1 inside the patch.
    const float c0 = std::fma(1.0f - y, v00, y * v01);
    const float c1 = std::fma(1.0f - y, v10, y * v11);
    x *= c0 + 0.5f * x * (c1 - c0);
    x += (1.0f - y) * at(conditional_, r * nx_ + c) + y * at(conditional_, (r + 1) * nx_ + c);
    const float r0 = at(conditional_, r * nx_ + nx_ - 1);
    const float r1 = at(conditional_, (r + 1) * nx_ + nx_ - 1);
    // A row without mass has no inverse: x goes to 0, as in invert() (0 / 0 would be NaN).
    const float row_mass = (1.0f - y) * r0 + y * r1;
    x = row_mass > 0.0f ? x / row_mass : 0.0f;
    y *= r0 + 0.5f * y * (r1 - r0);
    y += lerp_f(marginal_, ny_, r, w);
    return {x, y};
}

double Warp2D::pdf(const Point2& p, double outer, double param) const {
    const SliceWeights w = slice_weights(outer_params_, params_, outer, param);
    const std::size_t n = nx_ * ny_;
    const double x = clamp01(p[0]) * static_cast<double>(nx_ - 1);
    const double y = clamp01(p[1]) * static_cast<double>(ny_ - 1);
    const std::size_t c = clamp_index(x, nx_ - 1);
    const std::size_t r = clamp_index(y, ny_ - 1);
    const double fx = x - static_cast<double>(c);
    const double fy = y - static_cast<double>(r);
    auto d = [&](std::size_t cc, std::size_t rr) { return lerp(density_, n, rr * nx_ + cc, w); };
    const double v = (1 - fy) * ((1 - fx) * d(c, r) + fx * d(c + 1, r)) +
                     fy * ((1 - fx) * d(c, r + 1) + fx * d(c + 1, r + 1));
    return v * static_cast<double>(nx_ - 1) * static_cast<double>(ny_ - 1);
}

}  // namespace gonio::brdf
