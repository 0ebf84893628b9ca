// gonio._gonio: Python bindings of the C++ libraries (brdf, fitting, batch). The pure-Python
// package (python/gonio/__init__.py) re-exports these functions; docs/python.md and the type hints
// (gonio/_gonio.pyi) describe them. Every computation runs in the C++ libraries; this file only
// converts between numpy/dicts and the library types, and turns gonio::Error into gonio.Error
// carrying the library's message (the same text the command line prints).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/base/strings.h"
#include "gonio/batch/fit_request.h"
#include "gonio/batch/manifest.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/checks.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/direction_rows.h"
#include "gonio/brdf/material_library.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/brdf/table.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"
#include "gonio/version.h"

namespace py = pybind11;

namespace {

using gonio::ends_with;
using gonio::Expected;
using gonio::brdf::Brdf;
using gonio::brdf::Dataset;
using gonio::brdf::Sample;
using gonio::brdf::TableGrid;
using gonio::brdf::TableValues;
using gonio::brdf::TabulatedBrdf;

/// An expected failure of the libraries, raised in Python as gonio.Error (a ValueError).
struct GonioError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

template <class T>
T value_or_raise(Expected<T> e) {
    if (!e) {
        throw GonioError(e.error().message);
    }
    return std::move(*e);
}

void ok_or_raise(const Expected<void>& e) {
    if (!e) {
        throw GonioError(e.error().message);
    }
}

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

py::object json_module() {
    return py::module_::import("json");
}

std::string to_json_text(const py::handle& obj) {
    return json_module().attr("dumps")(obj).cast<std::string>();
}

py::object from_json_text(const std::string& text) {
    return json_module().attr("loads")(text);
}

/// A path from str or os.PathLike; empty optional for anything else.
bool as_path(const py::handle& obj, std::string& out) {
    if (py::isinstance<py::str>(obj)) {
        out = obj.cast<std::string>();
        return true;
    }
    if (py::hasattr(obj, "__fspath__")) {
        out = py::module_::import("os").attr("fspath")(obj).cast<std::string>();
        return true;
    }
    return false;
}

bool is_table_dict(const py::dict& d) {
    return d.contains("kind") && py::str(d["kind"]).cast<std::string>() == "table";
}

bool is_samples_dict(const py::dict& d) {
    return d.contains("theta_i") && d.contains("value");
}

/// A table from a dict made by load()/tabulate() (copies raw; checks what the constructor asserts).
TabulatedBrdf table_from_dict(const py::dict& d) {
    for (const char* key : {"grid", "scale", "raw"}) {
        if (!d.contains(key)) {
            throw GonioError(std::string("table dict: missing key \"") + key + "\"");
        }
    }
    const auto g = d["grid"].cast<std::vector<long long>>();
    if (g.size() != 3 || g[0] <= 0 || g[1] <= 0 || g[2] <= 0 || g[0] > gonio::brdf::kMaxTableDim ||
        g[1] > gonio::brdf::kMaxTableDim || g[2] > gonio::brdf::kMaxTableDim) {
        throw GonioError("table dict: grid must be three dimensions in [1, " +
                         std::to_string(gonio::brdf::kMaxTableDim) + "]");
    }
    const TableGrid grid{static_cast<int>(g[0]), static_cast<int>(g[1]), static_cast<int>(g[2])};
    const auto s = d["scale"].cast<std::vector<double>>();
    if (s.size() != 3) {
        throw GonioError("table dict: scale must have 3 entries (r, g, b)");
    }
    std::array<double, 3> scale{};
    for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(s[c]) || !(s[c] > 0)) {
            throw GonioError("table dict: scale[" + std::to_string(c) +
                             "] = " + std::to_string(s[c]) + ": must be finite and > 0");
        }
        scale[c] = s[c];
    }
    const DoubleArray raw = DoubleArray::ensure(d["raw"]);
    if (!raw || static_cast<std::size_t>(raw.size()) != 3 * grid.size()) {
        throw GonioError("table dict: raw must hold 3 x " + std::to_string(grid.size()) +
                         " numbers for grid " + std::to_string(g[0]) + "x" + std::to_string(g[1]) +
                         "x" + std::to_string(g[2]));
    }
    TableValues values(raw.data(), raw.data() + raw.size());
    for (std::size_t k = 0; k < values.size(); ++k) {
        if (!std::isfinite(values[k])) {
            throw GonioError("table dict: raw[" + std::to_string(k) + "] is not finite");
        }
    }
    std::string source = d.contains("source") ? py::str(d["source"]).cast<std::string>() : "<dict>";
    return TabulatedBrdf(grid, scale, std::move(values), std::move(source));
}

/// A BRDF from a model dict (model schema), a table dict, a path or "material:NAME".
std::unique_ptr<Brdf> brdf_from(const py::handle& obj) {
    std::string path;
    if (as_path(obj, path)) {
        return value_or_raise(gonio::brdf::load_brdf(path));
    }
    if (py::isinstance<py::dict>(obj)) {
        const py::dict d = py::reinterpret_borrow<py::dict>(obj);
        if (is_table_dict(d)) {
            return std::make_unique<TabulatedBrdf>(table_from_dict(d));
        }
        auto model = value_or_raise(gonio::brdf::parse_model_json(to_json_text(d), "<dict>"));
        return std::make_unique<gonio::brdf::AnalyticBrdf>(std::move(model), "<dict>");
    }
    throw GonioError(
        "model: expected a dict in the model schema, a table dict from gonio.load(), a path, or "
        "\"material:NAME\"");
}

// ---- eval ------------------------------------------------------------------------------------

/// The rows of one eval() call, evaluated together (brdf::DirectionRows: Brdf::eval_many, an
/// analytic model on SIMD packets). A row that cannot be evaluated keeps its place, as a refused
/// line of `gonio eval` does: a NaN row in the output and a warning naming the row; only an input
/// without a usable row raises.
class EvalRows {
  public:
    explicit EvalRows(std::size_t n) : n_(n) { rows_.reserve(n); }

    void add(const gonio::brdf::Vec3d& wi, const gonio::brdf::Vec3d& wo) { rows_.add(wi, wo); }

    /// The next row cannot be evaluated, for `reason`: written as NaN.
    void refuse(std::string reason) {
        note(rows_.size(), std::move(reason));
        rows_.add_refused();
        ++refused_count_;
    }

    /// Raises gonio.Error when rows were given and none can be evaluated.
    void require_a_usable_row() const {
        if (n_ == 0 || refused_count_ < n_) {
            return;
        }
        const std::string& first = notes_.front().second;
        throw GonioError(n_ == 1 ? first
                                 : "none of the " + std::to_string(n_) +
                                       " rows can be evaluated (row 0: " + first + ")");
    }

    /// The n x 3 values, NaN rows for the refused rows and for non-finite values; then one warning
    /// per such row (the first kNamedRows named, the rest counted in one more).
    py::array_t<double> evaluate(const Brdf& brdf) {
        py::array_t<double> out({static_cast<py::ssize_t>(n_), py::ssize_t{3}});
        double* pout = out.mutable_data();
        {
            py::gil_scoped_release release;
            std::vector<double> values(3 * n_);
            double* const channels[3] = {values.data(), values.data() + n_, values.data() + 2 * n_};
            for (const std::size_t k : rows_.evaluate(brdf, channels)) {
                note(k, "non-finite BRDF value");
            }
            for (std::size_t k = 0; k < n_; ++k) {
                for (int c = 0; c < 3; ++c) {
                    pout[3 * k + c] = channels[c][k];
                }
            }
        }
        warn();
        return out;
    }

  private:
    static constexpr std::size_t kNamedRows = 20;

    void note(std::size_t row, std::string reason) {
        if (notes_.size() < kNamedRows) {
            notes_.emplace_back(row, std::move(reason));
        }
        ++noted_;
    }

    void warn() const {
        std::vector<std::string> messages;
        for (const auto& [row, reason] : notes_) {
            messages.push_back("gonio.eval: row " + std::to_string(row) + ": " + reason +
                               " (NaN row written)");
        }
        if (noted_ > notes_.size()) {
            messages.push_back("gonio.eval: " + std::to_string(noted_ - notes_.size()) +
                               " more row(s) written as NaN");
        }
        for (const std::string& m : messages) {
            if (PyErr_WarnEx(PyExc_UserWarning, m.c_str(), 1) != 0) {
                throw py::error_already_set();
            }
        }
    }

    std::size_t n_;
    gonio::brdf::DirectionRows rows_;
    std::size_t refused_count_ = 0;
    std::vector<std::pair<std::size_t, std::string>> notes_;
    std::size_t noted_ = 0;
};

/// Why direction v (named `name`, row k) cannot be evaluated; empty when it can.
std::string direction_problem(const char* name, std::size_t k, const gonio::brdf::Vec3d& v) {
    if (v.allFinite() && std::abs(v.norm() - 1.0) <= 1e-6) {
        return {};
    }
    std::ostringstream s;
    s.precision(17);
    s << name << "[" << k << "] = (" << v[0] << ", " << v[1] << ", " << v[2]
      << "): must be a finite unit vector (|norm - 1| <= 1e-6)";
    return s.str();
}

py::array_t<double> eval_dirs(const py::handle& model,
                              const DoubleArray& wi,
                              const DoubleArray& wo) {
    const std::unique_ptr<Brdf> brdf = brdf_from(model);
    for (const auto& [name, a] :
         {std::pair<const char*, const DoubleArray*>{"wi", &wi}, {"wo", &wo}}) {
        if (a->ndim() != 2 || a->shape(1) != 3) {
            throw GonioError(std::string(name) + ": expected an N x 3 array of unit vectors");
        }
    }
    if (wi.shape(0) != wo.shape(0)) {
        throw GonioError("wi has " + std::to_string(wi.shape(0)) + " rows, wo has " +
                         std::to_string(wo.shape(0)));
    }
    const std::size_t n = static_cast<std::size_t>(wi.shape(0));
    const double* pi = wi.data();
    const double* po = wo.data();
    EvalRows rows(n);
    for (std::size_t k = 0; k < n; ++k) {
        const gonio::brdf::Vec3d a(pi[3 * k], pi[3 * k + 1], pi[3 * k + 2]);
        const gonio::brdf::Vec3d b(po[3 * k], po[3 * k + 1], po[3 * k + 2]);
        std::string problem = direction_problem("wi", k, a);
        if (problem.empty()) {
            problem = direction_problem("wo", k, b);
        }
        if (problem.empty()) {
            rows.add(a, b);
        } else {
            rows.refuse(std::move(problem));
        }
    }
    rows.require_a_usable_row();
    return rows.evaluate(*brdf);
}

/// Why angle j of row k (theta_i, phi_i, theta_o, phi_o) cannot be evaluated; empty when it can.
std::string angle_problem(const char* name, int j, std::size_t k, double v) {
    std::ostringstream s;
    s.precision(17);
    if (!std::isfinite(v)) {
        s << name << "[" << k << "] = " << v << ": must be finite";
    } else if ((j == 0 || j == 2) && (v < 0 || v > gonio::brdf::kPi)) {
        s << name << "[" << k << "] = " << v << ": outside [0, pi]";
    }
    return s.str();
}

py::array_t<double> eval_angles(const py::handle& model,
                                const DoubleArray& theta_i,
                                const DoubleArray& phi_i,
                                const DoubleArray& theta_o,
                                const DoubleArray& phi_o) {
    const std::unique_ptr<Brdf> brdf = brdf_from(model);
    const py::ssize_t n = theta_i.size();
    const char* names[4] = {"theta_i", "phi_i", "theta_o", "phi_o"};
    const DoubleArray* arrays[4] = {&theta_i, &phi_i, &theta_o, &phi_o};
    for (int j = 0; j < 4; ++j) {
        if (arrays[j]->ndim() > 1 || arrays[j]->size() != n) {
            throw GonioError(std::string(names[j]) + ": expected a 1-D array of " +
                             std::to_string(n) + " angles (radians), like theta_i");
        }
    }
    const double* p[4] = {theta_i.data(), phi_i.data(), theta_o.data(), phi_o.data()};
    EvalRows rows(static_cast<std::size_t>(n));
    for (std::size_t k = 0; k < static_cast<std::size_t>(n); ++k) {
        std::string problem;
        for (int j = 0; j < 4 && problem.empty(); ++j) {
            problem = angle_problem(names[j], j, k, p[j][k]);
        }
        if (!problem.empty()) {
            rows.refuse(std::move(problem));
            continue;
        }
        rows.add(gonio::brdf::spherical_to_cartesian(p[0][k], p[1][k]),
                 gonio::brdf::spherical_to_cartesian(p[2][k], p[3][k]));
    }
    rows.require_a_usable_row();
    return rows.evaluate(*brdf);
}

// ---- datasets and tables as numpy --------------------------------------------------------------

/// Read-only strided views into a heap Dataset kept alive by a capsule: no copy of the samples.
py::dict dataset_to_dict(std::unique_ptr<Dataset> data) {
    Dataset* d = data.release();
    py::capsule owner(d, [](void* p) { delete static_cast<Dataset*>(p); });
    const py::ssize_t n = static_cast<py::ssize_t>(d->samples.size());
    const Sample probe;
    const char* base = reinterpret_cast<const char*>(&probe);
    auto offset = [&](const void* field) {
        return static_cast<py::ssize_t>(reinterpret_cast<const char*>(field) - base);
    };
    const py::ssize_t stride = static_cast<py::ssize_t>(sizeof(Sample));
    // An empty vector has no storage: point the (empty) views at the probe's layout instead.
    static const Sample kEmpty;
    const char* first = n > 0 ? reinterpret_cast<const char*>(d->samples.data())
                              : reinterpret_cast<const char*>(&kEmpty);
    auto column = [&](const void* field) {
        py::array_t<double> a(
            {n}, {stride}, reinterpret_cast<const double*>(first + offset(field)), owner);
        py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
        return a;
    };
    auto rgb = [&](const void* field) {
        py::array_t<double> a({n, py::ssize_t{3}},
                              {stride, py::ssize_t{sizeof(double)}},
                              reinterpret_cast<const double*>(first + offset(field)),
                              owner);
        py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
        return a;
    };
    py::dict out;
    out["kind"] = "samples";
    out["source"] = d->source;
    out["theta_i"] = column(&probe.theta_i);
    out["phi_i"] = column(&probe.phi_i);
    out["theta_o"] = column(&probe.theta_o);
    out["phi_o"] = column(&probe.phi_o);
    out["value"] = rgb(&probe.value[0]);
    out["sigma"] = rgb(&probe.sigma[0]);
    out["weight"] = column(&probe.weight);
    py::array_t<std::uint32_t> flags(
        {n}, {stride}, reinterpret_cast<const std::uint32_t*>(first + offset(&probe.flags)), owner);
    py::detail::array_proxy(flags.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    out["flags"] = flags;
    py::array_t<std::uint64_t> lines(n);
    for (py::ssize_t k = 0; k < n; ++k) {
        lines.mutable_data()[k] = d->samples[static_cast<std::size_t>(k)].line;
    }
    out["line"] = lines;
    out["has_sigma"] = d->has_sigma;
    out["has_weight"] = d->has_weight;
    out["has_flags"] = d->has_flags;
    py::list rejected;
    for (const auto& r : d->rejected) {
        rejected.append(py::make_tuple(r.line, r.reason));
    }
    out["rejected"] = rejected;
    return out;
}

/// A Dataset from a samples dict (copies; columns sigma, weight, flags optional).
Dataset dataset_from_dict(const py::dict& d) {
    Dataset data;
    data.source = d.contains("source") ? py::str(d["source"]).cast<std::string>() : "<dict>";
    const char* names[4] = {"theta_i", "phi_i", "theta_o", "phi_o"};
    std::vector<DoubleArray> angles;
    for (const char* name : names) {
        if (!d.contains(name)) {
            throw GonioError(std::string("samples dict: missing key \"") + name + "\"");
        }
        angles.push_back(DoubleArray::ensure(d[name]));
    }
    const py::ssize_t n = angles[0].size();
    for (int j = 0; j < 4; ++j) {
        if (angles[j].ndim() != 1 || angles[j].size() != n) {
            throw GonioError(std::string("samples dict: ") + names[j] + " must be 1-D with " +
                             std::to_string(n) + " entries like theta_i");
        }
    }
    auto rgb_array = [&](const char* key) {
        DoubleArray a = DoubleArray::ensure(d[key]);
        if (!a || a.ndim() != 2 || a.shape(0) != n || a.shape(1) != 3) {
            throw GonioError(std::string("samples dict: ") + key +
                             " must be N x 3 with N = " + std::to_string(n));
        }
        return a;
    };
    auto want = [&](const char* key, const char* flag) {
        return d.contains(key) && !d[key].is_none() && !(d.contains(flag) && !d[flag].cast<bool>());
    };
    const DoubleArray value = rgb_array("value");
    data.has_sigma = want("sigma", "has_sigma");
    data.has_weight = want("weight", "has_weight");
    data.has_flags = want("flags", "has_flags");
    DoubleArray sigma, weight;
    py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast> flags;
    if (data.has_sigma) {
        sigma = rgb_array("sigma");
    }
    if (data.has_weight) {
        weight = DoubleArray::ensure(d["weight"]);
        if (weight.ndim() != 1 || weight.size() != n) {
            throw GonioError("samples dict: weight must be 1-D with N = " + std::to_string(n));
        }
    }
    if (data.has_flags) {
        flags = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>::ensure(
            d["flags"]);
        if (!flags || flags.ndim() != 1 || flags.size() != n) {
            throw GonioError("samples dict: flags must be 1-D unsigned with N = " +
                             std::to_string(n));
        }
    }
    data.samples.resize(static_cast<std::size_t>(n));
    for (py::ssize_t k = 0; k < n; ++k) {
        Sample& s = data.samples[static_cast<std::size_t>(k)];
        s.theta_i = angles[0].data()[k];
        s.phi_i = angles[1].data()[k];
        s.theta_o = angles[2].data()[k];
        s.phi_o = angles[3].data()[k];
        for (int c = 0; c < 3; ++c) {
            s.value[c] = value.data()[3 * k + c];
            if (data.has_sigma) {
                s.sigma[c] = sigma.data()[3 * k + c];
            }
        }
        if (data.has_weight) {
            s.weight = weight.data()[k];
        }
        if (data.has_flags) {
            s.flags = flags.data()[k];
        }
        s.line = static_cast<std::size_t>(k) + 1;
    }
    return data;
}

py::dict table_to_dict(std::unique_ptr<TabulatedBrdf> table) {
    TabulatedBrdf* t = table.release();
    py::capsule owner(t, [](void* p) { delete static_cast<TabulatedBrdf*>(p); });
    const TableGrid& g = t->grid();
    const py::ssize_t h = g.n_theta_h, dd = g.n_theta_d, p = g.n_phi_d;
    // raw() is the file's layout: channel blocks, each in flat order i_p + n_p (i_d + n_d i_h).
    py::array_t<double> raw({py::ssize_t{3}, h, dd, p}, t->raw().data(), owner);
    py::detail::array_proxy(raw.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    py::array_t<bool> valid({h, dd, p});
    bool* v = valid.mutable_data();
    for (std::size_t k = 0; k < g.size(); ++k) {
        v[k] = t->bin_valid(k);
    }
    py::array_t<double> scale(3);
    for (int c = 0; c < 3; ++c) {
        scale.mutable_data()[c] = t->scale()[static_cast<std::size_t>(c)];
    }
    py::dict out;
    out["kind"] = "table";
    out["source"] = t->source();
    out["grid"] = py::make_tuple(g.n_theta_h, g.n_theta_d, g.n_phi_d);
    out["scale"] = scale;
    out["raw"] = raw;
    out["valid"] = valid;
    return out;
}

py::dict load(const py::object& path_obj, bool samples, bool keep_going) {
    std::string path;
    if (!as_path(path_obj, path)) {
        throw GonioError("load: expected a path (str or os.PathLike)");
    }
    if (keep_going && !gonio::ends_with(path, ".csv")) {
        throw GonioError("load: keep_going applies to dataset CSV files only (" + path +
                         " is read whole or refused)");
    }
    if (gonio::brdf::is_table_path(path) && !samples) {
        auto t = value_or_raise(gonio::brdf::read_table_file(path));
        return table_to_dict(std::make_unique<TabulatedBrdf>(std::move(t)));
    }
    std::unique_ptr<Dataset> data;
    {
        py::gil_scoped_release release;
        gonio::brdf::DatasetReadOptions csv;
        csv.keep_going = keep_going;
        auto d = gonio::brdf::load_samples(path, csv);
        if (d) {
            data = std::make_unique<Dataset>(std::move(*d));
        } else {
            py::gil_scoped_acquire acquire;
            throw GonioError(d.error().message);
        }
    }
    return dataset_to_dict(std::move(data));
}

/// Through AtomicFile: a link planted at the temporary or final name is never followed, and a
/// failed write leaves the previous file and no debris.
void write_text_atomically(const std::string& path, const std::string& text) {
    ok_or_raise(gonio::write_file_atomic(path, text));
}

void save(const py::object& path_obj, const py::object& data) {
    std::string path;
    if (!as_path(path_obj, path)) {
        throw GonioError("save: expected a path (str or os.PathLike)");
    }
    if (gonio::brdf::is_table_path(path)) {
        if (py::isinstance<py::dict>(data) &&
            is_table_dict(py::reinterpret_borrow<py::dict>(data))) {
            ok_or_raise(gonio::brdf::write_merl(
                path, table_from_dict(py::reinterpret_borrow<py::dict>(data))));
            return;
        }
        if (py::isinstance<py::dict>(data) &&
            is_samples_dict(py::reinterpret_borrow<py::dict>(data))) {
            const Dataset d = dataset_from_dict(py::reinterpret_borrow<py::dict>(data));
            value_or_raise(gonio::brdf::export_merl(path, d));
            return;
        }
        const std::unique_ptr<Brdf> brdf = brdf_from(data);
        py::gil_scoped_release release;
        auto r = gonio::brdf::export_merl(path, *brdf);
        if (!r) {
            py::gil_scoped_acquire acquire;
            throw GonioError(r.error().message);
        }
        return;
    }
    if (ends_with(path, ".csv")) {
        if (!py::isinstance<py::dict>(data) ||
            !is_samples_dict(py::reinterpret_borrow<py::dict>(data))) {
            throw GonioError(
                path + ": a *.csv takes a samples dict (theta_i, phi_i, theta_o, phi_o, value)");
        }
        ok_or_raise(gonio::brdf::write_dataset_csv(
            path, dataset_from_dict(py::reinterpret_borrow<py::dict>(data))));
        return;
    }
    if (ends_with(path, ".json")) {
        if (!py::isinstance<py::dict>(data)) {
            throw GonioError(path + ": a *.json takes a model dict (docs/model-schema.md)");
        }
        auto model = value_or_raise(gonio::brdf::parse_model_json(to_json_text(data), path));
        write_text_atomically(path, gonio::brdf::model_to_json(model) + "\n");
        return;
    }
    throw GonioError(path +
                     ": unknown file type (expected *.csv samples, *.json model, or a table "
                     "*.binary, *.merl, *.gtab)");
}

py::dict tabulate(const py::object& model, const std::vector<int>& grid) {
    if (grid.size() != 3 || grid[0] <= 0 || grid[1] <= 0 || grid[2] <= 0 ||
        grid[0] > gonio::brdf::kMaxTableDim || grid[1] > gonio::brdf::kMaxTableDim ||
        grid[2] > gonio::brdf::kMaxTableDim) {
        throw GonioError("tabulate: grid must be three dimensions in [1, " +
                         std::to_string(gonio::brdf::kMaxTableDim) + "]");
    }
    const std::unique_ptr<Brdf> brdf = brdf_from(model);
    gonio::brdf::TabulateOptions options;
    options.grid = TableGrid{grid[0], grid[1], grid[2]};
    std::unique_ptr<TabulatedBrdf> table;
    {
        py::gil_scoped_release release;
        table = std::make_unique<TabulatedBrdf>(gonio::brdf::tabulate(*brdf, options));
    }
    return table_to_dict(std::move(table));
}

// ---- fit ------------------------------------------------------------------------------------

std::string option_text(const py::handle& v) {
    if (py::isinstance<py::bool_>(v)) {
        return v.cast<bool>() ? "true" : "false";
    }
    return py::str(v).cast<std::string>();
}

py::tuple fit(const py::object& samples,
              const py::object& model,
              const py::object& residual,
              const py::object& max_samples,
              const py::object& truth,
              const py::dict& options) {
    // Options left at None keep the fitting library's defaults (those of `gonio fit`); the one
    // request of every front end (batch::FitRequest), run by batch::run_fit.
    gonio::batch::FitRequest request;
    if (!residual.is_none()) {
        ok_or_raise(gonio::batch::set_option(request, "residual", option_text(residual)));
    }
    if (!max_samples.is_none()) {
        ok_or_raise(gonio::batch::set_option(request, "max_samples", option_text(max_samples)));
    }
    for (const auto& [k, v] : options) {
        ok_or_raise(
            gonio::batch::set_option(request, py::str(k).cast<std::string>(), option_text(v)));
    }
    std::string model_name;
    if (as_path(model, model_name)) {
        ok_or_raise(gonio::batch::set_option(request, "model", model_name));
    } else if (py::isinstance<py::dict>(model)) {
        // A fit template given inline: {"model": {...}, "free": [...], ...}.
        request.template_json = to_json_text(model);
    } else {
        throw GonioError(
            "model: expected a name (ggx, beckmann, blinn-phong, auto), a fit template path "
            "or a fit template dict");
    }
    if (auto c = gonio::batch::find_conflict(request)) {
        throw GonioError(
            c->option + " cannot be combined with model=" +
            (request.is_auto() ? std::string("\"auto\"") : std::string("<fit template>")) + ": " +
            c->rule);
    }
    value_or_raise(gonio::batch::make_fit_spec(request));
    Dataset data;
    std::string path;
    if (as_path(samples, path)) {
        py::gil_scoped_release release;
        auto d = gonio::brdf::load_samples(path);
        py::gil_scoped_acquire acquire;
        data = value_or_raise(std::move(d));
    } else if (py::isinstance<py::dict>(samples) &&
               is_table_dict(py::reinterpret_borrow<py::dict>(samples))) {
        data = gonio::brdf::table_to_dataset(
            table_from_dict(py::reinterpret_borrow<py::dict>(samples)));
    } else if (py::isinstance<py::dict>(samples) &&
               is_samples_dict(py::reinterpret_borrow<py::dict>(samples))) {
        data = dataset_from_dict(py::reinterpret_borrow<py::dict>(samples));
    } else {
        throw GonioError(
            "samples: expected a path, a samples dict or a table dict from gonio.load()");
    }
    std::optional<gonio::brdf::ModelD> ground_truth;
    if (!truth.is_none()) {
        std::string truth_path;
        if (as_path(truth, truth_path)) {
            ground_truth = value_or_raise(gonio::brdf::load_model_json(truth_path));
        } else {
            ground_truth =
                value_or_raise(gonio::brdf::parse_model_json(to_json_text(truth), "<truth>"));
        }
    }
    Expected<gonio::batch::FitRun> run = gonio::make_error("");
    {
        // Ceres runs without the GIL: other Python threads go on during the solve.
        py::gil_scoped_release release;
        run = gonio::batch::run_fit(data, request);
    }
    gonio::batch::FitRun r = value_or_raise(std::move(run));
    r.result.ground_truth = ground_truth;
    py::dict report = from_json_text(gonio::fitting::fit_report_json(r.result));
    // After model="auto" the report carries the ranking under "auto" (fit_report_json).
    return py::make_tuple(report["model"], report);
}

// ---- check, materials, manifests -----------------------------------------------------------

py::dict check(const py::object& model,
               std::uint64_t seed,
               int pairs,
               double reciprocity_tol,
               double isotropy_tol,
               double energy_tol) {
    if (pairs <= 0) {
        throw GonioError("check: pairs = " + std::to_string(pairs) + ": must be > 0");
    }
    for (const auto& [name, v] :
         {std::pair<const char*, double>{"reciprocity_tol", reciprocity_tol},
          {"isotropy_tol", isotropy_tol},
          {"energy_tol", energy_tol}}) {
        if (!std::isfinite(v) || v < 0) {
            throw GonioError(std::string("check: ") + name + " = " + std::to_string(v) +
                             ": must be finite and >= 0");
        }
    }
    const std::unique_ptr<Brdf> brdf = brdf_from(model);
    gonio::brdf::CheckOptions o;
    o.seed = seed;
    o.random_pairs = pairs;
    o.reciprocity_tolerance = reciprocity_tol;
    o.isotropy_tolerance = isotropy_tol;
    o.energy_tolerance = energy_tol;
    std::vector<gonio::brdf::CheckResult> results;
    {
        py::gil_scoped_release release;
        results = gonio::brdf::run_checks(*brdf, o);
    }
    py::list checks;
    for (const auto& c : results) {
        py::dict e;
        e["name"] = c.name;
        e["violation"] = c.violation;
        e["tolerance"] = c.tolerance;
        e["measure"] = c.measure;
        e["where"] = c.where;
        e["detail"] = c.detail;
        e["applicable"] = c.applicable;
        e["passed"] = c.passed;
        e["evaluations"] = c.evaluations;
        checks.append(e);
    }
    py::dict out;
    out["describe"] = brdf->describe();
    out["isotropic"] = brdf->isotropic();
    out["passed"] = gonio::brdf::all_passed(results);
    out["checks"] = checks;
    out["table"] = gonio::brdf::format_check_table(results);
    return out;
}

std::vector<std::string> materials(const py::object& library) {
    std::string path;
    if (library.is_none()) {
        path = value_or_raise(gonio::brdf::default_material_library());
    } else if (!as_path(library, path)) {
        throw GonioError("materials: library must be a path");
    }
    return value_or_raise(gonio::brdf::material_names(path));
}

py::dict material(const std::string& name) {
    const auto m = value_or_raise(gonio::brdf::load_material(name));
    return from_json_text(gonio::brdf::model_to_json(m));
}

py::list read_manifest(const std::string& path) {
    const auto entries = value_or_raise(gonio::batch::read_manifest(path));
    py::list out;
    for (const auto& e : entries) {
        py::dict d;
        d["index"] = e.index;
        d["line"] = e.line;
        d["id"] = e.id;
        d["input"] = e.input;
        d["options"] = gonio::batch::format_options(e.request);
        out.append(d);
    }
    return out;
}

py::dict outcome_to_dict(const gonio::batch::EntryOutcome& o) {
    py::dict d;
    d["id"] = o.id;
    d["input"] = o.input;
    d["status"] = gonio::batch::to_string(o.status);
    d["message"] = o.message;
    d["log_rmse"] = o.log_rmse;
    d["rel_rmse"] = o.rel_rmse;
    d["iterations"] = o.iterations;
    d["wall_time_s"] = o.wall_time_s;
    d["samples_used"] = o.samples_used;
    d["row"] = gonio::batch::summary_csv_row(o);
    return d;
}

py::dict run_entry(const std::string& id,
                   const std::string& input,
                   const std::string& options,
                   const std::string& out_dir) {
    gonio::batch::ManifestEntry e;
    e.id = id;
    e.input = input;
    gonio::batch::EntryOutcome o;
    auto s = gonio::batch::set_options(e.request, options);
    if (!s) {
        o.id = id;
        o.input = input;
        o.status = gonio::batch::EntryStatus::kFailed;
        o.message = s.error().message;
        return outcome_to_dict(o);
    }
    {
        py::gil_scoped_release release;
        o = gonio::batch::run_entry(e, out_dir);
    }
    return outcome_to_dict(o);
}

/// eval: from directions and from angles.
void def_eval(py::module_& m) {
    m.def("eval",
          &eval_dirs,
          py::arg("model"),
          py::arg("wi"),
          py::arg("wo"),
          R"doc(eval(model, wi, wo) -> numpy.ndarray (N x 3)

Evaluates a BRDF f(wi, wo) in 1/sr (r, g, b) for N direction pairs.

model: a dict in the model schema (docs/model-schema.md), a table dict from gonio.load(),
       a path (*.json model, *.binary/*.merl/*.gtab table) or "material:NAME".
wi, wo: N x 3 arrays of unit vectors in the local frame (z = normal); wi toward the light,
        wo toward the camera. A direction at or below the horizon gives 0.
A row with a non-unit or non-finite direction (or a non-finite BRDF value) gives a row of NaN
in its place, so that output row k answers input row k, and a UserWarning naming the row;
gonio.Error is raised only when no row can be evaluated.)doc");
    m.def("eval",
          &eval_angles,
          py::arg("model"),
          py::arg("theta_i"),
          py::arg("phi_i"),
          py::arg("theta_o"),
          py::arg("phi_o"),
          R"doc(eval(model, theta_i, phi_i, theta_o, phi_o) -> numpy.ndarray (N x 3)

The same from spherical angles in radians (1-D arrays of equal length N), exactly as
`gonio eval` computes them: theta in [0, pi], phi any finite value. A row outside those gives
a NaN row and a warning, as above.)doc");
}

/// load, save and tabulate: datasets, tables and models in files and as dicts.
void def_files(py::module_& m) {
    m.def("load",
          &load,
          py::arg("path"),
          py::arg("samples") = false,
          py::arg("keep_going") = false,
          R"doc(load(path, samples=False, keep_going=False) -> dict

A dataset CSV -> samples dict of read-only numpy views into the C++ dataset (no copy):
  theta_i, phi_i, theta_o, phi_o (N,), value (N, 3) 1/sr, sigma (N, 3), weight (N,),
  flags (N,) uint32, line (N,) source line numbers, has_sigma/has_weight/has_flags,
  rejected: [(line, reason)] for the rows refused with keep_going=True (empty otherwise),
  source, kind = "samples". Strict by default: the first bad row raises gonio.Error naming it;
  with keep_going=True a row with a field that is not a number, not finite or out of range, or
  with the wrong number of fields, is skipped and listed in rejected (more than 10000 such
  rows raise). keep_going applies to dataset CSV files only.
A table (*.binary, *.merl, *.gtab) -> table dict: raw (3, n_theta_h, n_theta_d, n_phi_d), the
  stored values as in the file (no copy; f = raw * scale per channel, raw < 0 = not measured),
  scale (3,), grid, valid (bool per bin), source, kind = "table". With samples=True, a table
  is returned as samples instead (one per valid bin centre above the horizon).
An RGL material (*.bsdf) -> samples dict of its stored nodes, each at its own direction pair
  (docs/file-formats-tables.md); no resampling.
Raises gonio.Error with the reader's message (file, line, field, rule).)doc");
    m.def("save",
          &save,
          py::arg("path"),
          py::arg("data"),
          R"doc(save(path, data) -> None

By extension: *.csv <- samples dict; *.json <- model dict (validated against the schema);
*.binary/*.merl/*.gtab <- table dict (bit-exact round trip), samples dict (resampled onto the
grid) or any model (tabulated at the bin centres). Files are written through a temporary file
and a rename.)doc");
    m.def("tabulate",
          &tabulate,
          py::arg("model"),
          py::arg("grid") = std::vector<int>{90, 90, 180},
          R"doc(tabulate(model, grid=(90, 90, 180)) -> table dict

Evaluates a BRDF at the bin centres of a half/difference grid (MERL's by default).)doc");
}

/// _fit (wrapped by gonio.fit) and check.
void def_fit_and_check(py::module_& m) {
    m.def("_fit",
          &fit,
          py::arg("samples"),
          py::arg("model"),
          py::arg("residual"),
          py::arg("max_samples"),
          py::arg("truth"),
          py::arg("options"));
    m.def("check",
          &check,
          py::arg("model"),
          py::arg("seed") = gonio::brdf::CheckOptions{}.seed,
          py::arg("pairs") = gonio::brdf::CheckOptions{}.random_pairs,
          py::arg("reciprocity_tol") = gonio::brdf::CheckOptions{}.reciprocity_tolerance,
          py::arg("isotropy_tol") = gonio::brdf::CheckOptions{}.isotropy_tolerance,
          py::arg("energy_tol") = gonio::brdf::CheckOptions{}.energy_tolerance,
          R"doc(check(model, seed=20261122, pairs=20000, reciprocity_tol=1e-6, isotropy_tol=1e-6,
      energy_tol=2e-3) -> dict

The checks of `gonio check`: non-negativity, reciprocity, isotropy, energy conservation.
Returns {"passed", "describe", "isotropic", "checks": [{"name", "violation", "tolerance",
"measure", "where", "detail", "applicable", "passed", "evaluations"}], "table"}.)doc");
}

/// The shipped material library.
void def_materials(py::module_& m) {
    m.def("materials",
          &materials,
          py::arg("library") = py::none(),
          "materials(library=None) -> list of str: names in the shipped material library.");
    m.def("material",
          &material,
          py::arg("name"),
          "material(name) -> dict: one shipped material's model (model schema).");
}

/// The batch runner's entry points (gonio.batch).
void def_batch(py::module_& m) {
    m.def("read_manifest",
          &read_manifest,
          py::arg("path"),
          "read_manifest(path) -> list of dict (index, line, id, input, options): a checked batch "
          "manifest (docs/scale-out.md).");
    m.def("run_entry",
          &run_entry,
          py::arg("id"),
          py::arg("input"),
          py::arg("options"),
          py::arg("out_dir"),
          "run_entry(id, input, options, out_dir) -> dict: fits one manifest entry into out_dir "
          "(as `gonio fit --manifest` does); status fitted, misfit, not-converged, failed or "
          "skipped.");
    m.def("summary_header", &gonio::batch::summary_csv_header, "Header line of a summary CSV.");
    m.def("write_text_atomically",
          &write_text_atomically,
          py::arg("path"),
          py::arg("text"),
          "Writes a text file through a temporary file and a rename, never following a link.");
}

}  // namespace

PYBIND11_MODULE(_gonio, m) {
    m.doc() = "gonio: BRDF evaluation, tables, datasets and Ceres fits (compiled core).";
    m.attr("__version__") = GONIO_VERSION_STRING;
    py::register_exception<GonioError>(m, "Error", PyExc_ValueError);
    def_eval(m);
    def_files(m);
    def_fit_and_check(m);
    def_materials(m);
    def_batch(m);
}
