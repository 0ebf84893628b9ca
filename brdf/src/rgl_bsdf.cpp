// Reading and evaluating RGL material files (see rgl_bsdf.h).

#include "gonio/brdf/rgl_bsdf.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "gonio/base/strings.h"

namespace gonio::brdf {

namespace {

// Elevation of a unit vector, accurate near the pole: 2 asin(|d - z| / 2) (acos(z) loses half the
// digits there, where the specular peak of a glossy file lives).
double elevation(const Vec3d& d) {
    const double dz = d.z() - 1.0;
    const double chord = std::sqrt(d.x() * d.x() + d.y() * d.y() + dz * dz);
    return 2.0 * std::asin(std::min(1.0, 0.5 * chord));
}

constexpr float kPiF = 3.14159265358979323846f;
using Vec3f = Eigen::Vector3f;

// elevation() for single-precision vectors: the chord in single precision, the arcsine in double
// and the result rounded to single, as the format's readers compute it.
float elevation_f(const Vec3f& d) {
    const float dz = d.z() - 1.0f;
    const float half_chord = 0.5f * std::sqrt(d.x() * d.x() + d.y() * d.y() + dz * dz);
    return static_cast<float>(2.0f * std::asin(static_cast<double>(half_chord)));
}

std::string shape_text(const std::vector<std::uint64_t>& shape) {
    std::string s = "[";
    for (std::size_t k = 0; k < shape.size(); ++k) {
        s += (k ? ", " : "") + std::to_string(shape[k]);
    }
    return s + "]";
}

// The field of that name as float32 with the given rank; the error names file, field and rule.
Expected<const TensorField*> float_field(const TensorFile& file,
                                         const std::string& label,
                                         const std::string& name,
                                         std::size_t rank) {
    const TensorField* f = file.find(name);
    if (f == nullptr) {
        return make_error(label + ": field \"" + name + "\" missing (an RGL material file has " +
                          "theta_i, phi_i, ndf, sigma, vndf, luminance, rgb and jacobian)");
    }
    if (f->dtype != TensorDtype::kFloat32) {
        return make_error(label + ": field \"" + name + "\" is " + tensor_dtype_name(f->dtype) +
                          ", expected float32");
    }
    if (f->shape.size() != rank) {
        return make_error(label + ": field \"" + name + "\" has shape " + shape_text(f->shape) +
                          ", expected " + std::to_string(rank) + " dimensions");
    }
    return f;
}

Expected<void> all_finite(const std::vector<float>& v,
                          const std::string& label,
                          const std::string& name,
                          bool non_negative) {
    for (std::size_t k = 0; k < v.size(); ++k) {
        if (!std::isfinite(v[k]) || (non_negative && v[k] < 0.0f)) {
            return make_error(label + ": field \"" + name + "\" element " + std::to_string(k) +
                              " = " + std::to_string(v[k]) +
                              (non_negative ? " (must be finite and >= 0)" : " (must be finite)"));
        }
    }
    return {};
}

}  // namespace

bool is_rgl_path(const std::string& path) {
    return ends_with(path, ".bsdf");
}

double rgl_theta_to_u(double theta) {
    return std::sqrt(std::max(0.0, theta) * (2.0 / kPi));
}
double rgl_u_to_theta(double u) {
    return u * u * (kPi / 2.0);
}
double rgl_phi_to_u(double phi) {
    return (phi + kPi) / (2.0 * kPi);
}
double rgl_u_to_phi(double u) {
    return (2.0 * u - 1.0) * kPi;
}

namespace {

const char* const kSupportedRgl =
    "gonio reads RGB files (an \"rgb\" field): isotropic (one phi_i node), as the RGL "
    "database publishes for every material, and anisotropic (phi_i nodes over a full turn)";

/// The phi_i nodes: one (isotropic) or at least 3 increasing over a full turn (anisotropic,
/// unreduced: the readers, RGL's and Mitsuba 3's, evaluate only unreduced files).
Expected<std::vector<float>> read_phi_nodes(const TensorFile& file, const std::string& label) {
    const std::string supported = kSupportedRgl;
    auto phi_i = float_field(file, label, "phi_i", 1);
    if (!phi_i) {
        return tl::unexpected(phi_i.error());
    }
    std::vector<float> phi_nodes = (*phi_i)->as_float32();
    if (phi_nodes.size() == 2) {
        return make_error(label +
                          ": field \"phi_i\" has 2 nodes (an isotropic file has one; an "
                          "anisotropic one at least 3 over a full turn); " +
                          supported);
    }
    for (std::size_t k = 0; k < phi_nodes.size() && phi_nodes.size() > 1; ++k) {
        const float p = phi_nodes[k];
        if (!(p >= -3.1416f && p <= 3.1416f) || (k > 0 && !(p > phi_nodes[k - 1]))) {
            return make_error(label + ": field \"phi_i\" node " + std::to_string(k) + " = " +
                              std::to_string(p) +
                              " (nodes must increase strictly within [-pi, pi])");
        }
    }
    if (phi_nodes.size() > 2) {
        // The span of the nodes is a full turn divided by the symmetry the file was reduced by.
        const double span = static_cast<double>(phi_nodes.back()) - phi_nodes.front();
        const long reduction = std::lround(2.0 * kPi / span);
        if (reduction != 1) {
            char deg[32];
            std::snprintf(deg, sizeof deg, "%.1f", span * 180.0 / kPi);
            return make_error(label + ": field \"phi_i\" spans " + std::string(deg) +
                              " deg, a file reduced by a " + std::to_string(reduction) +
                              "-fold symmetry; " + supported + " (reduction 1)");
        }
    }
    return phi_nodes;
}

/// The fields of an RGL material file besides phi_i, each of its dtype and rank.
struct RglFields {
    const TensorField* theta_i = nullptr;
    const TensorField* ndf = nullptr;
    const TensorField* sigma = nullptr;
    const TensorField* vndf = nullptr;
    const TensorField* luminance = nullptr;
    const TensorField* rgb = nullptr;
    const TensorField* jacobian = nullptr;
};

Expected<RglFields> read_fields(const TensorFile& file, const std::string& label) {
    auto theta_i = float_field(file, label, "theta_i", 1);
    auto ndf = float_field(file, label, "ndf", 2);
    auto sigma = float_field(file, label, "sigma", 2);
    auto vndf = float_field(file, label, "vndf", 4);
    auto luminance = float_field(file, label, "luminance", 4);
    auto rgb = float_field(file, label, "rgb", 5);
    for (const auto* f : {&theta_i, &ndf, &sigma, &vndf, &luminance, &rgb}) {
        if (!*f) {
            return tl::unexpected(f->error());
        }
    }
    const TensorField* jac = file.find("jacobian");
    if (jac == nullptr || jac->dtype != TensorDtype::kUInt8 || jac->shape.size() != 1 ||
        jac->shape[0] != 1) {
        return make_error(label + ": field \"jacobian\" " +
                          (jac ? "is " + jac->describe() : std::string("missing")) +
                          ", expected uint8 [1]");
    }
    return RglFields{*theta_i, *ndf, *sigma, *vndf, *luminance, *rgb, jac};
}

/// The fields' shapes agree with each other and with the n_phi phi_i nodes.
Expected<void> check_shapes(const RglFields& f, std::uint64_t n_phi, const std::string& label) {
    const std::uint64_t n_theta = f.theta_i->shape[0];
    const auto& vs = f.vndf->shape;
    const auto& ls = f.luminance->shape;
    const auto& rs = f.rgb->shape;
    const auto& ns = f.ndf->shape;
    const auto& ss = f.sigma->shape;
    auto disagree = [&](const std::string& what) -> Expected<void> {
        return make_error(label + ": field shapes disagree: " + what + " (theta_i " +
                          shape_text({n_theta}) + ", ndf " + shape_text(ns) + ", sigma " +
                          shape_text(ss) + ", vndf " + shape_text(vs) + ", luminance " +
                          shape_text(ls) + ", rgb " + shape_text(rs) + ")");
    };
    if (n_theta < 1) {
        return disagree("theta_i has no node");
    }
    if (ns[0] < 2 || ns[1] < 2 || ss[0] < 2 || ss[1] < 2) {
        return disagree("ndf and sigma need at least 2 x 2 nodes");
    }
    if (n_phi < 1) {
        return disagree("phi_i has no node");
    }
    if (vs[0] != n_phi || vs[1] != n_theta || vs[2] < 2 || vs[3] < 2) {
        return disagree("vndf must be [phi_i, theta_i, >= 2, >= 2]");
    }
    if (rs[0] != n_phi || rs[1] != n_theta || rs[2] != 3 || rs[3] < 2 || rs[3] != rs[4]) {
        return disagree("rgb must be [phi_i, theta_i, 3, N, N] with N >= 2");
    }
    if (ls[0] != n_phi || ls[1] != n_theta || ls[2] != rs[3] || ls[3] != rs[4]) {
        return disagree("luminance must be [phi_i, theta_i, N, N] like rgb");
    }
    return {};
}

Expected<void> check_theta_nodes(const std::vector<float>& theta_i, const std::string& label) {
    for (std::size_t k = 0; k < theta_i.size(); ++k) {
        const float t = theta_i[k];
        if (!(t >= 0.0f && t <= 1.5708f) || (k > 0 && !(t > theta_i[k - 1]))) {
            return make_error(label + ": field \"theta_i\" node " + std::to_string(k) + " = " +
                              std::to_string(t) +
                              " (nodes must increase strictly within [0, pi/2])");
        }
    }
    return {};
}

/// ndf and sigma finite and >= 0 (sigma > 0: the evaluation divides by it), rgb finite.
Expected<void> check_tables(const std::vector<float>& ndf_v,
                            const std::vector<float>& sigma_v,
                            const std::vector<float>& rgb_v,
                            const std::string& label) {
    if (auto ok = all_finite(ndf_v, label, "ndf", true); !ok) {
        return ok;
    }
    if (auto ok = all_finite(sigma_v, label, "sigma", true); !ok) {
        return ok;
    }
    if (auto ok = all_finite(rgb_v, label, "rgb", false); !ok) {
        return ok;
    }
    for (std::size_t k = 0; k < sigma_v.size(); ++k) {
        if (!(sigma_v[k] > 0.0f)) {
            return make_error(label + ": field \"sigma\" element " + std::to_string(k) + " = " +
                              std::to_string(sigma_v[k]) +
                              " (a projected area is > 0; the evaluation divides by it)");
        }
    }
    return {};
}

/// The optional "description" as text: trailing NULs dropped, control characters as spaces.
std::string read_description(const TensorFile& file) {
    std::string text;
    if (const TensorField* d = file.find("description"); d && d->dtype == TensorDtype::kUInt8) {
        text.assign(d->data.begin(), d->data.end());
        while (!text.empty() && text.back() == '\0') {
            text.pop_back();
        }
        for (char& c : text) {
            const auto u = static_cast<unsigned char>(c);
            if (u < 0x20 || u == 0x7f) {
                c = ' ';
            }
        }
    }
    return text;
}

}  // namespace

Expected<RglBsdf> RglBsdf::from_tensor(const TensorFile& file, const std::string& label) {
    // What the file is, before its fields are checked: spectral-only files are refused with what
    // is supported.
    if (file.find("rgb") == nullptr && (file.find("spectra") || file.find("wavelengths"))) {
        return make_error(label +
                          ": a spectral RGL file (fields \"spectra\" and \"wavelengths\", "
                          "no \"rgb\"); " +
                          kSupportedRgl);
    }
    auto phi_nodes = read_phi_nodes(file, label);
    if (!phi_nodes) {
        return tl::unexpected(phi_nodes.error());
    }
    const std::uint64_t n_phi = phi_nodes->size();
    auto fields = read_fields(file, label);
    if (!fields) {
        return tl::unexpected(fields.error());
    }
    if (auto ok = check_shapes(*fields, n_phi, label); !ok) {
        return tl::unexpected(ok.error());
    }
    const std::uint64_t n_theta = fields->theta_i->shape[0];
    const auto& vs = fields->vndf->shape;
    const auto& rs = fields->rgb->shape;
    // Sizes are bounded by the file size (the codec checked every field against it), so the
    // products below fit.
    RglBsdf b;
    b.label_ = label;
    b.n_ = static_cast<std::size_t>(rs[3]);
    b.jacobian_ = fields->jacobian->data[0] != 0;
    b.isotropic_ = n_phi == 1;
    b.phi_i_ = std::move(*phi_nodes);
    b.theta_i_ = fields->theta_i->as_float32();
    if (auto ok = check_theta_nodes(b.theta_i_, label); !ok) {
        return tl::unexpected(ok.error());
    }
    std::vector<float> ndf_v = fields->ndf->as_float32();
    std::vector<float> sigma_v = fields->sigma->as_float32();
    std::vector<float> rgb_v = fields->rgb->as_float32();
    if (auto ok = check_tables(ndf_v, sigma_v, rgb_v, label); !ok) {
        return tl::unexpected(ok.error());
    }
    b.ndf_ = BilinearGrid(fields->ndf->shape[1], fields->ndf->shape[0], 1, std::move(ndf_v));
    b.sigma_ =
        BilinearGrid(fields->sigma->shape[1], fields->sigma->shape[0], 1, std::move(sigma_v));
    b.rgb_ = BilinearGrid(rs[4], rs[3], n_phi * n_theta * 3, std::move(rgb_v));
    Expected<Warp2D> warp = Warp2D::build(
        vs[3], vs[2], fields->vndf->as_float32(), b.phi_i_, b.theta_i_, label + ": field \"vndf\"");
    if (!warp) {
        return tl::unexpected(warp.error());
    }
    b.vndf_ = std::move(*warp);
    b.description_ = read_description(file);
    if (const TensorField* v = file.find("valid")) {
        const std::uint64_t bits = n_phi * n_theta * rs[3] * rs[4];
        if (tensor_dtype_size(v->dtype) != 1 || v->data.size() != (bits + 7) / 8) {
            return make_error(label + ": field \"valid\" is " + v->describe() + ", expected " +
                              std::to_string((bits + 7) / 8) + " bytes (one bit per rgb node)");
        }
        b.valid_ = v->data;
    }
    return b;
}

Rgbd RglBsdf::eval_unclipped(const Vec3d& wi, const Vec3d& wo) const {
    // Below or at the horizon, and the degenerate pair wi = -wo (no half vector).
    if (!(wi.z() > 0.0) || !(wo.z() > 0.0)) {
        return Rgbd::Zero();
    }
    const Vec3d h = wi + wo;
    const double len = h.norm();
    if (!(len > 0.0)) {
        return Rgbd::Zero();
    }
    // The direction pair in single precision, as the format's readers (RGL's, Mitsuba 3's)
    // compute it: a file then gives the same values in gonio as in a renderer.
    const Vec3f wi_f = wi.cast<float>();
    const Vec3f wo_f = wo.cast<float>();
    const Vec3f m_f = (wi_f + wo_f) / std::sqrt((wi_f + wo_f).dot(wi_f + wo_f));
    const float theta_i_f = elevation_f(wi_f);
    const float phi_i_f = std::atan2(wi_f.y(), wi_f.x());
    const float theta_m_f = elevation_f(m_f);
    const float phi_m_f = std::atan2(m_f.y(), m_f.x());
    const float u_wi_x = std::sqrt(theta_i_f * (2.0f / kPiF));
    const float u_wi_y = (phi_i_f + kPiF) / (2.0f * kPiF);
    // An isotropic file measures the half vector's azimuth from the incident one; an anisotropic
    // file from the sample's x axis.
    float u_phi = ((isotropic_ ? phi_m_f - phi_i_f : phi_m_f) + kPiF) / (2.0f * kPiF);
    u_phi -= std::floor(u_phi);
    const float u_m_x = std::sqrt(theta_m_f * (2.0f / kPiF));
    const std::array<float, 2> s = vndf_.invert_f(u_m_x, u_phi, phi_i_f, theta_i_f);
    // (phi_i, theta_i) weights between the rgb slices, as the warp computes them.
    const SliceWeightsF sw = slice_weights_f(phi_i_, theta_i_, phi_i_f, theta_i_f);
    Eigen::Array3f fr;
    for (std::size_t c = 0; c < 3; ++c) {
        fr[static_cast<Eigen::Index>(c)] = rgb_.eval_f(s[0], s[1], sw, 3, c);
    }
    if (jacobian_) {
        fr = fr * ndf_.eval_f(u_m_x, u_phi, SliceWeightsF{}, 1, 0) /
             (4.0f * sigma_.eval_f(u_wi_x, u_wi_y, SliceWeightsF{}, 1, 0));
    }
    Rgbd f = fr.cast<double>() / static_cast<double>(wo_f.z());
    // A non-finite value cannot come from finite tables with sigma > 0; kept as a guard.
    if (!f.allFinite()) {
        return Rgbd::Zero();
    }
    return f;
}

Rgbd RglBsdf::eval(const Vec3d& wi, const Vec3d& wo) const {
    return eval_unclipped(wi, wo).max(0.0);
}

std::string RglBsdf::describe() const {
    char buf[160];
    if (isotropic_) {
        std::snprintf(
            buf,
            sizeof buf,
            ": RGL material file (isotropic RGB, %zu theta_i nodes, %zu x %zu nodes each)",
            theta_i_.size(),
            n_,
            n_);
    } else {
        std::snprintf(buf,
                      sizeof buf,
                      ": RGL material file (anisotropic RGB, %zu phi_i x %zu theta_i nodes, %zu x "
                      "%zu nodes each)",
                      phi_i_.size(),
                      theta_i_.size(),
                      n_,
                      n_);
    }
    return label_ + buf + (description_.empty() ? "" : ", \"" + description_ + "\"");
}

std::string RglBsdf::statistics() const {
    const std::vector<RglNode> all = nodes();
    std::size_t valid = 0;
    for (const RglNode& node : all) {
        valid += node_valid(node) ? 1 : 0;
    }
    return "nodes: " + std::to_string(all.size()) + " distinct, " + std::to_string(valid) +
           " with the \"valid\" bit set\n";
}

std::vector<RglNode> RglBsdf::nodes() const {
    std::vector<RglNode> out;
    const double step = 1.0 / static_cast<double>(n_ - 1);
    // An anisotropic file's last phi_i node is its first one a full turn on (the same wi).
    const std::size_t n_phi = isotropic_ ? 1 : phi_i_.size() - 1;
    for (std::size_t p = 0; p < n_phi; ++p) {
        const double phi_i = isotropic_ ? 0.0 : static_cast<double>(phi_i_[p]);
        for (std::size_t k = 0; k < theta_i_.size(); ++k) {
            const double theta_i = theta_i_[k];
            const Vec3d wi(std::sin(theta_i) * std::cos(phi_i),
                           std::sin(theta_i) * std::sin(phi_i),
                           std::cos(theta_i));
            const Point2 u_wi = {rgl_theta_to_u(theta_i), rgl_phi_to_u(phi_i)};
            const double sigma = sigma_.eval(u_wi, 0);
            for (std::size_t row = 0; row + 1 < n_; ++row) {
                for (std::size_t col = 0; col < n_; ++col) {
                    if (col == 0 && row > 0) {
                        continue;  // every row's first column is the normal half vector
                    }
                    RglNode node;
                    node.phi_index = p;
                    node.theta_index = k;
                    node.row = row;
                    node.column = col;
                    node.wi = wi;
                    node.u_m = vndf_.sample(
                        {static_cast<double>(col) * step, static_cast<double>(row) * step},
                        phi_i,
                        theta_i);
                    const double theta_m = rgl_u_to_theta(node.u_m[0]);
                    // Relative to phi_i (0 here) in an isotropic file, absolute in an anisotropic
                    // one.
                    const double phi_m = rgl_u_to_phi(node.u_m[1]);
                    const Vec3d m(std::sin(theta_m) * std::cos(phi_m),
                                  std::sin(theta_m) * std::sin(phi_m),
                                  std::cos(theta_m));
                    node.wo = 2.0 * wi.dot(m) * m - wi;
                    node.factor = jacobian_ ? ndf_.eval(node.u_m, 0) / (4.0 * sigma) : 1.0;
                    out.push_back(node);
                }
            }
        }
    }
    return out;
}

Rgbd RglBsdf::stored(const RglNode& node) const {
    Rgbd v;
    const std::size_t plane = n_ * n_;
    for (std::size_t c = 0; c < 3; ++c) {
        v[static_cast<Eigen::Index>(c)] =
            rgb_.values()[((node.phi_index * theta_i_.size() + node.theta_index) * 3 + c) * plane +
                          node.row * n_ + node.column];
    }
    return v;
}

bool RglBsdf::node_valid(const RglNode& node) const {
    if (valid_.empty()) {
        return true;
    }
    const std::size_t slice = node.phi_index * theta_i_.size() + node.theta_index;
    const std::size_t bit = (slice * n_ + node.row) * n_ + node.column;
    return (valid_[bit / 8] >> (7 - bit % 8)) & 1u;
}

Expected<RglBsdf> read_rgl_bsdf(const std::string& path) {
    Expected<TensorFile> file = read_tensor_file(path);
    if (!file) {
        return tl::unexpected(file.error());
    }
    return RglBsdf::from_tensor(*file, path);
}

Dataset rgl_nodes_to_dataset(const RglBsdf& bsdf) {
    Dataset data;
    data.source = bsdf.label();
    constexpr double kMaxThetaI = 89.0 * kPi / 180.0;
    for (const RglNode& node : bsdf.nodes()) {
        const double cos_o = node.wo.z();
        if (bsdf.theta_i()[node.theta_index] > kMaxThetaI || !(cos_o > 1e-3)) {
            continue;
        }
        Sample s;
        s.theta_i = static_cast<double>(bsdf.theta_i()[node.theta_index]);
        s.phi_i = std::atan2(node.wi.y(), node.wi.x());
        s.theta_o = elevation(node.wo);
        s.phi_o = std::atan2(node.wo.y(), node.wo.x());
        s.value = (bsdf.stored(node) * node.factor / cos_o).max(0.0);
        if (!s.value.allFinite() || !validate_sample(s).empty()) {
            continue;
        }
        data.samples.push_back(s);
    }
    return data;
}

}  // namespace gonio::brdf
