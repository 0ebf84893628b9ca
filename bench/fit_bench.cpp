// Run time against error of `gonio fit`: three real materials (published Lambert + Cook-Torrance
// fits of MERL measurements, data/materials/ngan2005.json) tabulated on the full 90 x 90 x 180
// MERL grid with 3 % multiplicative Gaussian measurement noise (seeded), fitted with the
// materials' own structure (Lambert + Beckmann, V-groove, scalar Schlick f0, RGB scale) at sample
// budgets of 1k, 5k, 20k, 100k and the full table, for three residual forms; plus the default
// model (GGX + Lambert + Schlick RGB) on the full table.
//
// Each row: samples used, wall time of the whole fit (reduction, initialisation, solve,
// covariance, metrics), the largest relative parameter error against the ground truth and against
// the full-table fit, and the RMSE against the full (noisy) table.
//
//   gonio_fit_bench [--csv=fit_bench.csv] [--png=fit_bench.png] [google-benchmark flags]

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/resample.h"
#include "gonio/fitting/cost.h"
#include "gonio/fitting/fit.h"

namespace {

namespace fitting = gonio::fitting;
namespace brdf = gonio::brdf;

struct Material {
    const char* label;
    const char* name;
};
const Material kMaterials[] = {
    {"rough plastic", "red-plastic"},
    {"glossy paint", "white-paint"},
    {"near-mirror metal", "chrome"},
};
const std::size_t kBudgets[] = {0, 100000, 20000, 5000, 1000};  // 0 = full table (run first)
const fitting::ResidualForm kForms[] = {
    fitting::ResidualForm::kLog, fitting::ResidualForm::kCosine, fitting::ResidualForm::kCubeRoot};

struct Row {
    std::string material, model, residual;
    std::size_t budget = 0, used = 0;
    double wall_s = 0, solve_s = 0, param_err_truth = 0, param_err_full = 0, rmse = 0, log_rmse = 0;
    int iterations = 0;
    bool usable = false;
};
std::vector<Row> g_rows;

struct Prepared {
    brdf::ModelD truth;
    brdf::Dataset data;
};

brdf::ModelD load_material(const std::string& name) {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/materials/ngan2005.json");
    std::stringstream ss;
    ss << in.rdbuf();
    const nlohmann::json j = nlohmann::json::parse(ss.str());
    auto m = brdf::parse_model_json(j.at("materials").at(name).dump(), name);
    if (!m) {
        std::fprintf(stderr, "%s\n", m.error().message.c_str());
        std::exit(1);
    }
    return *m;
}

const Prepared& prepared(const std::string& name) {
    static std::map<std::string, std::unique_ptr<Prepared>> cache;
    auto it = cache.find(name);
    if (it != cache.end()) {
        return *it->second;
    }
    cache.clear();  // one table in memory at a time
    auto p = std::make_unique<Prepared>();
    p->truth = load_material(name);
    const brdf::TabulatedBrdf table = brdf::tabulate(*brdf::make_analytic_brdf(p->truth));
    p->data = brdf::table_to_dataset(table);
    std::mt19937_64 rng(1);
    std::normal_distribution<double> n01(0.0, 1.0);
    for (brdf::Sample& s : p->data.samples) {
        for (int c = 0; c < 3; ++c) {
            s.value[c] = std::max(0.0, s.value[c] * (1 + 0.03 * n01(rng)));
        }
    }
    return *cache.emplace(name, std::move(p)).first->second;
}

/// The spec of the materials' structure: Beckmann, V-groove, scalar Schlick f0, RGB scale.
fitting::FitSpec truth_spec() {
    fitting::ModelOptions mo;
    mo.distribution = brdf::Distribution::kBeckmann;
    mo.shadowing = brdf::Shadowing::kVGroove;
    mo.fresnel_rgb = false;
    return *fitting::make_fit_spec(mo);
}

double max_rel_error(const fitting::FitSpec& spec, const brdf::ModelD& a, const brdf::ModelD& b) {
    const fitting::ParameterMap map = *fitting::ParameterMap::make(spec);
    double e = 0;
    for (const fitting::ScalarParam& s : map.scalars()) {
        if (s.free) {
            const double ref = map.value_of(b, s);
            e = std::max(e, std::abs(map.value_of(a, s) - ref) / std::abs(ref));
        }
    }
    return e;
}

std::map<std::string, brdf::ModelD> g_full_fits;

void run(benchmark::State& state,
         const Material& mat,
         std::size_t budget,
         fitting::ResidualForm form,
         bool default_model) {
    const Prepared& p = prepared(mat.name);
    fitting::FitSpec spec = default_model ? *fitting::make_fit_spec({}) : truth_spec();
    spec.options.residual = form;
    spec.options.max_samples = budget;
    fitting::FitResult r;
    for (auto _ : state) {
        r = *fitting::fit(p.data, spec);
    }
    Row row;
    row.material = mat.label;
    row.model = default_model ? "ggx+lambert" : "beckmann+lambert";
    row.residual = fitting::to_string(form);
    row.budget = budget;
    row.used = r.samples.used;
    row.wall_s = r.solver.wall_time_s;
    row.solve_s = r.solver.solve_time_s;
    row.iterations = r.solver.iterations;
    row.usable = r.usable();
    row.rmse = r.metrics.rmse.mean();
    row.log_rmse = r.metrics.log_rmse.mean();
    const std::string key = std::string(mat.name) + "/" + row.residual;
    if (!default_model) {
        row.param_err_truth = max_rel_error(spec, r.model, p.truth);
        if (budget == 0) {
            g_full_fits[key] = r.model;
        }
        row.param_err_full =
            g_full_fits.count(key) ? max_rel_error(spec, r.model, g_full_fits[key]) : std::nan("");
    } else {
        row.param_err_truth = row.param_err_full = std::nan("");
    }
    state.counters["used"] = static_cast<double>(row.used);
    state.counters["fit_s"] = row.wall_s;
    state.counters["solve_s"] = row.solve_s;
    state.counters["iters"] = row.iterations;
    state.counters["param_err_truth"] = row.param_err_truth;
    state.counters["param_err_full"] = row.param_err_full;
    state.counters["rmse_full"] = row.rmse;
    state.counters["usable"] = row.usable ? 1 : 0;
    g_rows.push_back(row);
}

void write_csv(const std::string& path) {
    std::ofstream out(path);
    out << "material,model,residual,budget,samples_used,wall_time_s,solve_time_s,iterations,param_"
           "err_vs_truth,"
           "param_err_vs_full_fit,rmse_vs_full,log_rmse_vs_full,usable\n";
    for (const Row& r : g_rows) {
        out << r.material << "," << r.model << "," << r.residual << ","
            << (r.budget == 0 ? std::string("full") : std::to_string(r.budget)) << "," << r.used
            << "," << r.wall_s << "," << r.solve_s << "," << r.iterations << ","
            << r.param_err_truth << "," << r.param_err_full << "," << r.rmse << "," << r.log_rmse
            << "," << (r.usable ? 1 : 0) << "\n";
    }
}

/// Log-log scatter of wall time (x) against parameter error vs truth (y), one colour per
/// material, one marker per residual form.
void write_png(const std::string& path) {
    const int w = 900, h = 600, left = 90, right = 220, top = 40, bottom = 70;
    cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
    const double x0 = -3, x1 = 2, y0 = -6, y1 = 0;  // log10 s, log10 error
    auto px = [&](double t) {
        return left + static_cast<int>((std::log10(t) - x0) / (x1 - x0) * (w - left - right));
    };
    auto py = [&](double e) {
        return h - bottom - static_cast<int>((std::log10(e) - y0) / (y1 - y0) * (h - top - bottom));
    };
    cv::rectangle(img, {left, top}, {w - right, h - bottom}, cv::Scalar(0, 0, 0));
    for (int d = static_cast<int>(x0); d <= static_cast<int>(x1); ++d) {
        const int x = px(std::pow(10.0, d));
        cv::line(img, {x, top}, {x, h - bottom}, cv::Scalar(220, 220, 220));
        cv::putText(img,
                    "1e" + std::to_string(d),
                    {x - 15, h - bottom + 20},
                    cv::FONT_HERSHEY_SIMPLEX,
                    0.45,
                    cv::Scalar(0, 0, 0));
    }
    for (int d = static_cast<int>(y0); d <= static_cast<int>(y1); ++d) {
        const int y = py(std::pow(10.0, d));
        cv::line(img, {left, y}, {w - right, y}, cv::Scalar(220, 220, 220));
        cv::putText(img,
                    "1e" + std::to_string(d),
                    {left - 45, y + 5},
                    cv::FONT_HERSHEY_SIMPLEX,
                    0.45,
                    cv::Scalar(0, 0, 0));
    }
    cv::putText(img,
                "wall time of the fit (s)",
                {left + 200, h - 25},
                cv::FONT_HERSHEY_SIMPLEX,
                0.55,
                cv::Scalar(0, 0, 0));
    cv::putText(img,
                "max relative parameter error vs ground truth",
                {left, top - 15},
                cv::FONT_HERSHEY_SIMPLEX,
                0.55,
                cv::Scalar(0, 0, 0));
    const cv::Scalar colours[] = {{40, 40, 200}, {40, 160, 40}, {200, 80, 40}};
    for (std::size_t m = 0; m < 3; ++m) {
        cv::circle(
            img, {w - right + 20, top + 20 + 22 * static_cast<int>(m)}, 5, colours[m], cv::FILLED);
        cv::putText(img,
                    kMaterials[m].label,
                    {w - right + 32, top + 25 + 22 * static_cast<int>(m)},
                    cv::FONT_HERSHEY_SIMPLEX,
                    0.45,
                    cv::Scalar(0, 0, 0));
    }
    const char* forms[] = {"o log", "[] cosine", "+ cbrt"};
    for (int f = 0; f < 3; ++f) {
        cv::putText(img,
                    forms[f],
                    {w - right + 20, top + 110 + 22 * f},
                    cv::FONT_HERSHEY_SIMPLEX,
                    0.45,
                    cv::Scalar(0, 0, 0));
    }
    for (const Row& r : g_rows) {
        if (!(r.param_err_truth > 0) || !std::isfinite(r.param_err_truth)) {
            continue;
        }
        std::size_t m = 0;
        for (std::size_t k = 0; k < 3; ++k) {
            if (r.material == kMaterials[k].label) {
                m = k;
            }
        }
        const cv::Point c(px(std::max(r.wall_s, 1e-3)),
                          py(std::min(1.0, std::max(r.param_err_truth, 1e-6))));
        if (r.residual == "log") {
            cv::circle(img, c, 5, colours[m], 2);
        } else if (r.residual == "cosine") {
            cv::rectangle(img, c - cv::Point(4, 4), c + cv::Point(4, 4), colours[m], 2);
        } else {
            cv::drawMarker(img, c, colours[m], cv::MARKER_CROSS, 10, 2);
        }
    }
    cv::imwrite(path, img);
}

}  // namespace

int main(int argc, char** argv) {
    std::string csv = "fit_bench.csv";
    std::string png = "fit_bench.png";
    std::vector<char*> args;
    for (int i = 0; i < argc; ++i) {
        if (std::strncmp(argv[i], "--csv=", 6) == 0) {
            csv = argv[i] + 6;
        } else if (std::strncmp(argv[i], "--png=", 6) == 0) {
            png = argv[i] + 6;
        } else {
            args.push_back(argv[i]);
        }
    }
    int n = static_cast<int>(args.size());
    for (const Material& mat : kMaterials) {
        for (fitting::ResidualForm form : kForms) {
            for (std::size_t budget : kBudgets) {
                const std::string name = std::string("fit/") + mat.name + "/" +
                                         fitting::to_string(form) + "/" +
                                         (budget == 0 ? "full" : std::to_string(budget));
                benchmark::RegisterBenchmark(name.c_str(), run, mat, budget, form, false)
                    ->Iterations(1)
                    ->Unit(benchmark::kMillisecond);
            }
        }
        benchmark::RegisterBenchmark(
            (std::string("fit/") + mat.name + "/ggx+lambert/log/full").c_str(),
            run,
            mat,
            std::size_t{0},
            fitting::ResidualForm::kLog,
            true)
            ->Iterations(1)
            ->Unit(benchmark::kMillisecond);
    }
    benchmark::Initialize(&n, args.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    write_csv(csv);
    write_png(png);
    std::printf("wrote %s and %s\n", csv.c_str(), png.c_str());
    return 0;
}
