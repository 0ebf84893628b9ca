// gonio export: a fitted model (or data) for renderers: Mitsuba 3, pbrt-v4, Blender, MERL binary.

#include <CLI/CLI.hpp>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <memory>

#include "command.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/resample.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/brdf/table.h"
#include "gonio/report/blender_export.h"
#include "gonio/report/export.h"
#include "option_checks.h"

namespace {

using gonio::ends_with;

struct Options {
    std::string input;
    std::string to;
    std::string out;
    std::string out_positional;
    std::string name = "gonio_fit";
    bool name_given = false;
    bool approximate = false;
};

int write_text(const std::string& path, const std::string& text) {
    if (path.empty() || path == "-") {
        std::fwrite(text.data(), 1, text.size(), stdout);
        return 0;
    }
    if (auto w = gonio::write_file_atomic(path, text); !w) {
        std::fprintf(stderr, "gonio export: %s\n", w.error().message.c_str());
        return 1;
    }
    std::printf("%s\n", path.c_str());
    return 0;
}

/// The material name by default for Blender: the input's file name without its folder and its
/// last extension, other characters than letters, digits, '_', '-', '.' replaced by '_'.
std::string name_from_input(const std::string& input) {
    std::string stem = input.substr(input.find_last_of('/') + 1);
    if (const std::size_t dot = stem.rfind('.'); dot != std::string::npos && dot > 0) {
        stem.resize(dot);
    }
    for (char& c : stem) {
        const unsigned char u = static_cast<unsigned char>(c);
        if (!(std::isalnum(u) || c == '_' || c == '-' || c == '.')) {
            c = '_';
        }
    }
    return stem.empty() ? std::string("gonio_fit") : stem.substr(0, 128);
}

/// --to blender: exit 2 for a term Blender cannot represent (or a name not allowed).
int export_blender(const Options& o, const std::string& out) {
    auto model = gonio::brdf::load_model_json(o.input);
    if (!model) {
        std::fprintf(stderr, "gonio export: %s\n", model.error().message.c_str());
        return 1;
    }
    gonio::report::BlenderExportOptions bo;
    bo.name = o.name_given ? o.name : name_from_input(o.input);
    bo.approximate = o.approximate;
    auto result = gonio::report::export_blender(*model, bo);
    if (!result) {
        std::fprintf(
            stderr, "gonio export: %s: %s\n", o.input.c_str(), result.error().message.c_str());
        return result.error().refused ? 2 : 1;
    }
    for (const std::string& n : result->approximations) {
        std::fprintf(stderr, "gonio export: approximated: %s\n", n.c_str());
    }
    return write_text(out, result->text);
}

/// --to merl from a dataset CSV: the samples binned, bins without data marked not measured.
int export_merl_from_samples(const Options& o, const std::string& out) {
    auto data = gonio::brdf::load_samples(o.input);
    if (!data) {
        std::fprintf(stderr, "gonio export: %s\n", data.error().message.c_str());
        return 1;
    }
    auto rep = gonio::brdf::export_merl(out, *data);
    if (!rep) {
        std::fprintf(stderr, "gonio export: %s\n", rep.error().message.c_str());
        return 1;
    }
    std::fprintf(stderr,
                 "gonio export: %zu samples into %zu bins filled, %zu bins left "
                 "without data (marked not measured)\n",
                 rep->samples_used,
                 rep->filled_bins,
                 rep->empty_bins);
    return 0;
}

/// --to merl from a model or a table: tabulated on the MERL grid.
int export_merl_from_brdf(const Options& o, const std::string& out) {
    auto brdf = gonio::brdf::load_brdf(o.input);
    if (!brdf) {
        std::fprintf(stderr, "gonio export: %s\n", brdf.error().message.c_str());
        return 1;
    }
    gonio::brdf::TabulateReport rep;
    const gonio::brdf::TabulatedBrdf table =
        gonio::brdf::tabulate(**brdf, gonio::brdf::TabulateOptions{}, &rep);
    if (rep.non_finite > 0 || rep.out_of_range > 0) {
        // Nothing written: holes the model did not ask for would pass as valid bins.
        std::fprintf(stderr,
                     "gonio export: %s: %zu bins where the model is not finite, %zu "
                     "above %s 1/sr; nothing written\n",
                     o.input.c_str(),
                     rep.non_finite,
                     rep.out_of_range,
                     gonio::show_number(gonio::brdf::kMaxTableValue).c_str());
        return 1;
    }
    if (auto w = gonio::brdf::write_merl(out, table); !w) {
        std::fprintf(stderr, "gonio export: %s\n", w.error().message.c_str());
        return 1;
    }
    return 0;
}

int export_merl(const Options& o, const std::string& out) {
    if (out.empty()) {
        std::fprintf(stderr, "gonio export: --to merl needs an output file (*.binary)\n");
        return 2;
    }
    const int rc = gonio::ends_with(o.input, ".csv") ? export_merl_from_samples(o, out)
                                                     : export_merl_from_brdf(o, out);
    if (rc != 0) {
        return rc;
    }
    std::printf("%s\n", out.c_str());
    return 0;
}

/// --to mitsuba or pbrt: the approximations said, a misfit's verdict carried into the file.
int export_renderer(const Options& o, const std::string& out) {
    auto model = gonio::brdf::load_model_json(o.input);
    if (!model) {
        std::fprintf(stderr, "gonio export: %s\n", model.error().message.c_str());
        return 1;
    }
    auto result = o.to == "mitsuba" ? gonio::report::export_mitsuba(*model, o.name)
                                    : gonio::report::export_pbrt(*model, o.name);
    if (!result) {
        std::fprintf(
            stderr, "gonio export: %s: %s\n", o.input.c_str(), result.error().message.c_str());
        return 1;
    }
    for (const std::string& n : result->approximations) {
        std::fprintf(stderr, "gonio export: not exact: %s\n", n.c_str());
    }
    // A misfit's verdict travels with the material (into the file) and is said here.
    auto verdict = gonio::report::read_model_verdict(o.input);
    if (verdict && *verdict && (*verdict)->verdict != "represents") {
        std::fprintf(stderr,
                     "gonio export: warning: %s: the fit's verdict is \"%s\": the exported "
                     "material reproduces that fit, not the measurement (the verdict is "
                     "written into %s)\n",
                     o.input.c_str(),
                     (*verdict)->headline.c_str(),
                     out.empty() || out == "-" ? "the output" : out.c_str());
        result->text = gonio::report::with_verdict(result->text, **verdict, o.to == "mitsuba");
    }
    return write_text(out, result->text);
}

int run_export(const Options& o) {
    if (o.approximate && o.to != "blender") {
        std::fprintf(stderr,
                     "gonio export: --approximate applies to --to blender only (--to %s "
                     "states its approximations in the file)\n",
                     o.to.c_str());
        return 2;
    }
    if (!o.out.empty() && !o.out_positional.empty() && o.out != o.out_positional) {
        std::fprintf(stderr,
                     "gonio export: two outputs named: out_file %s and --out %s (give one)\n",
                     o.out_positional.c_str(),
                     o.out.c_str());
        return 2;
    }
    const std::string out = !o.out.empty() ? o.out : o.out_positional;
    if (!out.empty() && out != "-") {
        // Refused before any work: a folder, a device, a missing folder.
        if (auto ok = gonio::check_output_path(out); !ok) {
            std::fprintf(stderr, "gonio export: %s\n", ok.error().message.c_str());
            return 1;
        }
    }
    if (o.to == "merl") {
        return export_merl(o, out);
    }
    if (o.to == "blender") {
        return export_blender(o, out);
    }
    return export_renderer(o, out);
}

}  // namespace

GONIO_COMMAND(export) {
    auto* cmd = app.add_subcommand(
        "export",
        "write a fitted model as a Mitsuba 3, pbrt-v4 or Blender material, or a MERL table");
    auto opts = std::make_shared<Options>();
    cmd->add_option(
           "input", opts->input, "model JSON (fit.json); for merl also a table or dataset CSV")
        ->required()
        ->check(gonio::tools::readable_input());
    cmd->add_option("out_file", opts->out_positional, "output file (same as --out)");
    cmd->add_option("--to", opts->to, "mitsuba | pbrt | blender | merl")
        ->required()
        ->check(CLI::IsMember({"mitsuba", "pbrt", "blender", "merl"}));
    cmd->add_option(
        "--out", opts->out, "output file (mitsuba, pbrt, blender: standard output when absent)");
    auto* name = cmd->add_option("--name",
                                 opts->name,
                                 "material id / name in the renderer file (blender: the input's "
                                 "file name without extension)")
                     ->capture_default_str();
    cmd->add_flag("--approximate",
                  opts->approximate,
                  "blender: write the terms Blender can only approximate (Blinn-Phong, conductor "
                  "Fresnel, ...), printing the measured difference; without it they are refused");
    return [opts, name]() -> int {
        opts->name_given = name->count() > 0;
        return run_export(*opts);
    };
}
