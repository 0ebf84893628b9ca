// gonio plot: pictures of a dataset and of a fit.

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/report/plot.h"
#include "option_checks.h"

namespace {

struct Options {
    std::string data;
    std::string fit;
    std::string out = "plots";
    bool log = false;
    std::string scale = "auto";
    int width = 800;
    std::vector<double> theta_i_deg;
};

/// --theta-i is in degrees: values that all lie below pi/2 with a fraction among them (0.52) were
/// most likely written in radians; the command says so and what they would be in degrees.
void radians_warning(const std::vector<double>& theta_i_deg) {
    constexpr double kHalfPi = 1.5707963267948966;
    bool all_small = !theta_i_deg.empty();
    bool fraction = false;
    std::string as_deg;
    for (double t : theta_i_deg) {
        all_small = all_small && t <= kHalfPi;
        fraction = fraction || t != std::floor(t);
        char buf[32];
        std::snprintf(buf, sizeof buf, "%s%.4g", as_deg.empty() ? "" : ",", t * 90 / kHalfPi);
        as_deg += buf;
    }
    if (all_small && fraction) {
        std::fprintf(stderr,
                     "gonio plot: warning: --theta-i is in degrees; every value given is below "
                     "pi/2 with a fraction, as radians would be (in degrees: --theta-i %s)\n",
                     as_deg.c_str());
    }
}

}  // namespace

GONIO_COMMAND(plot) {
    auto* cmd = app.add_subcommand("plot",
                                   "draw polar in-plane slices, delta_phi slices and (with --fit) "
                                   "residual maps, as PNG files");
    auto opts = std::make_shared<Options>();
    cmd->add_option("data",
                    opts->data,
                    "dataset CSV, table (*.binary, *.merl, *.gtab) or RGL material (*.bsdf)")
        ->required()
        ->check(gonio::tools::readable_input());
    cmd->add_option("--fit", opts->fit, "fitted model (fit.json) or table drawn over the data")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--out", opts->out, "output folder (created if missing)")
        ->capture_default_str();
    cmd->add_option("--scale",
                    opts->scale,
                    "BRDF axis: auto (log when the data span more than a decade), linear, log")
        ->check(CLI::IsMember({"auto", "linear", "log"}))
        ->capture_default_str();
    cmd->add_flag("--log", opts->log, "logarithmic BRDF axis (same as --scale log)");
    cmd->add_option("--width", opts->width, "picture width in pixels (>= 400)")
        ->capture_default_str()
        ->check(CLI::Range(400, 4000));
    cmd->add_option("--theta-i", opts->theta_i_deg, "incidence angles of the in-plane slices, deg")
        ->delimiter(',')
        ->check(gonio::tools::finite_in(0, 89.9, "deg"));
    return [opts]() -> int {
        radians_warning(opts->theta_i_deg);
        auto data = gonio::brdf::load_samples(opts->data);
        if (!data) {
            std::fprintf(stderr, "gonio plot: %s\n", data.error().message.c_str());
            return 1;
        }
        std::unique_ptr<gonio::brdf::Brdf> fit;
        if (!opts->fit.empty()) {
            auto loaded = gonio::brdf::load_brdf(opts->fit);
            if (!loaded) {
                std::fprintf(stderr, "gonio plot: %s\n", loaded.error().message.c_str());
                return 1;
            }
            fit = std::move(*loaded);
        }
        gonio::report::PlotOptions po;
        if (opts->log && opts->scale == "linear") {
            std::fprintf(stderr, "gonio plot: --log contradicts --scale linear\n");
            return 2;
        }
        po.scale = opts->log || opts->scale == "log" ? gonio::report::AxisScale::kLog
                   : opts->scale == "linear"         ? gonio::report::AxisScale::kLinear
                                                     : gonio::report::AxisScale::kAuto;
        po.width = opts->width;
        po.theta_i_deg = opts->theta_i_deg;
        // Drift-reference rows re-measure one configuration; they are not plotted as samples.
        auto set = gonio::report::write_plots(
            gonio::report::without_reference_rows(*data), fit.get(), po, opts->out);
        if (!set) {
            std::fprintf(stderr, "gonio plot: %s\n", set.error().message.c_str());
            return 1;
        }
        for (const auto& s : set->skipped) {
            std::fprintf(stderr, "gonio plot: skipped %s\n", s.c_str());
        }
        for (const auto& w : set->warnings) {
            std::fprintf(stderr, "gonio plot: warning: %s\n", w.c_str());
        }
        for (const auto& w : set->written) {
            std::printf("%s\n", w.path.c_str());
        }
        return 0;
    };
}
