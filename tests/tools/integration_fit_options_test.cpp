// `gonio fit` over its option space: model x fresnel x shadowing x lobes 0-4 x residual x loss x
// roughness x anisotropic x diffuse, every pair of values in at least one run (a greedy all-pairs
// cover of the 72,000 combinations), on a small synthetic dataset and a small real one. Each run
// fits (exit 0, a misfit included; or 1 when the walk's small iteration budget ends before the
// solver converges, said as such) or is refused with exit 2 before any work (the same refusal
// when the data file does not exist); never a signal. And the Lambert-only fit (--lobes 0), which
// once died in the packet cost kernel, recovers a Lambert truth.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../fitting/fit_test_util.h"
#include "cli_run.h"
#include "gonio/brdf/dataset.h"

namespace {

using gonio::testing::CliRun;
using gonio::testing::run_gonio;

std::string options_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("integration_fit_options").string();
    return d;
}

/// A readable dataset with its header and no sample: a fit of it fails (exit 1) once it reads the
/// data, so an option refused before that (exit 2) is refused before any work.
std::string empty_data() {
    const std::string path = options_dir() + "/no-samples.csv";
    std::ofstream(path) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n";
    return path;
}

/// One fit option and its values; the first value is the command's default (not passed).
struct Axis {
    std::string flag;
    std::vector<std::string> values;
};

const std::vector<Axis>& option_space() {
    static const std::vector<Axis> axes = {
        {"--model", {"ggx", "beckmann", "blinn-phong", "student-t", "tabulated", "auto"}},
        {"--fresnel", {"schlick", "schlick-rgb", "dielectric", "conductor", "none"}},
        {"--shadowing", {"smith-correlated", "smith-separable", "v-groove", "none"}},
        {"--lobes", {"1", "0", "2", "3", "4"}},
        {"--residual", {"log", "absolute", "relative", "cosine", "cbrt"}},
        {"--loss", {"none", "huber", "cauchy"}},
        {"--roughness", {"shared", "rgb"}},
        {"--anisotropic", {"false", "true"}},
        {"--no-diffuse", {"false", "true"}},
    };
    return axes;
}

/// A greedy all-pairs cover (AETG-like, deterministic): each new row starts from a pair not yet
/// covered and gives every other option the value that covers the most new pairs.
std::vector<std::vector<int>> all_pairs(const std::vector<Axis>& axes) {
    const int n = static_cast<int>(axes.size());
    // covered[a][b][va * |b| + vb]
    std::vector<std::vector<std::vector<bool>>> covered(n, std::vector<std::vector<bool>>(n));
    std::size_t left = 0;
    for (int a = 0; a < n; ++a) {
        for (int b = a + 1; b < n; ++b) {
            covered[a][b].assign(axes[a].values.size() * axes[b].values.size(), false);
            left += covered[a][b].size();
        }
    }
    auto idx = [&](int, int va, int b, int vb) {
        return static_cast<std::size_t>(va) * axes[b].values.size() + static_cast<std::size_t>(vb);
    };
    std::vector<std::vector<int>> rows;
    while (left > 0) {
        std::vector<int> row(n, -1);
        bool seeded = false;
        for (int a = 0; a < n && !seeded; ++a) {
            for (int b = a + 1; b < n && !seeded; ++b) {
                for (std::size_t k = 0; k < covered[a][b].size(); ++k) {
                    if (!covered[a][b][k]) {
                        row[a] = static_cast<int>(k / axes[b].values.size());
                        row[b] = static_cast<int>(k % axes[b].values.size());
                        seeded = true;
                        break;
                    }
                }
            }
        }
        for (int a = 0; a < n; ++a) {
            if (row[a] >= 0) {
                continue;
            }
            int best = 0;
            int best_gain = -1;
            for (int v = 0; v < static_cast<int>(axes[a].values.size()); ++v) {
                int gain = 0;
                for (int b = 0; b < n; ++b) {
                    if (b == a || row[b] < 0) {
                        continue;
                    }
                    gain += a < b ? !covered[a][b][idx(a, v, b, row[b])]
                                  : !covered[b][a][idx(b, row[b], a, v)];
                }
                if (gain > best_gain) {
                    best_gain = gain;
                    best = v;
                }
            }
            row[a] = best;
        }
        for (int a = 0; a < n; ++a) {
            for (int b = a + 1; b < n; ++b) {
                const std::size_t k = idx(a, row[a], b, row[b]);
                if (!covered[a][b][k]) {
                    covered[a][b][k] = true;
                    --left;
                }
            }
        }
        rows.push_back(row);
    }
    return rows;
}

/// The options of a row as typed (defaults left out, so that auto runs when the rest is default).
std::string options_of(const std::vector<int>& row) {
    const std::vector<Axis>& axes = option_space();
    std::string s;
    for (std::size_t a = 0; a < axes.size(); ++a) {
        if (row[a] == 0) {
            continue;
        }
        const std::string& v = axes[a].values[static_cast<std::size_t>(row[a])];
        if (v == "true") {
            s += " " + axes[a].flag;
        } else {
            s += " " + axes[a].flag + " " + v;
        }
    }
    return s;
}

std::string synthetic_data() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = gonio::brdf::Rgbd(0.5, 0.3, 0.05);
    gonio::brdf::Lobe<double> l;
    l.distribution = gonio::brdf::Distribution::kBeckmann;
    l.alpha_x = l.alpha_y = 0.2;
    l.fresnel.type = gonio::brdf::FresnelType::kSchlick;
    l.fresnel.f0 = gonio::brdf::Rgbd::Constant(0.04);
    m.lobes.push_back(l);
    gonio::brdf::Dataset d =
        gonio::fitting::testing::synthesize(m, gonio::fitting::testing::measurement_grid());
    const std::string path = options_dir() + "/synthetic.csv";
    EXPECT_TRUE(gonio::brdf::write_dataset_csv(path, d));
    return path;
}

/// A measured material (the RGL database's, kept outside the repository): empty when absent.
std::string real_data() {
    const char* env = std::getenv("GONIO_RGL_DIR");
    const std::filesystem::path rgl =
        env != nullptr ? std::filesystem::path(env)
                       : std::filesystem::path(GONIO_SOURCE_DIR) / ".." / "shared" / "data" / "rgl";
    const std::filesystem::path p = rgl / "paper_white_rgb.bsdf";
    return std::filesystem::exists(p) ? p.string() : std::string();
}

/// Walks the cover on `data`; the budget options keep each fit short.
void walk(const std::string& data) {
    std::vector<std::vector<int>> rows = all_pairs(option_space());
    ASSERT_GE(rows.size(), 30u);  // at least |model| x |fresnel| pairs
    // Every row of auto names a structure option (refused with it); auto with solver options only.
    rows.push_back({5, 0, 0, 0, 4, 1, 0, 0, 0});
    rows.push_back({5, 0, 0, 0, 2, 2, 0, 0, 0});
    int fitted = 0;
    int refused = 0;
    for (const std::vector<int>& row : rows) {
        const std::string opts = options_of(row) + " --starts 2 --max-iterations 30 --threads 1";
        SCOPED_TRACE("gonio fit DATA" + opts);
        // Refused before any work: the same refusal when the data hold no sample at all (a file
        // that does not exist is refused before the options, as every unreadable input is).
        CliRun missing = run_gonio("fit " + empty_data() + opts);
        ASSERT_NE(missing.status, -1) << "signal\n" << missing.out;
        CliRun r = run_gonio("fit " + data + " --max-samples 400" + opts);
        ASSERT_NE(r.status, -1) << "signal\n" << r.out;
        if (missing.status == 2) {
            EXPECT_EQ(r.status, 2) << r.out;
            EXPECT_EQ(r.out.find("goodness of fit"), std::string::npos) << r.out;
            ++refused;
            continue;
        }
        EXPECT_EQ(missing.status, 1) << missing.out;
        EXPECT_NE(missing.out.find("no-samples.csv"), std::string::npos) << missing.out;
        // A fit: exit 0, or 1 when the iteration budget of the walk ends before the solver
        // converges, said as such (the report is the fit's, with usable false).
        const bool stopped = r.out.find("the fit did not converge") != std::string::npos;
        EXPECT_TRUE(r.status == 0 || (r.status == 1 && stopped)) << r.out;
        EXPECT_TRUE(r.out.find("goodness of fit") != std::string::npos || stopped) << r.out;
        ++fitted;
    }
    // Both kinds occur: the walk is not all refusals (nor all fits: auto with a structure option
    // is refused).
    EXPECT_GT(fitted, static_cast<int>(rows.size()) / 2);
    EXPECT_GT(refused, 0);
}

TEST(GonioFit, EveryPairOfFitOptionsFitsOrIsRefusedBeforeWorkOnSyntheticData) {
    walk(synthetic_data());
}

TEST(GonioFit, EveryPairOfFitOptionsFitsOrIsRefusedBeforeWorkOnMeasuredData) {
    const std::string data = real_data();
    if (data.empty()) {
        GTEST_SKIP() << "RGL data not found (set GONIO_RGL_DIR; measurements are not in the "
                        "repository)";
    }
    walk(data);
}

TEST(GonioFit, LambertOnlyFitRecoversTheAlbedo) {
    gonio::brdf::ModelD truth;
    truth.has_diffuse = true;
    truth.diffuse = gonio::brdf::Rgbd(0.62, 0.35, 0.08);
    gonio::brdf::Dataset d =
        gonio::fitting::testing::synthesize(truth, gonio::fitting::testing::measurement_grid());
    const std::string data = options_dir() + "/lambert.csv";
    ASSERT_TRUE(gonio::brdf::write_dataset_csv(data, d));
    for (const std::string model : {"ggx", "beckmann", "blinn-phong"}) {
        for (const std::string starts : {"1", "6"}) {
            const std::string out = options_dir() + "/lambert_" + model + starts + ".json";
            CliRun r = run_gonio("fit " + data + " --lobes 0 --model " + model + " --starts " +
                                 starts + " --out " + out);
            ASSERT_EQ(r.status, 0) << r.out;
            std::ifstream in(out);
            const nlohmann::json j = nlohmann::json::parse(in);
            ASSERT_TRUE(j.at("lobes").empty()) << j.dump();
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(
                    j.at("diffuse").at(c).get<double>(), truth.diffuse[c], 1e-4 * truth.diffuse[c])
                    << model << " starts " << starts << " channel " << c;
            }
        }
    }
}

}  // namespace
