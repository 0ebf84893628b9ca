// gonio report: the self-contained HTML page of a campaign folder.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "command.h"
#include "gonio/report/blender_render.h"
#include "gonio/report/html_report.h"
#include "option_checks.h"

namespace {

struct Options {
    std::string dir;
    bool regenerate = false;
    int preview_size = 256;
    int preview_samples = 192;
    bool blender = false;
};

}  // namespace

GONIO_COMMAND(report) {
    auto* cmd = app.add_subcommand(
        "report",
        "write DIR/report.html for a point or image-mode campaign folder: the result (verdict, "
        "model, parameters), pictures, coverage, calibration, run history, raw descriptions");
    auto opts = std::make_shared<Options>();
    cmd->add_option("dir", opts->dir, "campaign folder")
        ->required()
        ->check(gonio::tools::readable_input(gonio::tools::InputKind::kFolder));
    cmd->add_flag("--regenerate", opts->regenerate, "redraw plots and previews that already exist");
    cmd->add_option("--preview-size", opts->preview_size, "sphere picture size in pixels")
        ->capture_default_str()
        ->check(CLI::Range(16, 2048));
    cmd->add_option("--preview-samples", opts->preview_samples, "environment directions per pixel")
        ->capture_default_str()
        ->check(CLI::Range(6, 65536));
    cmd->add_flag("--blender",
                  opts->blender,
                  "also render the fit in Blender (gonio export --to blender) beside the preview, "
                  "with the measured difference; needs blender installed");
    return [opts]() -> int {
        if (opts->blender && gonio::report::find_blender().empty()) {
            std::fprintf(stderr,
                         "gonio report: --blender: blender is not installed (apt-get install "
                         "blender)\n");
            return 2;
        }
        gonio::report::ReportOptions ro;
        ro.blender = opts->blender;
        ro.regenerate = opts->regenerate;
        ro.preview.size_px = opts->preview_size;
        ro.preview.env_samples = opts->preview_samples;
        auto r = gonio::report::build_report(opts->dir, ro);
        if (!r) {
            std::fprintf(stderr, "gonio report: %s\n", r.error().message.c_str());
            return 1;
        }
        for (const std::string& g : r->generated) {
            std::fprintf(stderr, "gonio report: drew %s\n", g.c_str());
        }
        for (const std::string& n : r->notes) {
            std::fprintf(stderr, "gonio report: note: %s\n", n.c_str());
        }
        std::printf("%s\n", r->html_path.c_str());
        return 0;
    };
}
