// gonio check MODEL_OR_TABLE: property checks with a table of the worst violations.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/checks.h"
#include "gonio/brdf/table.h"
#include "option_checks.h"

namespace {

struct CheckCliOptions {
    std::string brdf_path;
    gonio::brdf::CheckOptions checks;
};

int run_check(const CheckCliOptions& opts) {
    auto brdf = gonio::brdf::load_brdf(opts.brdf_path);
    if (!brdf) {
        std::fprintf(stderr, "gonio check: %s\n", brdf.error().message.c_str());
        return 1;
    }
    if (const auto* table = dynamic_cast<const gonio::brdf::TabulatedBrdf*>(brdf->get())) {
        const gonio::brdf::TableStatistics st = table->compute_statistics();
        if (st.valid_bins == 0) {
            // Every check would pass vacuously on a table that holds no value at all.
            std::fprintf(stderr,
                         "gonio check: %s: 0 of %zu bins valid; a table without data cannot "
                         "pass the checks\n",
                         opts.brdf_path.c_str(),
                         st.bins);
            return 1;
        }
    }
    std::printf("%s\n", (*brdf)->describe().c_str());
    const std::string stats = (*brdf)->statistics();
    if (!stats.empty()) {
        std::printf("%s%s", stats.c_str(), stats.back() == '\n' ? "" : "\n");
    }
    std::printf("isotropic: %s; seed %llu, %d random pairs\n\n",
                (*brdf)->isotropic() ? "yes" : "no",
                static_cast<unsigned long long>(opts.checks.seed),
                opts.checks.random_pairs);
    const auto results = gonio::brdf::run_checks(**brdf, opts.checks);
    std::printf("%s", gonio::brdf::format_check_table(results).c_str());
    const bool ok = gonio::brdf::all_passed(results);
    std::printf("\n%s\n", ok ? "all checks passed" : "VIOLATION beyond tolerance");
    return ok ? 0 : 1;
}

}  // namespace

GONIO_COMMAND(check) {
    auto* cmd = app.add_subcommand(
        "check", "Check a BRDF for non-negativity, reciprocity, isotropy and energy conservation");
    auto opts = std::make_shared<CheckCliOptions>();
    cmd->add_option("brdf", opts->brdf_path, "Model JSON or tabulated BRDF file")->required();
    cmd->add_option("--seed", opts->checks.seed, "Seed of the random direction pairs")
        ->capture_default_str();
    cmd->add_option("--pairs", opts->checks.random_pairs, "Random direction pairs per check")
        ->check(gonio::tools::integer_at_least(1))
        ->capture_default_str();
    cmd->add_option("--reciprocity-tol",
                    opts->checks.reciprocity_tolerance,
                    "Largest accepted relative difference f(wi,wo) vs f(wo,wi)")
        ->check(gonio::tools::finite_at_least(0))
        ->capture_default_str();
    cmd->add_option("--isotropy-tol",
                    opts->checks.isotropy_tolerance,
                    "Largest accepted relative difference under a rotation about the normal")
        ->check(gonio::tools::finite_at_least(0))
        ->capture_default_str();
    cmd->add_option("--energy-tol",
                    opts->checks.energy_tolerance,
                    "Largest accepted directional albedo above 1 (quadrature error allowance)")
        ->check(gonio::tools::finite_at_least(0))
        ->capture_default_str();
    cmd->footer(
        "Exit status: 0 all checks passed, 1 a violation beyond tolerance, an unreadable BRDF or a "
        "table without valid bins, 2 usage error.");
    return [opts]() -> int { return run_check(*opts); };
}
