// gonio convert IN OUT: between models, tables (MERL *.binary / *.merl, *.gtab) and sample CSVs.
//   MODEL.json or table -> table   evaluate at the bin centres (threads)
//   table or MODEL.json -> CSV     one sample per valid bin at its centre
//   CSV -> table                   kernel-weighted resampling; bins without data left invalid

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/brdf/table.h"

namespace {

using gonio::Expected;

struct ConvertOptions {
    std::string input;
    std::string output;
    std::string grid = "90x90x180";
    std::string interpolation = "nearest";
    unsigned threads = 0;
    double radius_bins = 1.5;
};

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// "AxBxC" -> grid; false on anything else.
bool parse_grid(const std::string& text, gonio::brdf::TableGrid* grid) {
    int a = 0, b = 0, c = 0;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%dx%dx%d%c", &a, &b, &c, &tail) != 3) {
        return false;
    }
    if (a < 1 || b < 1 || c < 1 || a > gonio::brdf::kMaxTableDim || b > gonio::brdf::kMaxTableDim ||
        c > gonio::brdf::kMaxTableDim) {
        return false;
    }
    *grid = gonio::brdf::TableGrid{a, b, c};
    return true;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int fail(const std::string& message) {
    std::fprintf(stderr, "gonio convert: %s\n", message.c_str());
    return 1;
}

int to_table(const ConvertOptions& o, const gonio::brdf::TableGrid& grid) {
    using namespace gonio::brdf;
    const auto t0 = std::chrono::steady_clock::now();
    if (ends_with(o.input, ".csv")) {
        Expected<Dataset> data = load_samples(o.input);
        if (!data) {
            return fail(data.error().message);
        }
        for (const RejectedRow& r : data->rejected) {
            std::fprintf(
                stderr, "%s:%zu: row skipped: %s\n", o.input.c_str(), r.line, r.reason.c_str());
        }
        ResampleOptions ro;
        ro.grid = grid;
        ro.radius_bins = o.radius_bins;
        Expected<ResampleReport> rep = export_merl(o.output, *data, ro);
        if (!rep) {
            return fail(rep.error().message);
        }
        std::printf(
            "%s: %zu samples (%zu rows rejected) -> %s: %zu of %zu bins filled, %zu bins without "
            "data within %g bins left invalid, %zu bins below the horizon (%.2f s)\n",
            o.input.c_str(),
            rep->samples_used,
            data->rejected.size(),
            o.output.c_str(),
            rep->filled_bins,
            rep->bins,
            rep->empty_bins,
            o.radius_bins,
            rep->below_horizon,
            seconds_since(t0));
        return 0;
    }
    Expected<std::unique_ptr<Brdf>> brdf = load_brdf(o.input);
    if (!brdf) {
        return fail(brdf.error().message);
    }
    if (!(*brdf)->isotropic()) {
        return fail(
            o.input +
            ": the BRDF is anisotropic; a half/difference table holds isotropic BRDFs only");
    }
    if (auto* table = dynamic_cast<TabulatedBrdf*>(brdf->get())) {
        table->set_interpolation(o.interpolation == "trilinear" ? Interpolation::kTrilinear
                                                                : Interpolation::kNearest);
    }
    TabulateOptions to;
    to.grid = grid;
    to.threads = o.threads;
    Expected<TabulateReport> rep = export_merl(o.output, **brdf, to);
    if (!rep) {
        return fail(rep.error().message);
    }
    std::printf(
        "%s -> %s: %zu of %zu bins valid, %zu bins below the horizon left invalid%s (%.2f s)\n",
        o.input.c_str(),
        o.output.c_str(),
        rep->valid_bins,
        rep->bins,
        rep->below_horizon,
        rep->non_finite > 0
            ? (", " + std::to_string(rep->non_finite) + " non-finite values left invalid").c_str()
            : "",
        seconds_since(t0));
    return rep->non_finite > 0 ? 1 : 0;
}

int to_csv(const ConvertOptions& o, const gonio::brdf::TableGrid& grid) {
    using namespace gonio::brdf;
    if (ends_with(o.input, ".csv")) {
        return fail(o.input + " -> " + o.output + ": both are sample CSVs, nothing to convert");
    }
    Dataset data;
    if (is_table_path(o.input)) {
        Expected<Dataset> d = load_samples(o.input);
        if (!d) {
            return fail(d.error().message);
        }
        data = std::move(*d);
    } else {
        Expected<std::unique_ptr<Brdf>> brdf = load_brdf(o.input);
        if (!brdf) {
            return fail(brdf.error().message);
        }
        TabulateOptions to;
        to.grid = grid;
        to.threads = o.threads;
        data = table_to_dataset(tabulate(**brdf, to));
        data.source = o.input;
    }
    Expected<void> w = write_dataset_csv(o.output, data);
    if (!w) {
        return fail(w.error().message);
    }
    std::printf("%s -> %s: %zu samples (one per valid bin above the horizon)\n",
                o.input.c_str(),
                o.output.c_str(),
                data.samples.size());
    return 0;
}

}  // namespace

GONIO_COMMAND(convert) {
    auto* cmd = app.add_subcommand(
        "convert",
        "Convert between models (*.json), tables (MERL *.binary/*.merl, *.gtab) and sample CSVs");
    auto opts = std::make_shared<ConvertOptions>();
    cmd->add_option("input", opts->input, "model JSON, table or sample CSV")->required();
    cmd->add_option("output", opts->output, "table (*.binary, *.merl, *.gtab) or sample CSV")
        ->required();
    cmd->add_option("--grid",
                    opts->grid,
                    "table resolution n_theta_h x n_theta_d x n_phi_d for *.gtab outputs and model "
                    "-> CSV (MERL outputs are always 90x90x180)")
        ->capture_default_str();
    cmd->add_option("--interpolation", opts->interpolation, "lookup of a table input")
        ->check(CLI::IsMember({"nearest", "trilinear"}))
        ->capture_default_str();
    cmd->add_option("--threads", opts->threads, "worker threads for tabulation (0 = all cores)")
        ->capture_default_str();
    cmd->add_option(
           "--radius",
           opts->radius_bins,
           "CSV -> table: kernel radius in bins; bins with no sample this close stay invalid")
        ->capture_default_str();
    return [opts]() -> int {
        gonio::brdf::TableGrid grid;
        if (!parse_grid(opts->grid, &grid)) {
            return fail("--grid " + opts->grid + ": expected AxBxC with each in [1, " +
                        std::to_string(gonio::brdf::kMaxTableDim) + "]");
        }
        if (gonio::brdf::is_table_path(opts->output)) {
            if (!ends_with(opts->output, ".gtab")) {
                grid = gonio::brdf::TableGrid::merl();
            }
            return to_table(*opts, grid);
        }
        if (ends_with(opts->output, ".csv")) {
            return to_csv(*opts, grid);
        }
        return fail(opts->output +
                    ": unknown output type (expected .binary, .merl, .gtab or .csv)");
    };
}
