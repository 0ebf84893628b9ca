// End to end: `gonio convert` between a model JSON, tables and sample CSVs in a temporary
// directory; tables read back and compared with eval_model() of the same model at the bin centres.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_json.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {
namespace {

namespace fs = std::filesystem;

const char* kConvertModel = R"({
  "diffuse": [0.25, 0.2, 0.15],
  "lobes": [
    {"distribution": "ggx", "alpha": 0.25, "shadowing": "smith-correlated",
     "fresnel": {"type": "schlick", "f0": [0.9, 0.7, 0.4]}, "scale": [1, 1, 1]}
  ]
})";

class ConvertCli : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("gonio_convert_test_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(dir_);
        std::ofstream(path("model.json")) << kConvertModel;
        Expected<ModelD> m = parse_model_json(kConvertModel, "model.json");
        ASSERT_TRUE(m) << m.error().message;
        model_ = *m;
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    std::string read(const std::string& name) const {
        std::ifstream in(path(name));
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }

    /// Runs gonio with the arguments, stdout to out.txt and stderr to err.txt; the exit status.
    int run(const std::string& args) const {
        const std::string cmd = std::string("'") + GONIO_EXE + "' " + args + " > '" +
                                path("out.txt") + "' 2> '" + path("err.txt") + "'";
        const int status = std::system(cmd.c_str());
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }

    /// Worst relative difference between a table's valid bins and the model at their centres.
    double worst_against_model(const TabulatedBrdf& t, std::size_t* valid) const {
        const TableGrid& g = t.grid();
        double worst = 0;
        *valid = 0;
        for (std::size_t flat = 0; flat < g.size(); ++flat) {
            const std::array<int, 3> b = g.unflatten(flat);
            const auto [wi, wo] = g.centre_directions(b[0], b[1], b[2]);
            if (wi.z() <= 0 || wo.z() <= 0) {
                EXPECT_FALSE(t.bin_valid(flat));
                continue;
            }
            EXPECT_TRUE(t.bin_valid(flat));
            const Rgbd f = eval_model(model_, wi, wo);
            worst = std::max(worst, ((t.bin_value(flat) - f).abs() / f).maxCoeff());
            ++*valid;
        }
        return worst;
    }

    fs::path dir_;
    ModelD model_;
};

TEST_F(ConvertCli, ModelToGtabToCsvToGtab) {
    ASSERT_EQ(run("convert '" + path("model.json") + "' '" + path("m.gtab") + "' --grid 20x20x40"),
              0)
        << read("err.txt");
    EXPECT_NE(read("out.txt").find("bins valid"), std::string::npos) << read("out.txt");
    Expected<TabulatedBrdf> t = read_table_file(path("m.gtab"));
    ASSERT_TRUE(t) << t.error().message;
    ASSERT_EQ(t->grid().size(), 16000u);
    std::size_t valid = 0;
    EXPECT_LT(worst_against_model(*t, &valid), 1e-15);

    // Table -> CSV: one row per valid bin, values as stored.
    ASSERT_EQ(run("convert '" + path("m.gtab") + "' '" + path("m.csv") + "'"), 0)
        << read("err.txt");
    Expected<Dataset> d = read_dataset_csv(path("m.csv"));
    ASSERT_TRUE(d) << d.error().message;
    EXPECT_EQ(d->samples.size(), valid);
    EXPECT_TRUE(d->rejected.empty());
    for (const Sample& s : d->samples) {
        const Rgbd f = eval_model(model_, s.wi(), s.wo());
        ASSERT_LT(((s.value - f).abs() / f).maxCoeff(), 1e-12) << "line " << s.line;
    }

    // CSV -> table with a kernel narrower than a bin: each bin gets exactly its own sample back.
    ASSERT_EQ(run("convert '" + path("m.csv") + "' '" + path("back.gtab") +
                  "' --grid 20x20x40 --radius 0.5"),
              0)
        << read("err.txt");
    EXPECT_NE(
        read("out.txt").find(std::to_string(valid) + " of 16000 bins filled, 0 bins without data"),
        std::string::npos)
        << read("out.txt");
    Expected<TabulatedBrdf> back = read_table_file(path("back.gtab"));
    ASSERT_TRUE(back) << back.error().message;
    std::size_t valid_back = 0;
    EXPECT_LT(worst_against_model(*back, &valid_back), 1e-12);
    EXPECT_EQ(valid_back, valid);
}

TEST_F(ConvertCli, ModelToMerlBinary) {
    ASSERT_EQ(run("convert '" + path("model.json") + "' '" + path("m.binary") + "' --threads 2"), 0)
        << read("err.txt");
    EXPECT_EQ(fs::file_size(path("m.binary")), 34992012u);
    Expected<TabulatedBrdf> t = read_merl(path("m.binary"));
    ASSERT_TRUE(t) << t.error().message;
    std::size_t valid = 0;
    EXPECT_LT(worst_against_model(*t, &valid), 1e-15);
    EXPECT_NE(read("out.txt").find(std::to_string(valid) + " of 1458000 bins valid"),
              std::string::npos)
        << read("out.txt");
}

TEST_F(ConvertCli, SparseCsvLeavesBinsInvalidAndCountsThem) {
    // Three measurements only: most bins have no data within the radius.
    std::ofstream(path("sparse.csv")) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n"
                                         "0.5,0,0.5,3.14159,1,1,1\n"
                                         "0.3,0,0.7,3.0,0.5,0.5,0.5\n"
                                         "0.2,0.1,0.9,1.0,0.1,0.1,0.1\n";
    ASSERT_EQ(run("convert '" + path("sparse.csv") + "' '" + path("s.gtab") + "' --grid 10x10x20"),
              0)
        << read("err.txt");
    const std::string out = read("out.txt");
    EXPECT_NE(out.find("3 samples (0 rows rejected)"), std::string::npos) << out;
    EXPECT_NE(out.find("bins without data within 1.5 bins left invalid"), std::string::npos) << out;
    // A row below the horizon is an error naming file, line and column (the CSV reader is strict).
    std::ofstream(path("below.csv")) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n"
                                        "2.0,0,0.5,0,1,1,1\n";
    EXPECT_EQ(run("convert '" + path("below.csv") + "' '" + path("b.gtab") + "' --grid 10x10x20"),
              1);
    EXPECT_NE(read("err.txt").find("below.csv:2:1: theta_i = 2 outside [0, pi/2)"),
              std::string::npos)
        << read("err.txt");
    Expected<TabulatedBrdf> t = read_table_file(path("s.gtab"));
    ASSERT_TRUE(t);
    const std::size_t valid = t->compute_statistics().valid_bins;
    EXPECT_GT(valid, 0u);
    // Each sample reaches at most the 4 x 4 x 4 bins around it.
    EXPECT_LE(valid, 3u * 64u);
}

TEST_F(ConvertCli, ErrorsNameTheFile) {
    EXPECT_EQ(run("convert '" + path("missing.json") + "' '" + path("x.binary") + "'"), 2);
    EXPECT_NE(read("err.txt").find(path("missing.json")), std::string::npos) << read("err.txt");
    std::ofstream(path("short.binary"), std::ios::binary) << "abc";
    EXPECT_EQ(run("convert '" + path("short.binary") + "' '" + path("x.csv") + "'"), 1);
    EXPECT_NE(read("err.txt").find("shorter than the 12-byte header"), std::string::npos)
        << read("err.txt");
    // Usage errors (an output type or a grid that cannot be) exit with 2.
    EXPECT_EQ(run("convert '" + path("model.json") + "' '" + path("x.txt") + "'"), 2);
    EXPECT_NE(read("err.txt").find("unknown output type"), std::string::npos) << read("err.txt");
    EXPECT_EQ(run("convert '" + path("model.json") + "' '" + path("x.gtab") + "' --grid 0x2x2"), 2);
    EXPECT_NE(read("err.txt").find("--grid 0x2x2"), std::string::npos) << read("err.txt");
    EXPECT_FALSE(fs::exists(path("x.gtab")));
}

TEST_F(ConvertCli, EvalReadsATable) {
    ASSERT_EQ(run("convert '" + path("model.json") + "' '" + path("m.gtab") + "' --grid 20x20x40"),
              0);
    // A bin centre direction pair: the table returns the model's value there.
    const TableGrid g{20, 20, 40};
    const auto [wi, wo] = g.centre_directions(3, 5, 7);
    const Spherical<double> si = cartesian_to_spherical(wi);
    const Spherical<double> so = cartesian_to_spherical(wo);
    char row[256];
    std::snprintf(row, sizeof row, "%.17g,%.17g,%.17g,%.17g\n", si.theta, si.phi, so.theta, so.phi);
    std::ofstream(path("dirs.csv")) << "theta_i,phi_i,theta_o,phi_o\n" << row;
    ASSERT_EQ(run("eval '" + path("m.gtab") + "' < '" + path("dirs.csv") + "'"), 0)
        << read("err.txt");
    std::istringstream out(read("out.txt"));
    std::string header, line;
    std::getline(out, header);
    std::getline(out, line);
    double r = 0, gg = 0, b = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf", &r, &gg, &b), 3) << line;
    const Rgbd f = eval_model(model_, wi, wo);
    EXPECT_NEAR(r, f[0], 1e-12 * f[0]);
    EXPECT_NEAR(b, f[2], 1e-12 * f[2]);
}

}  // namespace
}  // namespace gonio::brdf
