// gonio check MODEL_OR_TABLE: property checks with a table of the worst violations.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "command.h"
#include "exit_rule.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/checks.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/table.h"
#include "option_checks.h"

namespace {

struct CheckCliOptions {
    std::string brdf_path;
    gonio::brdf::CheckOptions checks;
    std::string noise_from;
    gonio::brdf::DatasetCheckOptions dataset;
    /// Options given on the command line, by name: each mode refuses those it cannot honour.
    std::vector<std::pair<std::string, const CLI::Option*>> given;
};

/// Exit 2 naming the first option in `names` that was given: `mode` cannot honour it.
bool refuse_given(const CheckCliOptions& opts,
                  const std::vector<std::string>& names,
                  const std::string& mode) {
    for (const auto& [name, option] : opts.given) {
        if (option->count() > 0 && std::find(names.begin(), names.end(), name) != names.end()) {
            std::fprintf(stderr,
                         "gonio check: %s does not apply to %s (%s)\n",
                         name.c_str(),
                         mode.c_str(),
                         opts.brdf_path.c_str());
            return true;
        }
    }
    return false;
}

/// A measured dataset: checks of the samples against each other within their sigma.
int run_dataset_check(const CheckCliOptions& opts) {
    // A dataset is checked against itself, pair by pair, with a threshold from its sigma and the
    // number of pairs: no random pairs, tolerances or stated noise enter.
    if (refuse_given(opts,
                     {"--seed",
                      "--pairs",
                      "--reciprocity-tol",
                      "--isotropy-tol",
                      "--energy-tol",
                      "--noise",
                      "--noise-from"},
                     "a measured dataset, whose own sigma sets the thresholds")) {
        return 2;
    }
    auto data = gonio::brdf::read_dataset_csv(opts.brdf_path);
    if (!data) {
        std::fprintf(stderr, "gonio check: %s\n", data.error().message.c_str());
        return 1;
    }
    if (data->samples.empty()) {
        std::fprintf(stderr, "gonio check: %s: no sample to check\n", opts.brdf_path.c_str());
        return 1;
    }
    std::printf("dataset %s: %zu samples%s; pairs matched within %.3g deg\n\n",
                opts.brdf_path.c_str(),
                data->samples.size(),
                data->has_sigma ? " with sigma" : " without sigma (relative floor only)",
                opts.dataset.match_tolerance_deg);
    const auto results = gonio::brdf::check_dataset(*data, opts.dataset);
    std::printf("%s", gonio::brdf::format_check_table(results).c_str());
    const bool ok = gonio::brdf::all_passed(results);
    std::printf("\n%s\n", ok ? "all checks passed" : "VIOLATION beyond the noise");
    return ok ? 0 : 1;
}

int run_check(CheckCliOptions opts) {
    if (gonio::ends_with(opts.brdf_path, ".csv")) {
        return run_dataset_check(opts);
    }
    if (refuse_given(opts, {"--match-tol"}, "a model or table; it pairs dataset samples")) {
        return 2;
    }
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
        // Stated noise: a dataset whose samples are the table's bins (an image-mode campaign
        // writes dataset.csv beside its table).
        std::string noise = opts.noise_from;
        if (noise.empty()) {
            const auto side = std::filesystem::path(opts.brdf_path).parent_path() / "dataset.csv";
            if (std::filesystem::exists(side)) {
                noise = side.string();
            }
        }
        if (!noise.empty()) {
            auto d = gonio::brdf::read_dataset_csv(noise);
            if (!d) {
                std::fprintf(stderr, "gonio check: noise: %s\n", d.error().message.c_str());
                return 1;
            }
            opts.checks.bin_sigma = gonio::brdf::bin_sigma_from_dataset(table->grid(), *d);
            std::printf(
                "noise: per-bin sigma of %zu samples from %s\n", d->samples.size(), noise.c_str());
        }
        if (opts.checks.noise_relative > 0) {
            std::printf("noise: stated relative sigma %.3g\n", opts.checks.noise_relative);
        }
        std::printf("table: reciprocity and isotropy held to the bins' spread + %.3g sigma\n",
                    opts.checks.noise_sigmas);
    } else if (!opts.noise_from.empty() || opts.checks.noise_relative > 0) {
        std::fprintf(stderr,
                     "gonio check: --noise and --noise-from apply to tables only; %s is a "
                     "model\n",
                     opts.brdf_path.c_str());
        return 2;
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
        "check",
        "check a BRDF (model, table or measured dataset) for non-negativity, reciprocity, "
        "isotropy and energy conservation");
    auto opts = std::make_shared<CheckCliOptions>();
    cmd->add_option("brdf", opts->brdf_path, "Model JSON, tabulated BRDF or dataset CSV")
        ->required()
        ->check(gonio::tools::readable_input());
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
    cmd->add_option("--noise",
                    opts->checks.noise_relative,
                    "Tables: stated relative noise (one sigma) of every value")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    cmd->add_option("--noise-from",
                    opts->noise_from,
                    "Tables: dataset CSV with one sample per bin and its sigma (default: "
                    "dataset.csv beside the table, when present)");
    cmd->add_option("--match-tol",
                    opts->dataset.match_tolerance_deg,
                    "Datasets: angle within which two samples form a pair, deg")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    for (const char* name : {"--seed",
                             "--pairs",
                             "--reciprocity-tol",
                             "--isotropy-tol",
                             "--energy-tol",
                             "--noise",
                             "--noise-from",
                             "--match-tol"}) {
        opts->given.emplace_back(name, cmd->get_option(name));
    }
    cmd->footer(
        "A dataset (*.csv) is checked against itself: reciprocal and rotated pairs of samples "
        "must agree within their sigma (threshold from the number of pairs, no random choice). "
        "A table is held to its own resolution and stated noise. An option that does not apply "
        "to the input's kind is refused (exit 2). "
        "Exit status 1 here also means a violation beyond tolerance or a table without valid "
        "bins.\n" +
        std::string(gonio::tools::kExitRule));
    return [opts]() -> int { return run_check(*opts); };
}
