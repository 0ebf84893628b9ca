// One exit rule for every command: an input named on the command line that does not exist, or is
// a folder where a file is wanted, is a usage error (exit status 2) found before any work, with the
// command, the option and the path named; every --help states the same rule, word for word as the
// README does.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "exit_rule.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

/// Whitespace runs as one space (help text and the README wrap lines differently).
std::string squeezed(const std::string& s) {
    return std::regex_replace(s, std::regex("\\s+"), " ");
}

std::string model_file(const fs::path& dir) {
    const fs::path p = dir / "model.json";
    std::ofstream(p) << read_text(std::string(GONIO_SOURCE_DIR) + "/data/models/plastic-ggx.json");
    return p.string();
}

TEST(ExitRule, AnInputThatCannotBeReadIsAUsageErrorInEveryCommand) {
    const fs::path dir = fresh_test_dir("exit_rule");
    const std::string m = model_file(dir);
    const std::string gone = (dir / "missing.json").string();
    const std::string nope = (dir / "nope.csv").string();
    const std::string no_dir = (dir / "no-such-campaign").string();
    struct Case {
        std::string command;  ///< after `gonio `
        std::string named;    ///< the path the message names
    };
    const std::vector<Case> cases = {
        {"fit " + nope, nope},
        {"fit " + m + " --truth " + gone, gone},
        {"fit --manifest " + nope + " --out " + (dir / "shards").string(), nope},
        {"fit " + dir.string(), dir.string()},  // a folder where a file is wanted
        {"acquire --brdf " + gone + " --out " + (dir / "c1").string(), gone},
        {"acquire " + gone + " --out " + (dir / "c2").string(), gone},
        {"acquire --rig " + gone + " --out " + (dir / "c3").string(), gone},
        {"acquire --scene " + gone + " --out " + (dir / "c4").string(), gone},
        {"acquire --resume " + no_dir, no_dir},
        {"acquire --mode image --brdf " + gone + " --out " + (dir / "c5").string(), gone},
        {"plot " + nope + " --out " + (dir / "p").string(), nope},
        {"plot " + m + " --fit " + gone + " --out " + (dir / "p").string(), gone},
        {"preview " + gone, gone},
        {"preview " + m + " --vs " + gone, gone},
        {"check " + gone, gone},
        {"convert " + gone + " " + (dir / "o.binary").string(), gone},
        {"export " + gone + " --to mitsuba", gone},
        {"eval " + gone, gone},
        {"eval " + m + " -i " + nope, nope},
        {"report " + no_dir, no_dir},
        {"sim --config " + gone, gone},
        {"sim --brdf " + gone, gone},
    };
    for (const Case& c : cases) {
        const CliRun r = run_gonio(c.command);
        const std::string word = c.command.substr(0, c.command.find(' '));
        EXPECT_EQ(r.status, 2) << c.command << "\n" << r.out;
        EXPECT_EQ(r.out.rfind("gonio " + word + ": ", 0), 0u) << c.command << "\n" << r.out;
        EXPECT_NE(r.out.find(c.named), std::string::npos) << c.command << "\n" << r.out;
    }
    // Nothing was made by any of them.
    for (const char* made : {"c1", "c2", "c3", "c4", "c5", "p", "o.binary", "shards"}) {
        EXPECT_FALSE(fs::exists(dir / made)) << made;
    }
    // What a file holds is the work's to judge: a file that exists but is not a dataset is exit
    // status 1, after reading it.
    const fs::path junk = dir / "junk.csv";
    std::ofstream(junk) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.1,0,0.2,x,1,1,1\n";
    const CliRun j = run_gonio("fit " + junk.string());
    EXPECT_EQ(j.status, 1) << j.out;
    EXPECT_NE(j.out.find("junk.csv:2:4"), std::string::npos) << j.out;
}

TEST(ExitRule, EveryHelpAndTheReadmeStateTheSameRule) {
    const std::string rule = gonio::tools::kExitRule;
    const std::string readme = squeezed(read_text(std::string(GONIO_SOURCE_DIR) + "/README.md"));
    EXPECT_NE(readme.find(rule), std::string::npos) << "README.md does not state: " << rule;
    for (const char* command : {"",
                                "acquire",
                                "sim",
                                "axis",
                                "camera",
                                "camera capture",
                                "devices",
                                "fit",
                                "eval",
                                "check",
                                "convert",
                                "plot",
                                "preview",
                                "export",
                                "report"}) {
        const CliRun r = run_gonio(std::string(command) + " --help");
        EXPECT_EQ(r.status, 0) << command << "\n" << r.out;
        EXPECT_NE(squeezed(r.out).find(rule), std::string::npos)
            << "gonio " << command << " --help does not state the rule\n"
            << r.out;
        EXPECT_EQ(r.out.find("bad input"), std::string::npos) << command << "\n" << r.out;
    }
}

}  // namespace
}  // namespace gonio::testing
