// gonio convert IN OUT: between models, tables (MERL *.binary / *.merl, *.gtab) and sample CSVs.
//   MODEL.json or table -> table   evaluate at the bin centres (threads)
//   table or MODEL.json -> CSV     one sample per valid bin at its centre
//   CSV -> table                   kernel-weighted resampling; bins without data left invalid
//   MODEL.json or table -> *.bsdf  RGL material file: NDF by power iteration, VNDF warps, values
//   *.bsdf -> CSV                  the file's own nodes, one sample each (no resampling)

#include <CLI/CLI.hpp>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "command.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/brdf/table.h"
#include "option_checks.h"

namespace {

using gonio::ends_with;
using gonio::Expected;

struct ConvertOptions {
    std::string input;
    std::string output;
    std::string grid = "90x90x180";
    std::string interpolation = "nearest";
    unsigned threads = 0;
    unsigned phi_i = 0;  // RGL output: incident azimuths (0: as the input needs)
    double radius_bins = 1.5;
};

// "AxBxC" -> grid; false on anything else (signs, spaces, numbers past kMaxTableDim).
bool parse_grid(const std::string& text, gonio::brdf::TableGrid* grid) {
    long dims[3] = {0, 0, 0};
    const char* p = text.c_str();
    for (int a = 0; a < 3; ++a) {
        if (!std::isdigit(static_cast<unsigned char>(*p))) {
            return false;
        }
        char* end = nullptr;
        errno = 0;
        dims[a] = std::strtol(p, &end, 10);
        if (errno != 0 || dims[a] < 1 || dims[a] > gonio::brdf::kMaxTableDim) {
            return false;
        }
        p = end;
        if (a < 2) {
            if (*p != 'x') {
                return false;
            }
            ++p;
        }
    }
    if (*p != '\0') {
        return false;
    }
    *grid = gonio::brdf::TableGrid{
        static_cast<int>(dims[0]), static_cast<int>(dims[1]), static_cast<int>(dims[2])};
    return true;
}

// Bytes a table of the grid takes: three doubles and a validity flag per bin.
double table_bytes(const gonio::brdf::TableGrid& g) {
    return static_cast<double>(g.n_theta_h) * g.n_theta_d * g.n_phi_d * (3 * 8 + 1);
}

std::string grid_text(const gonio::brdf::TableGrid& g) {
    return std::to_string(g.n_theta_h) + "x" + std::to_string(g.n_theta_d) + "x" +
           std::to_string(g.n_phi_d);
}

// "N bins non-finite, M bins above 1e+12 1/sr": empty when the tabulation is clean.
std::string tabulate_problems(const gonio::brdf::TabulateReport& rep) {
    std::string out;
    if (rep.non_finite > 0) {
        out += std::to_string(rep.non_finite) + " bins where the model is not finite";
    }
    if (rep.out_of_range > 0) {
        out += out.empty() ? "" : ", ";
        out += std::to_string(rep.out_of_range) + " bins above the largest value a table stores (" +
               gonio::show_number(gonio::brdf::kMaxTableValue) + " 1/sr)";
    }
    return out;
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
    TabulateReport rep;
    const TabulatedBrdf table = tabulate(**brdf, to, &rep);
    if (const std::string bad = tabulate_problems(rep); !bad.empty()) {
        // Nothing is written: a table with holes the model did not ask for would pass as valid.
        return fail(o.input + ": " + bad + "; nothing written to " + o.output);
    }
    if (auto w = write_merl(o.output, table); !w) {
        return fail(w.error().message);
    }
    std::printf(
        "%s -> %s: %zu of %zu bins valid, %zu bins below the horizon left invalid (%.2f s)\n",
        o.input.c_str(),
        o.output.c_str(),
        rep.valid_bins,
        rep.bins,
        rep.below_horizon,
        seconds_since(t0));
    return 0;
}

int to_rgl(const ConvertOptions& o) {
    using namespace gonio::brdf;
    const auto t0 = std::chrono::steady_clock::now();
    Expected<std::unique_ptr<Brdf>> brdf = load_brdf(o.input);
    if (!brdf) {
        return fail(brdf.error().message);
    }
    if (auto* table = dynamic_cast<TabulatedBrdf*>(brdf->get())) {
        table->set_interpolation(o.interpolation == "trilinear" ? Interpolation::kTrilinear
                                                                : Interpolation::kNearest);
    }
    RglWriteOptions wo;
    wo.phi_i_count = o.phi_i;
    Expected<RglWriteReport> rep = write_rgl_bsdf(o.output, **brdf, wo);
    if (!rep) {
        return fail(rep.error().message);
    }
    const std::size_t azimuths = rgl_phi_i_count(**brdf, wo);
    const std::string kind =
        azimuths <= 1 ? std::string("isotropic")
                      : "anisotropic, " + std::to_string(azimuths) + " incident azimuths";
    std::printf(
        "%s -> %s: RGL material file (%s), NDF by power iteration (%d iterations, last change "
        "%.1e), %zu nodes (%zu below the horizon stored as 0), %zu bytes (%.2f s)\n",
        o.input.c_str(),
        o.output.c_str(),
        kind.c_str(),
        rep->ndf.iterations,
        rep->ndf.change,
        rep->nodes,
        rep->below_horizon,
        rep->bytes,
        seconds_since(t0));
    return 0;
}

int to_csv(const ConvertOptions& o, const gonio::brdf::TableGrid& grid) {
    using namespace gonio::brdf;
    if (ends_with(o.input, ".csv")) {
        return fail(o.input + " -> " + o.output + ": both are sample CSVs, nothing to convert");
    }
    Dataset data;
    if (is_table_path(o.input) || is_rgl_path(o.input)) {
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
        TabulateReport rep;
        const TabulatedBrdf table = tabulate(**brdf, to, &rep);
        if (const std::string bad = tabulate_problems(rep); !bad.empty()) {
            return fail(o.input + ": " + bad + "; nothing written to " + o.output);
        }
        data = table_to_dataset(table);
        data.source = o.input;
    }
    Expected<void> w = write_dataset_csv(o.output, data);
    if (!w) {
        return fail(w.error().message);
    }
    std::printf(is_rgl_path(o.input)
                    ? "%s -> %s: %zu samples (one per stored node above the horizon)\n"
                    : "%s -> %s: %zu samples (one per valid bin above the horizon)\n",
                o.input.c_str(),
                o.output.c_str(),
                data.samples.size());
    return 0;
}

/// An RGL *.bsdf output: its own parameterisation (no grid, threads or kernel radius), written
/// from a model or a table.
int run_rgl_output(const ConvertOptions& o, const CLI::App& cmd) {
    for (const char* name : {"--grid", "--threads", "--radius"}) {
        if (cmd.count(name) > 0) {
            return gonio::tools::usage_error(
                "convert", std::string(name) + " does not apply to an RGL *.bsdf output");
        }
    }
    if (cmd.count("--interpolation") > 0 && !gonio::brdf::is_table_path(o.input)) {
        return gonio::tools::usage_error("convert",
                                         "--interpolation does not apply to " + o.input + " -> " +
                                             o.output + ": only a table input is looked up");
    }
    if (ends_with(o.input, ".csv")) {
        return gonio::tools::usage_error(
            "convert",
            o.input + " -> " + o.output +
                ": an RGL file is written from a model or a table (resample the CSV to "
                "a table first)");
    }
    if (auto ok = gonio::check_output_path(o.output); !ok) {
        return fail(ok.error().message);
    }
    return to_rgl(o);
}

/// The options each conversion to a table or a CSV honours; the first given one it does not,
/// as "OPTION does not apply to IN -> OUT: why", or empty.
std::string refused_option(const ConvertOptions& o, const CLI::App& cmd, bool table_out) {
    const bool csv_in = ends_with(o.input, ".csv");
    const bool table_in = gonio::brdf::is_table_path(o.input);
    const bool stored_in = table_in || gonio::brdf::is_rgl_path(o.input);
    const bool merl_out = table_out && !ends_with(o.output, ".gtab");
    const char* refused = nullptr;
    std::string why;
    if (cmd.count("--grid") > 0 && merl_out) {
        refused = "--grid";
        why =
            "a MERL output (*.binary, *.merl) is always 90x90x180; write a *.gtab for "
            "another grid";
    } else if (cmd.count("--grid") > 0 && !table_out && stored_in) {
        refused = "--grid";
        why = "a stored file is written to CSV at its own bins or nodes";
    } else if (cmd.count("--interpolation") > 0 && (!table_in || !table_out)) {
        refused = "--interpolation";
        why = table_in ? "a table is written to CSV at its bin centres, without lookups"
                       : "only a table input is looked up";
    } else if (cmd.count("--threads") > 0 && (csv_in || stored_in) && !table_out) {
        refused = "--threads";
        why = "nothing is tabulated when a stored file is written to CSV";
    } else if (cmd.count("--threads") > 0 && csv_in) {
        refused = "--threads";
        why = "resampling a CSV onto a table runs on one thread";
    } else if (cmd.count("--radius") > 0 && !(csv_in && table_out)) {
        refused = "--radius";
        why = "the kernel radius is for resampling a sample CSV onto a table";
    }
    if (refused == nullptr) {
        return {};
    }
    return std::string(refused) + " does not apply to " + o.input + " -> " + o.output + ": " + why;
}

/// Memory: the table, and for CSV outputs up to one sample (about 150 bytes with its text) per
/// bin.
Expected<void> check_convert_memory(const ConvertOptions& o,
                                    const gonio::brdf::TableGrid& grid,
                                    bool table_out) {
    const bool csv_in = ends_with(o.input, ".csv");
    const bool grid_used =
        table_out || (!gonio::brdf::is_table_path(o.input) && !gonio::brdf::is_rgl_path(o.input));
    if (!grid_used) {
        return {};
    }
    // A table output is encoded into one buffer before it is written: twice the table.
    const double bytes = table_bytes(grid) * (csv_in ? 2.3 : 1.0) +
                         (table_out ? table_bytes(grid) : static_cast<double>(grid.size()) * 150);
    return gonio::check_memory(bytes, "convert to a " + grid_text(grid) + " grid");
}

int run_convert(const ConvertOptions& o, const CLI::App& cmd) {
    gonio::brdf::TableGrid grid;
    if (!parse_grid(o.grid, &grid)) {
        return gonio::tools::usage_error("convert",
                                         "--grid " + o.grid.substr(0, 64) +
                                             ": expected AxBxC with each in [1, " +
                                             std::to_string(gonio::brdf::kMaxTableDim) + "]");
    }
    const bool table_out = gonio::brdf::is_table_path(o.output);
    const bool rgl_out = gonio::brdf::is_rgl_path(o.output);
    if (!table_out && !rgl_out && !ends_with(o.output, ".csv")) {
        return gonio::tools::usage_error(
            "convert",
            o.output + ": unknown output type (expected .binary, .merl, .gtab, .bsdf or .csv)");
    }
    if (rgl_out) {
        return run_rgl_output(o, cmd);
    }
    if (cmd.count("--phi-i") > 0) {
        return gonio::tools::usage_error(
            "convert", "--phi-i applies to an RGL *.bsdf output only, not " + o.output);
    }
    if (const std::string refused = refused_option(o, cmd, table_out); !refused.empty()) {
        return gonio::tools::usage_error("convert", refused);
    }
    if (table_out && !ends_with(o.output, ".gtab")) {
        grid = gonio::brdf::TableGrid::merl();
    }
    // Refused before any work: an output that is a folder or a device, a missing folder.
    if (auto ok = gonio::check_output_path(o.output); !ok) {
        return fail(ok.error().message);
    }
    if (auto ok = check_convert_memory(o, grid, table_out); !ok) {
        return fail(ok.error().message);
    }
    return table_out ? to_table(o, grid) : to_csv(o, grid);
}

void add_convert_options(CLI::App* cmd, ConvertOptions* opts) {
    cmd->add_option("input", opts->input, "model JSON, table or sample CSV")
        ->required()
        ->check(gonio::tools::readable_input());
    cmd->add_option("output",
                    opts->output,
                    "table (*.binary, *.merl, *.gtab), RGL material (*.bsdf) or sample CSV")
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
        ->check(gonio::tools::integer_in(0, 1024))
        ->capture_default_str();
    cmd->add_option(
           "--radius",
           opts->radius_bins,
           "CSV -> table: kernel radius in bins; bins with no sample this close stay invalid")
        ->check(gonio::tools::finite_in(1e-3, 16, "bins"))
        ->capture_default_str();
    cmd->add_option("--phi-i",
                    opts->phi_i,
                    "RGL output: incident azimuths (0 = as the input needs: an isotropic file for "
                    "an isotropic input, 16 azimuths for an anisotropic one; 1 = isotropic; 2-360 "
                    "= an anisotropic file with that many)")
        ->check(gonio::tools::integer_in(0, 360))
        ->capture_default_str();
}

}  // namespace

GONIO_COMMAND(convert) {
    auto* cmd = app.add_subcommand(
        "convert",
        "convert between models (*.json), tables (MERL *.binary/*.merl, *.gtab), RGL materials "
        "(*.bsdf) and sample CSVs");
    auto opts = std::make_shared<ConvertOptions>();
    add_convert_options(cmd, opts.get());
    return [opts, cmd_ptr = cmd]() -> int { return run_convert(*opts, *cmd_ptr); };
}
