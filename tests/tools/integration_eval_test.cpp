// End to end: `gonio eval` and `gonio check` on files in a temporary directory; values compared
// with eval_model() on the same model.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
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

TEST_F(EvalCli, ValuesEqualEvalModelAndBadRowsKeepTheirPlaceAsNaN) {
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
    EXPECT_EQ(status, 0) << read("err.txt");
    std::string header;
    const auto rows = parse_csv_numbers(read("out.csv"), &header);
    EXPECT_EQ(header, "r,g,b");
    ASSERT_EQ(rows.size(), 7u) << read("out.csv");
    const ModelD m = *load_model_json(path("model.json"));
    // Input rows in order; nullptr marks a refused row.
    const double good[4][4] = {
        {0.3, 0.1, 0.5, 3.0}, {1.2, -0.4, 0.2, 2.0}, {0, 0, 0, 0}, {0.3, 0, 1.8, 0}};
    const double* dirs[7] = {good[0], good[1], nullptr, good[2], nullptr, good[3], nullptr};
    for (int r = 0; r < 7; ++r) {
        ASSERT_EQ(rows[r].size(), 3u);
        if (dirs[r] == nullptr) {
            for (int c = 0; c < 3; ++c) {
                EXPECT_TRUE(std::isnan(rows[r][c])) << "row " << r;
            }
            continue;
        }
        const Rgbd f = eval_model(m,
                                  spherical_to_cartesian(dirs[r][0], dirs[r][1]),
                                  spherical_to_cartesian(dirs[r][2], dirs[r][3]));
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(rows[r][c], f[c], 1e-15 * std::abs(f[c])) << "row " << r;
        }
    }
    EXPECT_EQ(rows[5][0], 0.0);  // below the horizon
    const std::string err = read("err.txt");
    EXPECT_NE(err.find("<stdin>:5: phi_i = \"abc\": not a number (NaN row written)"),
              std::string::npos)
        << err;
    EXPECT_NE(err.find("<stdin>:7: theta_i = 4.0: outside [0, pi]"), std::string::npos) << err;
    EXPECT_NE(err.find("<stdin>:9: 3 fields, header has 4"), std::string::npos) << err;
    EXPECT_NE(err.find("warning: 3 of 7 row(s) written as NaN"), std::string::npos) << err;
}

/// GGX with height-correlated Smith G and Schlick F plus Lambert, written here from the papers
/// (Walter et al. 2007 eq. 33 for D; Heitz 2014 eq. 99 for G), independently of brdf/.
Rgbd ggx_closed_form(
    double alpha, const Rgbd& rho, const Rgbd& f0, const Vec3d& wi, const Vec3d& wo) {
    const double kPiHere = 3.14159265358979323846;
    if (wi.z() <= 0 || wo.z() <= 0) {
        return Rgbd::Zero();
    }
    const Vec3d h = (wi + wo).normalized();
    const double a2 = alpha * alpha;
    const double c2 = h.z() * h.z();
    const double t2 = (1 - c2) / c2;
    const double D = a2 / (kPiHere * c2 * c2 * (a2 + t2) * (a2 + t2));
    const auto lambda = [a2](const Vec3d& w) {
        const double tan2 = (1 - w.z() * w.z()) / (w.z() * w.z());
        return (-1 + std::sqrt(1 + a2 * tan2)) / 2;
    };
    const double G = 1 / (1 + lambda(wi) + lambda(wo));
    const double c_d = wi.dot(h);
    Rgbd f;
    for (int c = 0; c < 3; ++c) {
        const double F = f0[c] + (1 - f0[c]) * std::pow(1 - c_d, 5);
        f[c] = rho[c] / kPiHere + F * D * G / (4 * wi.z() * wo.z());
    }
    return f;
}

TEST_F(EvalCli, RowsInDegreesInTheMiddleKeepTheOthersAligned) {
    write("ggx.json",
          R"({"diffuse": [0.25, 0.12, 0.05], "lobes": [{"distribution": "ggx", "alpha": 0.18,
              "shadowing": "smith-correlated", "fresnel": {"type": "schlick",
              "f0": [0.9, 0.55, 0.3]}, "scale": [1, 1, 1]}]})");
    // 40 rows; rows 13 and 27 (0-based) were written in degrees, row 20 does not parse.
    std::vector<std::string> lines;
    std::vector<std::array<double, 4>> angles;
    for (int k = 0; k < 40; ++k) {
        const std::array<double, 4> a = {
            0.02 + 0.035 * k, -3.0 + 0.15 * k, 1.3 - 0.03 * k, 0.4 + 0.07 * k};
        angles.push_back(a);
        char buf[128];
        std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g", a[0], a[1], a[2], a[3]);
        lines.emplace_back(buf);
    }
    lines[13] = "45,0,30,180";
    lines[20] = "0.5,0.1,0.5,";
    lines[27] = "0.4,0,75.5,90";
    std::string text = "theta_i,phi_i,theta_o,phi_o\n";
    for (const std::string& l : lines) {
        text += l + "\n";
    }
    write("dirs.csv", text);
    ASSERT_EQ(run("eval " + path("ggx.json") + " -i " + path("dirs.csv") + " -o " +
                  path("out.csv") + " 2> " + path("err.txt")),
              0)
        << read("err.txt");
    std::istringstream out(read("out.csv"));
    std::string line;
    std::getline(out, line);
    ASSERT_EQ(line, "r,g,b");
    std::vector<std::string> out_rows;
    while (std::getline(out, line)) {
        out_rows.push_back(line);
    }
    ASSERT_EQ(out_rows.size(), lines.size()) << read("out.csv");
    const std::string err = read("err.txt");
    EXPECT_NE(err.find("dirs.csv:15: theta_i = 45: outside [0, pi] (it looks like degrees"),
              std::string::npos)
        << err;
    EXPECT_NE(err.find("dirs.csv:22: phi_o = \"\": not a number"), std::string::npos) << err;
    EXPECT_NE(err.find("dirs.csv:29: theta_o = 75.5: outside [0, pi]"), std::string::npos) << err;
    const Rgbd rho(0.25, 0.12, 0.05);
    const Rgbd f0(0.9, 0.55, 0.3);
    for (std::size_t k = 0; k < lines.size(); ++k) {
        if (k == 13 || k == 20 || k == 27) {
            EXPECT_EQ(out_rows[k], "nan,nan,nan") << "row " << k;
            continue;
        }
        // The same text as `gonio eval` prints for the row alone ...
        write("one.csv", "theta_i,phi_i,theta_o,phi_o\n" + lines[k] + "\n");
        ASSERT_EQ(run("eval " + path("ggx.json") + " -i " + path("one.csv") + " -o " +
                      path("one_out.csv")),
                  0);
        EXPECT_EQ("r,g,b\n" + out_rows[k] + "\n", read("one_out.csv")) << "row " << k;
        // ... and the closed form.
        const auto& a = angles[k];
        const Rgbd f = ggx_closed_form(
            0.18, rho, f0, spherical_to_cartesian(a[0], a[1]), spherical_to_cartesian(a[2], a[3]));
        std::string header;
        const auto v = parse_csv_numbers("r,g,b\n" + out_rows[k] + "\n", &header);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(v[0][c], f[c], 1e-10 * std::abs(f[c]) + 1e-300) << "row " << k;
        }
    }
}

TEST_F(EvalCli, AnInputWithoutAUsableRowIsRefusedWholeBeforeAnyOutput) {
    write("model.json", kEvalModel);
    write("degrees.csv", "theta_i,phi_i,theta_o,phi_o\n30,0,45,180\n60,90,10,0\n");
    EXPECT_EQ(run("eval " + path("model.json") + " -i " + path("degrees.csv") + " > " + path("o") +
                  " 2> " + path("e")),
              2);
    EXPECT_EQ(read("o"), "");
    EXPECT_NE(read("e").find("none of its 2 row(s) can be evaluated; nothing written"),
              std::string::npos)
        << read("e");
    // A file output is not created at all.
    EXPECT_EQ(run("eval " + path("model.json") + " -i " + path("degrees.csv") + " -o " +
                  path("out.csv") + " 2> " + path("e")),
              2);
    EXPECT_FALSE(fs::exists(path("out.csv")));
    // A header alone is a usable (empty) input.
    write("empty.csv", "theta_i,phi_i,theta_o,phi_o\n");
    EXPECT_EQ(run("eval " + path("model.json") + " -i " + path("empty.csv") + " > " + path("o")),
              0);
    EXPECT_EQ(read("o"), "r,g,b\n");
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
              2);
    EXPECT_EQ(read("o"), "");
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
