// Writing RGL material files: the NDF by power iteration, the parameterisation, the values at the
// warped nodes (see rgl_bsdf.h).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/tabulated_ndf.h"
#include "gonio/brdf/tensor_file.h"
#include "gonio/brdf/warp2d.h"

namespace gonio::brdf {

namespace {

double luminance(const Rgbd& c) {
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

Expected<void> check_options(const RglWriteOptions& o) {
    if (o.theta_i_count < 2 || o.theta_i_count > 256) {
        return make_error("RGL file: " + std::to_string(o.theta_i_count) +
                          " theta_i nodes (2 to 256)");
    }
    if (o.ndf_resolution < 2 || o.ndf_resolution > 1024 || o.rgb_resolution < 2 ||
        o.rgb_resolution > 1024) {
        return make_error("RGL file: grid resolutions " + std::to_string(o.ndf_resolution) +
                          " (ndf) and " + std::to_string(o.rgb_resolution) +
                          " (rgb) must be within 2 to 1024");
    }
    if (o.power_iterations < 1 || !(o.ndf_floor >= 0.0 && o.ndf_floor < 1.0)) {
        return make_error("RGL file: power iterations >= 1 and an NDF floor in [0, 1) required");
    }
    if (!(o.max_theta_i > 0.0 && o.max_theta_i < kPi / 2)) {
        return make_error("RGL file: the largest evaluated theta_i must lie in (0, 90) deg");
    }
    if (o.phi_i_count > 360) {
        return make_error("RGL file: " + std::to_string(o.phi_i_count) +
                          " phi_i azimuths (0 for automatic, 1 for an isotropic file, 2 to 360)");
    }
    if (o.phi_i_count >= 2 && o.ndf_resolution > 128) {
        return make_error("RGL file: an anisotropic file's NDF grid is at most 128 x 128 nodes (" +
                          std::to_string(o.ndf_resolution) + " asked)");
    }
    return {};
}

bool anisotropic(const RglWriteOptions& o) {
    return o.phi_i_count >= 2;
}

Vec3d direction(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// The projected area of a tabulated NDF over the full unit square, sigma(w) = int D(m) <w, m>+ dm,
// at every node of the n x n grid (rows: phi, columns: theta), by the trapezoidal rule on the
// nodes in unit coordinates (dm = 2 pi^2 u_x sin(theta) du; the weight vanishes at the pole).
class SigmaQuadrature2D {
  public:
    explicit SigmaQuadrature2D(std::size_t n) : n_(n) {
        const double h = 1.0 / static_cast<double>(n - 1);
        for (std::size_t row = 0; row < n; ++row) {
            for (std::size_t col = 0; col < n; ++col) {
                const double ux = static_cast<double>(col) * h;
                const double theta = rgl_u_to_theta(ux);
                const Vec3d m = direction(theta, rgl_u_to_phi(static_cast<double>(row) * h));
                const double trapezoid = (col == 0 || col == n - 1 ? 0.5 : 1.0) *
                                         (row == 0 || row == n - 1 ? 0.5 : 1.0) * h * h;
                mx_.push_back(m.x());
                my_.push_back(m.y());
                mz_.push_back(m.z());
                weight_.push_back(trapezoid * 2.0 * kPi * kPi * ux * std::sin(theta));
            }
        }
    }

    std::vector<double> operator()(const std::vector<double>& d) const {
        const std::size_t count = n_ * n_;
        std::vector<double> wd(count);
        for (std::size_t k = 0; k < count; ++k) {
            wd[k] = weight_[k] * d[k];
        }
        std::vector<double> sigma(count);
        for (std::size_t j = 0; j < count; ++j) {
            const double wx = mx_[j], wy = my_[j], wz = mz_[j];
            double sum = 0.0;
            for (std::size_t k = 0; k < count; ++k) {
                const double c = wx * mx_[k] + wy * my_[k] + wz * mz_[k];
                sum += c > 0.0 ? wd[k] * c : 0.0;
            }
            sigma[j] = sum;
        }
        return sigma;
    }

  private:
    std::size_t n_;
    std::vector<double> mx_, my_, mz_, weight_;
};

// The power iteration on an n x n grid (an anisotropic file's NDF); retro as in
// rgl_ndf_from_retro, row-major (phi rows, theta columns).
Expected<RglNdf> power_iteration_2d(const std::vector<double>& retro,
                                    const RglWriteOptions& options) {
    const std::size_t n = options.ndf_resolution;
    const SigmaQuadrature2D sigma_of(n);
    RglNdf out;
    out.rows = n;
    std::vector<double> d(n * n, 1.0);
    auto normalise = [&](std::vector<double>* v) {
        const std::vector<double> s = sigma_of(*v);
        for (double& x : *v) {
            x /= s[0];  // sigma(normal) = int D cos = 1 (node (0, 0) is the normal)
        }
    };
    normalise(&d);
    for (int it = 1; it <= options.power_iterations; ++it) {
        const std::vector<double> s = sigma_of(d);
        std::vector<double> next(n * n);
        for (std::size_t j = 0; j < n * n; ++j) {
            next[j] = retro[j] * s[j];
        }
        normalise(&next);
        double change = 0.0, peak = 0.0;
        for (std::size_t j = 0; j < n * n; ++j) {
            change = std::max(change, std::abs(next[j] - d[j]));
            peak = std::max(peak, next[j]);
        }
        d = std::move(next);
        out.iterations = it;
        out.change = change / peak;
        if (out.change < 1e-6) {
            break;
        }
    }
    const double peak = *std::max_element(d.begin(), d.end());
    for (double& x : d) {
        x = std::max(x, options.ndf_floor * peak);
    }
    normalise(&d);
    out.sigma = sigma_of(d);
    out.d = std::move(d);
    return out;
}

}  // namespace

std::size_t rgl_phi_i_count(const Brdf& brdf, const RglWriteOptions& options) {
    if (options.phi_i_count != 0) {
        return options.phi_i_count;
    }
    return brdf.isotropic() ? 1 : 16;
}

Expected<RglNdf> rgl_ndf_power_iteration(const Brdf& brdf, const RglWriteOptions& options) {
    if (auto ok = check_options(options); !ok) {
        return tl::unexpected(ok.error());
    }
    const std::size_t n = options.ndf_resolution;
    const double h = 1.0 / static_cast<double>(n - 1);
    // Retro-reflection times cos(theta) at the nodes: the kernel's diagonal factor. An isotropic
    // file's NDF is one row (phi = 0), an anisotropic file's n rows over the full turn.
    const std::size_t rows = anisotropic(options) ? n : 1;
    std::vector<double> retro(rows * n, 0.0);
    for (std::size_t r = 0; r < rows; ++r) {
        const double phi = rows == 1 ? 0.0 : rgl_u_to_phi(static_cast<double>(r) * h);
        for (std::size_t j = 0; j < n; ++j) {
            const double theta = rgl_u_to_theta(static_cast<double>(j) * h);
            const Vec3d w = direction(theta, phi);
            if (!(w.z() > 0.0)) {
                continue;  // on the horizon: cos(theta) = 0
            }
            const double f = luminance(brdf.eval(w, w));
            if (!std::isfinite(f)) {
                return make_error(
                    "NDF by power iteration: the BRDF is not finite in retro-reflection "
                    "at theta = " +
                    std::to_string(theta * 180.0 / kPi) +
                    " deg, phi = " + std::to_string(phi * 180.0 / kPi) + " deg");
            }
            retro[r * n + j] = std::max(0.0, f) * w.z();
        }
    }
    return rgl_ndf_from_retro(retro, options);
}

Expected<RglNdf> rgl_ndf_from_retro(const std::vector<double>& retro,
                                    const RglWriteOptions& options) {
    if (auto ok = check_options(options); !ok) {
        return tl::unexpected(ok.error());
    }
    const std::size_t n = options.ndf_resolution;
    const std::size_t count = anisotropic(options) ? n * n : n;
    if (retro.size() != count) {
        return make_error("NDF by power iteration: " + std::to_string(retro.size()) +
                          " retro-reflection values for " + std::to_string(count) + " nodes");
    }
    for (std::size_t j = 0; j < count; ++j) {
        if (!std::isfinite(retro[j]) || retro[j] < 0.0) {
            return make_error("NDF by power iteration: retro-reflection value " +
                              std::to_string(j) + " = " + std::to_string(retro[j]) +
                              " (must be finite and >= 0)");
        }
    }
    if (*std::max_element(retro.begin(), retro.end()) <= 0.0) {
        return make_error(
            "NDF by power iteration: the BRDF reflects nothing back towards the "
            "light at any elevation; no microfacet distribution to extract");
    }
    if (anisotropic(options)) {
        return power_iteration_2d(retro, options);
    }
    // The NDF grid of a file is that of a tabulated NDF (u = sqrt(theta / (pi/2))).
    const std::vector<double> K = tabulated_ndf_sigma_matrix(n);
    RglNdf out;
    std::vector<double> d(n, 1.0);
    auto normalise = [&](std::vector<double>* v) {
        const std::vector<double> s = tabulated_ndf_sigma(K, *v);
        for (double& x : *v) {
            x /= s[0];  // sigma(normal) = int D cos = 1
        }
    };
    normalise(&d);
    for (int it = 1; it <= options.power_iterations; ++it) {
        const std::vector<double> s = tabulated_ndf_sigma(K, d);
        std::vector<double> next(n);
        for (std::size_t j = 0; j < n; ++j) {
            next[j] = retro[j] * s[j];
        }
        normalise(&next);
        double change = 0.0, peak = 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            change = std::max(change, std::abs(next[j] - d[j]));
            peak = std::max(peak, next[j]);
        }
        d = std::move(next);
        out.iterations = it;
        out.change = change / peak;
        if (out.change < 1e-6) {
            break;
        }
    }
    const double peak = *std::max_element(d.begin(), d.end());
    for (double& x : d) {
        x = std::max(x, options.ndf_floor * peak);
    }
    normalise(&d);
    out.sigma = tabulated_ndf_sigma(K, d);
    out.d = std::move(d);
    return out;
}

namespace {

/// The incidence nodes: T elevations over [0, pi/2]; azimuths one node (0) for an isotropic file,
/// P + 1 over [-pi, pi] for an anisotropic one (the last the first a full turn on, as the
/// format's readers interpolate between nodes).
void set_incidence_nodes(const RglWriteOptions& options, RglLayout* L) {
    const std::size_t T = options.theta_i_count;
    for (std::size_t k = 0; k < T; ++k) {
        L->theta_i.push_back(
            static_cast<float>(static_cast<double>(k) / static_cast<double>(T - 1) * kPi / 2));
    }
    if (anisotropic(options)) {
        const std::size_t P = options.phi_i_count;
        for (std::size_t p = 0; p <= P; ++p) {
            L->phi_i.push_back(static_cast<float>(
                (2.0 * static_cast<double>(p) / static_cast<double>(P) - 1.0) * kPi));
        }
    } else {
        L->phi_i.push_back(0.0f);
    }
}

/// Node values (`rows` rows of n) as a grid over the unit square: an isotropic file (one row)
/// repeats its row.
BilinearGrid unit_square_grid(const std::vector<float>& values, std::size_t n, std::size_t rows) {
    std::vector<float> grid_rows(values);
    if (rows == 1) {
        grid_rows.insert(grid_rows.end(), values.begin(), values.end());
    }
    return BilinearGrid(n, std::max<std::size_t>(rows, 2), 1, std::move(grid_rows));
}

/// The VNDF of every (phi_i, theta_i) node over u_m, times the Jacobian of the unit coordinates.
/// The half vector's azimuth is relative to phi_i (0) in an isotropic file and absolute in an
/// anisotropic one; the NDF is read at the node's own u_m either way.
void fill_vndf(const BilinearGrid& ndf_grid, std::size_t n, std::size_t rows, RglLayout* L) {
    const std::size_t T = L->theta_i.size();
    const double h = 1.0 / static_cast<double>(n - 1);
    const std::size_t n_phi = L->phi_i.size();
    L->vndf.resize(n_phi * T * n * n);
    for (std::size_t p = 0; p < n_phi; ++p) {
        for (std::size_t k = 0; k < T; ++k) {
            const Vec3d wi = direction(L->theta_i[k], L->phi_i[p]);
            float* slice = L->vndf.data() + (p * T + k) * n * n;
            for (std::size_t row = 0; row < n; ++row) {
                const double phi_m = rgl_u_to_phi(static_cast<double>(row) * h);
                for (std::size_t col = 0; col < n; ++col) {
                    const double u = static_cast<double>(col) * h;
                    const double theta_m = rgl_u_to_theta(u);
                    const Vec3d m = direction(theta_m, phi_m);
                    const double jacobian = 2.0 * kPi * kPi * u * std::sin(theta_m);
                    const double d = ndf_grid.values()[(rows == 1 ? 0 : row * n) + col];
                    slice[row * n + col] =
                        static_cast<float>(d * std::max(0.0, wi.dot(m)) * jacobian);
                }
            }
        }
    }
}

/// The rgb nodes: the sample square's grid, warped onto half vectors.
void add_rgb_nodes(const BilinearGrid& ndf_grid,
                   const BilinearGrid& sigma_grid,
                   std::size_t rows,
                   RglLayout* L) {
    const std::size_t N = L->options.rgb_resolution;
    const double step = 1.0 / static_cast<double>(N - 1);
    for (std::size_t p = 0; p < L->phi_i.size(); ++p) {
        const double phi_i = L->phi_i[p];
        for (std::size_t k = 0; k < L->theta_i.size(); ++k) {
            const double theta_node = L->theta_i[k];
            const double theta_i = std::min(theta_node, L->options.max_theta_i);
            const Vec3d wi = direction(theta_i, phi_i);
            const double sigma = sigma_grid.eval(
                {rgl_theta_to_u(theta_node), rows == 1 ? 0.5 : rgl_phi_to_u(phi_i)}, 0);
            for (std::size_t row = 0; row < N; ++row) {
                for (std::size_t col = 0; col < N; ++col) {
                    RglNode node;
                    node.phi_index = p;
                    node.theta_index = k;
                    node.row = row;
                    node.column = col;
                    node.wi = wi;
                    node.u_m = L->vndf_warp.sample(
                        {static_cast<double>(col) * step, static_cast<double>(row) * step},
                        phi_i,
                        theta_node);
                    const double theta_m = rgl_u_to_theta(node.u_m[0]);
                    const double phi_m = rgl_u_to_phi(node.u_m[1]) + (rows == 1 ? phi_i : 0.0);
                    const Vec3d m = direction(theta_m, phi_m);
                    node.wo = 2.0 * wi.dot(m) * m - wi;
                    node.factor = ndf_grid.eval(node.u_m, 0) / (4.0 * sigma);
                    L->nodes.push_back(node);
                }
            }
        }
    }
}

}  // namespace

Expected<RglLayout> rgl_layout(const RglNdf& ndf, const RglWriteOptions& options) {
    if (auto ok = check_options(options); !ok) {
        return tl::unexpected(ok.error());
    }
    const std::size_t n = options.ndf_resolution;
    const std::size_t rows = anisotropic(options) ? n : 1;
    if (ndf.d.size() != rows * n || ndf.sigma.size() != rows * n) {
        return make_error("RGL layout: the NDF has " + std::to_string(ndf.d.size()) +
                          " nodes, the options ask for " + std::to_string(rows * n));
    }
    RglLayout L;
    L.options = options;
    for (std::size_t k = 0; k < rows * n; ++k) {
        if (!(ndf.d[k] > 0.0) || !(ndf.sigma[k] > 0.0) || !std::isfinite(ndf.d[k]) ||
            !std::isfinite(ndf.sigma[k])) {
            return make_error(
                "RGL layout: NDF node " + std::to_string(k) + " D = " + std::to_string(ndf.d[k]) +
                ", sigma = " + std::to_string(ndf.sigma[k]) + " (both must be finite and > 0)");
        }
        L.ndf.push_back(static_cast<float>(ndf.d[k]));
        L.sigma.push_back(static_cast<float>(ndf.sigma[k]));
    }
    set_incidence_nodes(options, &L);
    const BilinearGrid ndf_grid = unit_square_grid(L.ndf, n, rows);
    const BilinearGrid sigma_grid = unit_square_grid(L.sigma, n, rows);
    fill_vndf(ndf_grid, n, rows, &L);
    Expected<Warp2D> warp = Warp2D::build(n, n, L.vndf, L.phi_i, L.theta_i, "RGL layout: vndf");
    if (!warp) {
        return tl::unexpected(warp.error());
    }
    L.vndf_warp = std::move(*warp);
    add_rgb_nodes(ndf_grid, sigma_grid, rows, &L);
    return L;
}

Expected<TensorFile> rgl_tensor(const RglLayout& L, const std::vector<Rgbd>& f_r) {
    const std::size_t n = L.options.ndf_resolution;
    const std::size_t N = L.options.rgb_resolution;
    const std::size_t T = L.theta_i.size() * L.phi_i.size();  // slices of (phi_i, theta_i)
    if (f_r.size() != L.nodes.size()) {
        return make_error("RGL file: " + std::to_string(f_r.size()) + " values for " +
                          std::to_string(L.nodes.size()) + " nodes");
    }
    std::vector<float> rgb(T * 3 * N * N, 0.0f);
    std::vector<float> lum(T * N * N, 0.0f);
    std::vector<std::uint8_t> valid((T * N * N + 7) / 8, 0);
    for (std::size_t i = 0; i < L.nodes.size(); ++i) {
        const RglNode& node = L.nodes[i];
        const double cos_o = node.wo.z();
        const bool measured = f_r[i].allFinite() && (f_r[i] >= 0.0).all();
        if (!(cos_o > 0.0) || !measured || !(node.factor > 0.0)) {
            continue;  // stored 0: f_r cos(theta_o) vanishes at the horizon; bit clear
        }
        const Rgbd v = f_r[i] * cos_o / node.factor;
        if (!v.allFinite() || (v.abs() > 3e38).any()) {
            return make_error("RGL file: the value at theta_i node " +
                              std::to_string(node.theta_index) + ", row " +
                              std::to_string(node.row) + ", column " + std::to_string(node.column) +
                              " does not fit in float32");
        }
        const std::size_t plane = N * N;
        const std::size_t at = node.row * N + node.column;
        const std::size_t slice = node.phi_index * L.theta_i.size() + node.theta_index;
        for (std::size_t c = 0; c < 3; ++c) {
            rgb[(slice * 3 + c) * plane + at] = static_cast<float>(v[static_cast<Eigen::Index>(c)]);
        }
        lum[slice * plane + at] = static_cast<float>(std::max(0.0, luminance(v)));
        const std::size_t bit = slice * plane + at;
        valid[bit / 8] = static_cast<std::uint8_t>(valid[bit / 8] | (0x80u >> (bit % 8)));
    }
    // A renderer samples the luminance: a slice without any mass would normalise to NaN there.
    for (std::size_t k = 0; k < T; ++k) {
        float* slice = lum.data() + k * N * N;
        if (std::all_of(slice, slice + N * N, [](float v) { return v <= 0.0f; })) {
            std::fill(slice, slice + N * N, 1.0f);
        }
    }
    // An isotropic file's NDF and sigma are one row, written twice (a grid needs two).
    const bool aniso = L.phi_i.size() > 1;
    const std::size_t rows = aniso ? n : 2;
    std::vector<float> ndf2(L.ndf), sigma2(L.sigma);
    if (!aniso) {
        ndf2.insert(ndf2.end(), L.ndf.begin(), L.ndf.end());
        sigma2.insert(sigma2.end(), L.sigma.begin(), L.sigma.end());
    }
    const std::size_t P = L.phi_i.size(), TT = L.theta_i.size();
    const std::string& text = L.options.description;
    TensorFile f;
    f.fields.push_back(TensorField::uint8("version", {2}, {1, 0}));
    f.fields.push_back(TensorField::uint8(
        "description", {text.size()}, std::vector<std::uint8_t>(text.begin(), text.end())));
    f.fields.push_back(TensorField::float32("phi_i", {P}, L.phi_i));
    f.fields.push_back(TensorField::float32("theta_i", {TT}, L.theta_i));
    f.fields.push_back(TensorField::float32("sigma", {rows, n}, sigma2));
    f.fields.push_back(TensorField::float32("ndf", {rows, n}, ndf2));
    f.fields.push_back(TensorField::float32("vndf", {P, TT, n, n}, L.vndf));
    f.fields.push_back(TensorField::float32("luminance", {P, TT, N, N}, lum));
    f.fields.push_back(TensorField::float32("rgb", {P, TT, 3, N, N}, rgb));
    f.fields.push_back(TensorField::uint8("jacobian", {1}, {1}));
    f.fields.push_back(TensorField::uint8("valid", {valid.size()}, valid));
    return f;
}

Expected<RglWriteReport> write_rgl_bsdf(const std::string& path,
                                        const Brdf& brdf,
                                        const RglWriteOptions& options) {
    RglWriteOptions o = options;
    o.phi_i_count = rgl_phi_i_count(brdf, options);
    if (!brdf.isotropic() && o.phi_i_count == 1) {
        return make_error(path +
                          ": the BRDF is anisotropic; an isotropic RGL file (one phi_i node) "
                          "cannot hold it (ask for 2 or more phi_i azimuths)");
    }
    if (o.phi_i_count == 1) {
        o.phi_i_count = 0;  // the isotropic layout
    }
    if (anisotropic(o) && options.ndf_resolution == RglWriteOptions{}.ndf_resolution) {
        o.ndf_resolution = 64;  // the 2-D power iteration costs n^4 per step
    }
    RglWriteReport report;
    Expected<RglNdf> ndf = rgl_ndf_power_iteration(brdf, o);
    if (!ndf) {
        return make_error(path + ": " + ndf.error().message);
    }
    report.ndf = *ndf;
    if (o.description.empty()) {
        o.description = brdf.describe();
    }
    Expected<RglLayout> layout = rgl_layout(*ndf, o);
    if (!layout) {
        return make_error(path + ": " + layout.error().message);
    }
    std::vector<Rgbd> values(layout->nodes.size(), Rgbd::Zero());
    for (std::size_t i = 0; i < layout->nodes.size(); ++i) {
        const RglNode& node = layout->nodes[i];
        if (!(node.wo.z() > 0.0)) {
            ++report.below_horizon;
            continue;
        }
        values[i] = brdf.eval(node.wi, node.wo);
        if (!values[i].allFinite()) {
            return make_error(path + ": the BRDF is not finite at phi_i node " +
                              std::to_string(node.phi_index) + ", theta_i node " +
                              std::to_string(node.theta_index) + ", row " +
                              std::to_string(node.row) + ", column " + std::to_string(node.column));
        }
    }
    report.nodes = layout->nodes.size();
    Expected<TensorFile> file = rgl_tensor(*layout, values);
    if (!file) {
        return make_error(path + ": " + file.error().message);
    }
    const std::string bytes = encode_tensor_file(*file);
    report.bytes = bytes.size();
    if (auto w = write_file_atomic(path, bytes); !w) {
        return tl::unexpected(w.error());
    }
    return report;
}

}  // namespace gonio::brdf
