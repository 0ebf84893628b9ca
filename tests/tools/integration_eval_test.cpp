// End to end: `gonio eval` and `gonio check` on files in a temporary directory; values compared
// with eval_model() on the same model.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/brdf/model_eval.h"
#include "gonio/brdf/model_json.h"

namespace gonio::brdf {
namespace {

namespace fs = std::filesystem;

class EvalCli : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("gonio_eval_test_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    void write(const std::string& name, const std::string& text) const {
        std::ofstream(path(name)) << text;
    }

    std::string read(const std::string& name) const {
        std::ifstream in(path(name));
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }

    /// Runs the gonio executable with a shell command line tail; returns the exit status.
    int run(const std::string& args) const {
        const std::string cmd = std::string("'") + GONIO_EXE + "' " + args;
        const int status = std::system(cmd.c_str());
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }

    fs::path dir_;
};

const char* kEvalModel = R"({
  "diffuse": [0.2, 0.3, 0.4],
  "lobes": [
    {"distribution": "ggx", "alpha_x": 0.15, "alpha_y": 0.3, "shadowing": "smith-correlated",
     "fresnel": {"type": "schlick", "f0": [0.04, 0.05, 0.06]}},
    {"distribution": "beckmann", "alpha": 0.4, "shadowing": "v-groove",
     "fresnel": {"type": "conductor", "material": "gold"}, "scale": 0.5}
  ]
})";

std::vector<std::vector<double>> parse_csv_numbers(const std::string& text, std::string* header) {
    std::vector<std::vector<double>> rows;
    std::istringstream in(text);
    std::string line;
    std::getline(in, *header);
    while (std::getline(in, line)) {
        std::vector<double> row;
        std::istringstream ls(line);
        std::string field;
        while (std::getline(ls, field, ',')) {
            row.push_back(std::strtod(field.c_str(), nullptr));
        }
        rows.push_back(row);
    }
    return rows;
}

TEST_F(EvalCli, ValuesEqualEvalModelAndBadRowsAreReportedByLine) {
    write("model.json", kEvalModel);
    // Line 1 header, line 2 comment, 3-4 good, 5 bad number, 6 good, 7 theta out of range,
    // 8 below the horizon (valid: value 0), 9 wrong field count.
    write("dirs.csv",
          "theta_i,phi_i,theta_o,phi_o\n"
          "# a comment\n"
          "0.3,0.1,0.5,3.0\n"
          "1.2,-0.4,0.2,2.0\n"
          "0.5,abc,0.5,0.0\n"
          "0.0,0.0,0.0,0.0\n"
          "4.0,0,0,0\n"
          "0.3,0,1.8,0\n"
          "0.1,0.2,0.3\n");
    const int status = run("eval " + path("model.json") + " < " + path("dirs.csv") + " > " +
                           path("out.csv") + " 2> " + path("err.txt"));
    EXPECT_EQ(status, 1);
    std::string header;
    const auto rows = parse_csv_numbers(read("out.csv"), &header);
    EXPECT_EQ(header, "r,g,b");
    ASSERT_EQ(rows.size(), 4u) << read("out.csv");
    const ModelD m = *load_model_json(path("model.json"));
    const double dirs[4][4] = {
        {0.3, 0.1, 0.5, 3.0}, {1.2, -0.4, 0.2, 2.0}, {0, 0, 0, 0}, {0.3, 0, 1.8, 0}};
    for (int r = 0; r < 4; ++r) {
        const Rgbd f = eval_model(m,
                                  spherical_to_cartesian(dirs[r][0], dirs[r][1]),
                                  spherical_to_cartesian(dirs[r][2], dirs[r][3]));
        ASSERT_EQ(rows[r].size(), 3u);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(rows[r][c], f[c], 1e-15 * std::abs(f[c])) << "row " << r;
        }
    }
    EXPECT_EQ(rows[3][0], 0.0);  // below the horizon
    const std::string err = read("err.txt");
    EXPECT_NE(err.find("<stdin>:5: phi_i = \"abc\": not a number"), std::string::npos) << err;
    EXPECT_NE(err.find("<stdin>:7: theta_i = 4.0: outside [0, pi]"), std::string::npos) << err;
    EXPECT_NE(err.find("<stdin>:9: 3 fields, header has 4"), std::string::npos) << err;
    EXPECT_NE(err.find("3 row(s) failed, 4 evaluated"), std::string::npos) << err;
}

TEST_F(EvalCli, ColumnsInAnyOrderAndFilesAsOptions) {
    write("model.json", kEvalModel);
    write("dirs.csv", "phi_o,theta_o,note,phi_i,theta_i\n3.0,0.5,x,0.1,0.3\n");
    EXPECT_EQ(
        run("eval " + path("model.json") + " -i " + path("dirs.csv") + " -o " + path("out.csv")),
        0);
    std::string header;
    const auto rows = parse_csv_numbers(read("out.csv"), &header);
    ASSERT_EQ(rows.size(), 1u);
    const ModelD m = *load_model_json(path("model.json"));
    const Rgbd f =
        eval_model(m, spherical_to_cartesian(0.3, 0.1), spherical_to_cartesian(0.5, 3.0));
    EXPECT_NEAR(rows[0][1], f[1], 1e-15 * f[1]);
}

TEST_F(EvalCli, StructuralErrorsFailTheWork) {
    write("model.json", kEvalModel);
    write("noheader.csv", "0.1,0.2,0.3,0.4\n");
    EXPECT_EQ(run("eval " + path("model.json") + " < " + path("noheader.csv") + " > " + path("o") +
                  " 2> " + path("e")),
              1);
    EXPECT_NE(read("e").find("header lacks column \"theta_i\""), std::string::npos) << read("e");
    write(
        "bad.json",
        R"({"lobes":[{"distribution":"ggx","alpha":-0.1,"shadowing":"none","fresnel":{"type":"none"}}]})");
    EXPECT_EQ(run("eval " + path("bad.json") + " < " + path("noheader.csv") + " > " + path("o") +
                  " 2> " + path("e")),
              1);
    EXPECT_NE(read("e").find("bad.json: lobes[0].alpha = -0.1: must be > 0"), std::string::npos)
        << read("e");
}

TEST_F(EvalCli, CheckPassesAPhysicalModelAndFlagsAnUnshadowedOne) {
    // Diffuse plus a dielectric-like coat: albedo stays below 1 at every incidence. (kEvalModel adds
    // a strong gold lobe to a diffuse base and does exceed 1 near grazing incidence.)
    write("model.json",
          R"({"diffuse":[0.5,0.4,0.3],"lobes":[{"distribution":"ggx","alpha":0.2,)"
          R"("shadowing":"smith-correlated","fresnel":{"type":"schlick","f0":0.04}}]})");
    EXPECT_EQ(run("check " + path("model.json") + " --pairs 2000 > " + path("out.txt")), 0)
        << read("out.txt");
    const std::string out = read("out.txt");
    for (const char* name :
         {"non-negativity", "reciprocity", "isotropy", "energy", "all checks passed"}) {
        EXPECT_NE(out.find(name), std::string::npos) << out;
    }
    write(
        "bright.json",
        R"({"lobes":[{"distribution":"ggx","alpha":0.5,"shadowing":"none","fresnel":{"type":"none"}}]})");
    EXPECT_EQ(run("check " + path("bright.json") + " --pairs 2000 > " + path("out2.txt")), 1);
    EXPECT_NE(read("out2.txt").find("FAIL"), std::string::npos) << read("out2.txt");
}

TEST_F(EvalCli, HelpWorks) {
    EXPECT_EQ(run("eval --help > " + path("h1")), 0);
    EXPECT_NE(read("h1").find("theta_i,phi_i,theta_o,phi_o"), std::string::npos);
    EXPECT_EQ(run("check --help > " + path("h2")), 0);
    EXPECT_NE(read("h2").find("--energy-tol"), std::string::npos);
}

}  // namespace
}  // namespace gonio::brdf
