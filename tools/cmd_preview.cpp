// gonio preview: shaded spheres of one or two BRDFs.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "command.h"
#include "gonio/base/atomic_file.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/table.h"
#include "gonio/report/preview.h"
#include "option_checks.h"

namespace {

struct Options {
    std::string brdf;
    std::string vs;
    std::string out = "preview.png";
    int size = 256;
    int samples = 192;
};

/// False (with a message) for a table without a single valid bin: its spheres would be black.
/// A table with some invalid bins renders them black and says how many.
bool has_data(const gonio::brdf::Brdf& brdf, const std::string& path) {
    const auto* table = dynamic_cast<const gonio::brdf::TabulatedBrdf*>(&brdf);
    if (table == nullptr) {
        return true;
    }
    const gonio::brdf::TableStatistics st = table->compute_statistics();
    if (st.valid_bins == 0) {
        std::fprintf(stderr,
                     "gonio preview: %s: 0 of %zu bins valid; nothing to render\n",
                     path.c_str(),
                     st.bins);
        return false;
    }
    if (st.valid_bins < st.bins) {
        std::fprintf(stderr,
                     "gonio preview: %s: %zu of %zu bins invalid (not measured or below the "
                     "horizon); they contribute nothing (black)\n",
                     path.c_str(),
                     st.bins - st.valid_bins,
                     st.bins);
    }
    return true;
}

}  // namespace

GONIO_COMMAND(preview) {
    auto* cmd = app.add_subcommand(
        "preview", "render a sphere under a directional light and a sky/ground environment (PNG)");
    auto opts = std::make_shared<Options>();
    cmd->add_option(
           "brdf",
           opts->brdf,
           "model JSON (fit.json), table (*.binary, *.merl, *.gtab) or RGL material (*.bsdf)")
        ->required()
        ->check(gonio::tools::readable_input());
    cmd->add_option("--vs", opts->vs, "a second BRDF rendered below the first for comparison")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--out", opts->out, "output PNG")->capture_default_str();
    cmd->add_option("--size", opts->size, "sphere picture size in pixels")
        ->capture_default_str()
        ->check(CLI::Range(16, 2048));
    cmd->add_option("--samples", opts->samples, "environment directions per pixel")
        ->capture_default_str()
        ->check(CLI::Range(6, 65536));
    return [opts]() -> int {
        if (auto ok = gonio::check_output_path(opts->out); !ok) {
            std::fprintf(stderr, "gonio preview: %s\n", ok.error().message.c_str());
            return 1;
        }
        auto a = gonio::brdf::load_brdf(opts->brdf);
        if (!a) {
            std::fprintf(stderr, "gonio preview: %s\n", a.error().message.c_str());
            return 1;
        }
        if (!has_data(**a, opts->brdf)) {
            return 1;
        }
        std::unique_ptr<gonio::brdf::Brdf> b;
        if (!opts->vs.empty()) {
            auto loaded = gonio::brdf::load_brdf(opts->vs);
            if (!loaded) {
                std::fprintf(stderr, "gonio preview: %s\n", loaded.error().message.c_str());
                return 1;
            }
            b = std::move(*loaded);
            if (!has_data(*b, opts->vs)) {
                return 1;
            }
        }
        gonio::report::PreviewOptions po;
        po.size_px = opts->size;
        po.env_samples = opts->samples;
        // describe() names the file and what it holds.
        auto sheet = gonio::report::preview_sheet(
            **a, (*a)->describe(), b.get(), b ? b->describe() : std::string(), po);
        if (!sheet) {
            std::fprintf(stderr, "gonio preview: %s\n", sheet.error().message.c_str());
            return 1;
        }
        if (auto w = gonio::report::write_png(opts->out, *sheet); !w) {
            std::fprintf(stderr, "gonio preview: %s\n", w.error().message.c_str());
            return 1;
        }
        std::printf("%s\n", opts->out.c_str());
        return 0;
    };
}
