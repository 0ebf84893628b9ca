// The command-line contract: every option honoured or refused (exit 2 naming it and what it
// conflicts with), one request per job whatever the front end, exit codes by the scheme
// (0 ok, 1 the work failed, 2 usage or input error), messages that name the command.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "../fitting/fit_test_util.h"
#include "cli_run.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model_json.h"

namespace {

namespace fs = std::filesystem;
using gonio::testing::CliRun;
using gonio::testing::run_gonio;

std::string contract_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("contract").string();
    return d;
}

gonio::brdf::ModelD truth() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = gonio::brdf::Rgbd(0.4, 0.3, 0.2);
    gonio::brdf::Lobe<double> l;
    l.distribution = gonio::brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.15;
    l.fresnel.type = gonio::brdf::FresnelType::kSchlick;
    l.fresnel.f0 = gonio::brdf::Rgbd::Constant(0.05);
    l.scale = gonio::brdf::Rgbd(1.0, 0.9, 0.8);
    m.lobes.push_back(l);
    return m;
}

std::string data_csv() {
    const std::string path = contract_dir() + "/data.csv";
    if (!fs::exists(path)) {
        gonio::brdf::Dataset d = gonio::fitting::testing::synthesize(
            truth(), gonio::fitting::testing::measurement_grid());
        EXPECT_TRUE(gonio::brdf::write_dataset_csv(path, d));
    }
    return path;
}

std::string read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

bool has(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// ---- gonio fit -----------------------------------------------------------------------------

TEST(FitContract, AutoRefusesEveryStructureOptionNamingBoth) {
    const std::string data = data_csv();
    for (const char* opt :
         {"--no-diffuse", "--fresnel none", "--shadowing v-groove", "--lobes 2", "--anisotropic"}) {
        CliRun r = run_gonio("fit " + data + " --model auto " + opt);
        EXPECT_EQ(r.status, 2) << opt << "\n" << r.out;
        const std::string flag = std::string(opt).substr(0, std::string(opt).find(' '));
        EXPECT_TRUE(has(r.out, "gonio fit: " + flag + " cannot be combined with --model auto"))
            << r.out;
    }
}

TEST(FitContract, TemplateRefusesStructureOptions) {
    const std::string tmpl = contract_dir() + "/t.json";
    std::ofstream(tmpl) << R"({"model": )" << gonio::brdf::model_to_json(truth())
                        << R"(, "free": ["diffuse", "lobes[0].alpha"]})";
    CliRun r = run_gonio("fit " + data_csv() + " --template " + tmpl + " --fresnel none");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_TRUE(has(r.out, "--fresnel cannot be combined with --template")) << r.out;
}

TEST(FitContract, CompareRefusesTemplateModelOutAndTruth) {
    // The files named exist, so the refusal is the conflict, not an unreadable input.
    for (const char* name : {"x.json", "t.json"}) {
        std::ofstream(contract_dir() + "/" + name) << "{}";
    }
    for (const std::string& opt : {"--template " + contract_dir() + "/x.json",
                                   std::string("--model ggx"),
                                   "--out " + contract_dir() + "/f.json",
                                   "--truth " + contract_dir() + "/t.json"}) {
        CliRun r = run_gonio("fit " + data_csv() + " --compare ggx,beckmann " + opt);
        EXPECT_EQ(r.status, 2) << opt << "\n" << r.out;
        const std::string flag = std::string(opt).substr(0, std::string(opt).find(' '));
        EXPECT_TRUE(has(r.out, "gonio fit: " + flag + " cannot be combined with --compare"))
            << r.out;
    }
    CliRun a = run_gonio("fit " + data_csv() + " --compare ggx,auto");
    EXPECT_EQ(a.status, 2) << a.out;
}

TEST(FitContract, UnreadableTruthIsRefusedBeforeTheFit) {
    CliRun r = run_gonio("fit " + data_csv() + " --truth " + contract_dir() + "/missing.json");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_TRUE(has(r.out, "gonio fit: --truth:")) << r.out;
    // Nothing of a fit was printed: the check came first.
    EXPECT_FALSE(has(r.out, "log_rmse")) << r.out;
}

TEST(FitContract, LossScaleRangeIsWrittenAsPeopleWriteIt) {
    CliRun r = run_gonio("fit " + data_csv() + " --loss-scale -1");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_TRUE(has(r.out, "must be > 0")) << r.out;
    EXPECT_FALSE(has(r.out, "179769313486")) << r.out;
    EXPECT_TRUE(has(r.out, "gonio fit:")) << r.out;
}

TEST(FitContract, MistypedOptionGetsASuggestionAndTheCommandName) {
    CliRun r = run_gonio("fit " + data_csv() + " --modle ggx");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_TRUE(has(r.out, "gonio fit: --modle: unknown option; did you mean --model?")) << r.out;
}

TEST(FitContract, ManifestAppliesCommandLineOptionsToEveryEntry) {
    const std::string m = contract_dir() + "/m.csv";
    std::ofstream(m) << "input,model,options,id\n" << data_csv() << ",ggx,,a\n";
    const std::string out = contract_dir() + "/fits";
    fs::remove_all(out);
    CliRun r = run_gonio("fit --manifest " + m + " --out " + out +
                         " --residual relative --max-samples 150 --starts 2");
    ASSERT_EQ(r.status, 0) << r.out;
    const nlohmann::json rep = nlohmann::json::parse(read(out + "/a.report.json"));
    EXPECT_EQ(rep["residual"], "relative");
    // The first stage solved on a reduction of about 150 samples, not on all valid ones.
    const std::size_t valid = rep["samples"]["valid"].get<std::size_t>();
    ASSERT_GT(valid, 300u);
    EXPECT_LE(rep["solver"]["stages"][0]["samples"].get<std::size_t>(), 200u) << rep.dump();
    // A structure option that conflicts with an entry's model is refused naming the line.
    std::ofstream(m) << "input,model,options,id\n" << data_csv() << ",auto,,b\n";
    CliRun c = run_gonio("fit --manifest " + m + " --out " + out + " --lobes 2");
    EXPECT_EQ(c.status, 2) << c.out;
    EXPECT_TRUE(has(c.out, "--lobes cannot be combined with " + m + " line 2, model auto"))
        << c.out;
    // Options that name one fit are refused with --manifest (the truth file exists: the refusal
    // is the conflict, not an unreadable input).
    std::ofstream(contract_dir() + "/x.json") << "{}";
    CliRun t = run_gonio("fit --manifest " + m + " --out " + out + " --truth " + contract_dir() +
                         "/x.json");
    EXPECT_EQ(t.status, 2) << t.out;
    EXPECT_TRUE(has(t.out, "--truth cannot be combined with --manifest")) << t.out;
}

TEST(FitContract, ManifestExitCodesFollowTheScheme) {
    // Unreadable manifest: an input error (2).
    CliRun r =
        run_gonio("fit --manifest " + contract_dir() + "/none.csv --out " + contract_dir() + "/o");
    EXPECT_EQ(r.status, 2) << r.out;
    // An output folder that cannot be made: the work failed (1).
    const std::string m = contract_dir() + "/m2.csv";
    std::ofstream(m) << "input,model,options,id\n" << data_csv() << ",ggx,,a\n";
    std::ofstream(contract_dir() + "/plainfile") << "x";
    CliRun f = run_gonio("fit --manifest " + m + " --out " + contract_dir() + "/plainfile/sub");
    EXPECT_EQ(f.status, 1) << f.out;
    EXPECT_TRUE(has(f.out, "cannot create the folder")) << f.out;
}

TEST(FitContract, DegreesInARadianColumnGetAHint) {
    const std::string path = contract_dir() + "/deg.csv";
    std::ofstream(path) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n45,0,30,180,0.5,0.5,0.5\n";
    CliRun r = run_gonio("fit " + path);
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_TRUE(has(r.out, "gonio fit: " + path + ":2:1: theta_i = 45 outside [0, pi/2)")) << r.out;
    EXPECT_TRUE(has(r.out, "looks like degrees")) << r.out;
    // A value beyond 90 is no degree of a polar angle: no hint.
    std::ofstream(path) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n120,0,30,180,0.5,0.5,0.5\n";
    CliRun b = run_gonio("fit " + path);
    EXPECT_FALSE(has(b.out, "looks like degrees")) << b.out;
}

// ---- gonio acquire -------------------------------------------------------------------------

TEST(AcquireContract, ImageModeRefusesPointModeOptionsNamingBoth) {
    const std::string camp = contract_dir() + "/campaign.json";
    std::ofstream(camp) << "{}";
    std::ofstream(contract_dir() + "/s.json") << "{}";  // readable: the refusal is the combination
    const std::pair<std::string, std::string> cases[] = {
        {camp, "campaign.json (the positional description) cannot be combined with --mode image"},
        {"--scene " + contract_dir() + "/s.json", "--scene cannot be combined with --mode image"},
        {"--plan uniform", "--plan cannot be combined with --mode image"},
        {"--n-theta 4", "--n-theta cannot be combined with --mode image"},
        {"--n-dphi 4", "--n-dphi cannot be combined with --mode image"},
        {"--adaptive 1", "--adaptive cannot be combined with --mode image"},
        {"--accept-drift", "--accept-drift cannot be combined with --mode image"},
    };
    for (const auto& [args, want] : cases) {
        CliRun r = run_gonio("acquire --mode image " + args);
        EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
        EXPECT_TRUE(has(r.out, "gonio acquire: " + want)) << r.out;
        EXPECT_FALSE(has(r.out, "--table-factor")) << r.out;
        EXPECT_FALSE(has(r.out, "frame 1")) << r.out;
    }
}

TEST(AcquireContract, ImageResumeReadsTheFolderAndRefusesNewCampaignOptions) {
    // A folder that holds no image campaign: an error naming it, nothing created in it.
    fs::create_directories(contract_dir() + "/old");
    CliRun a = run_gonio("acquire --mode image --resume " + contract_dir() + "/old");
    EXPECT_EQ(a.status, 1) << a.out;
    EXPECT_TRUE(has(a.out, "not an image-mode campaign folder")) << a.out;
    EXPECT_TRUE(fs::is_empty(contract_dir() + "/old"));
    // A folder that does not exist is an input that cannot be read: refused before any work.
    CliRun missing = run_gonio("acquire --mode image --resume " + contract_dir() + "/nowhere");
    EXPECT_EQ(missing.status, 2) << missing.out;
    EXPECT_FALSE(fs::exists(contract_dir() + "/nowhere"));
    // The settings of a resumed image campaign come from its folder.
    const std::pair<std::string, std::string> cases[] = {
        {"--grid 15x15x30", "--grid cannot be combined with --resume"},
        {"--coverage-target 0.4", "--coverage-target cannot be combined with --resume"},
        {"--max-frames 3", "--max-frames cannot be combined with --resume"},
        {"--material gold", "--material cannot be combined with --resume"},
    };
    for (const auto& [args, want] : cases) {
        CliRun r = run_gonio("acquire --mode image --resume " + contract_dir() + "/old " + args);
        EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
        EXPECT_TRUE(has(r.out, "gonio acquire: " + want)) << r.out;
    }  // The live page goes with a resume as with a new campaign: the folder is read first.
    CliRun s =
        run_gonio("acquire --mode image --resume " + contract_dir() + "/old --serve 127.0.0.1:0");
    EXPECT_EQ(s.status, 1) << s.out;
    EXPECT_TRUE(has(s.out, "not an image-mode campaign folder")) << s.out;
}

TEST(AcquireContract, GridIsAnImageModeOptionHonouredByThePlan) {
    CliRun a = run_gonio("acquire --plan-only --grid 15x15x30");
    EXPECT_EQ(a.status, 2) << a.out;
    EXPECT_TRUE(has(a.out, "--grid cannot be combined with --mode point")) << a.out;
    CliRun b = run_gonio("acquire --mode image --plan-only --grid 15x15x30");
    EXPECT_EQ(b.status, 0) << b.out;
    EXPECT_TRUE(has(b.out, "15x15x30 table")) << b.out;
    CliRun c = run_gonio("acquire --mode image --plan-only --grid 15x15");
    EXPECT_EQ(c.status, 2) << c.out;
    EXPECT_TRUE(has(c.out, "--grid")) << c.out;
    CliRun d = run_gonio("acquire --plan-only --serve 0");
    EXPECT_EQ(d.status, 2) << d.out;
    EXPECT_TRUE(has(d.out, "--serve cannot be combined with --plan-only")) << d.out;
}

TEST(AcquireContract, ImagePlanOnlyPrintsThePlanAndMeasuresNothing) {
    const fs::path cwd = fs::current_path();
    const std::string here = contract_dir() + "/plan";
    fs::create_directories(here);
    fs::current_path(here);
    CliRun r = run_gonio("acquire --mode image --plan-only --coverage-target 0.4 --max-frames 7");
    fs::current_path(cwd);
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(has(r.out, "image mode plan")) << r.out;
    EXPECT_TRUE(has(r.out, "coverage target 40%")) << r.out;
    EXPECT_TRUE(has(r.out, "at most 7 light positions")) << r.out;
    EXPECT_FALSE(has(r.out, "frame 1")) << r.out;
    EXPECT_TRUE(fs::is_empty(here)) << "plan-only wrote into the folder";
}

TEST(AcquireContract, PointModeRefusesImageOptionsAndResumeRefusesNewCampaignOptions) {
    CliRun a = run_gonio("acquire --plan-only --coverage-target 0.5");
    EXPECT_EQ(a.status, 2) << a.out;
    EXPECT_TRUE(has(a.out, "--coverage-target cannot be combined with --mode point")) << a.out;
    fs::create_directories(contract_dir() + "/c");  // readable: the refusal is the combination
    CliRun b = run_gonio("acquire --resume " + contract_dir() + "/c --material gold");
    EXPECT_EQ(b.status, 2) << b.out;
    EXPECT_TRUE(has(b.out, "--material cannot be combined with --resume")) << b.out;
    CliRun c = run_gonio("acquire --plan-only --out " + contract_dir() + "/x");
    EXPECT_EQ(c.status, 2) << c.out;
    EXPECT_TRUE(has(c.out, "--out cannot be combined with --plan-only")) << c.out;
    EXPECT_FALSE(fs::exists(contract_dir() + "/x"));
}

// ---- gonio export, eval, check ---------------------------------------------------------------

TEST(ExportContract, TwoOutputsAreRefused) {
    const std::string model = contract_dir() + "/m.json";
    std::ofstream(model) << gonio::brdf::model_to_json(truth());
    CliRun r = run_gonio("export " + model + " --to mitsuba " + contract_dir() + "/a.xml --out " +
                         contract_dir() + "/b.xml");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_TRUE(has(r.out, "out_file")) << r.out;
    EXPECT_TRUE(has(r.out, "--out")) << r.out;
    EXPECT_FALSE(fs::exists(contract_dir() + "/a.xml"));
    EXPECT_FALSE(fs::exists(contract_dir() + "/b.xml"));
}

TEST(EvalContract, OutputReplacesAPlantedLinkAndFailureLeavesNoFile) {
    const std::string model = contract_dir() + "/m.json";
    std::ofstream(model) << gonio::brdf::model_to_json(truth());
    const std::string in = contract_dir() + "/dirs.csv";
    std::ofstream(in) << "theta_i,phi_i,theta_o,phi_o\n0.3,0,0.4,3.1\n";
    const std::string victim = contract_dir() + "/victim.txt";
    std::ofstream(victim) << "precious\n";
    const std::string out = contract_dir() + "/out.csv";
    fs::remove(out);
    fs::create_symlink(victim, out);
    CliRun r = run_gonio("eval " + model + " -i " + in + " -o " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(read(victim), "precious\n");
    EXPECT_FALSE(fs::is_symlink(out));
    EXPECT_TRUE(has(read(out), "r,g,b\n"));
    // A failure (no header line: the input is refused whole, exit 2) leaves no file and no
    // temporary debris.
    const std::string bad_in = contract_dir() + "/empty.csv";
    std::ofstream(bad_in) << "# nothing\n";
    const std::string out2 = contract_dir() + "/out2.csv";
    CliRun f = run_gonio("eval " + model + " -i " + bad_in + " -o " + out2);
    EXPECT_EQ(f.status, 2) << f.out;
    EXPECT_FALSE(fs::exists(out2));
    for (const auto& e : fs::directory_iterator(contract_dir())) {
        EXPECT_FALSE(has(e.path().filename().string(), ".tmp")) << e.path();
    }
}

TEST(CheckContract, PairsZeroIsRefusedWithTheRuleAsWritten) {
    const std::string model = contract_dir() + "/m.json";
    std::ofstream(model) << gonio::brdf::model_to_json(truth());
    CliRun r = run_gonio("check " + model + " --pairs 0");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_TRUE(has(r.out, "gonio check: --pairs: 0: must be a whole number >= 1")) << r.out;
    CliRun e = run_gonio("check " + model + " --energy-tol -1");
    EXPECT_EQ(e.status, 2) << e.out;
    EXPECT_TRUE(has(e.out, "must be >= 0")) << e.out;
    EXPECT_FALSE(has(e.out, "179769313486")) << e.out;
}

// Image mode's camera size and grazing limit are checked against the rig description before
// anything starts: beyond the rig's geometry.max_theta_deg, or a camera size for a rig whose
// calibrated camera is the camera, is a usage error naming the option and the rig's limit; within
// them the plan honours both.
TEST(Contract, ImageModeCameraSizeAndGrazingLimitAreCheckedAgainstTheRig) {
    const CliRun beyond = run_gonio("acquire --mode image --plan-only --max-theta-deg 88");
    EXPECT_EQ(beyond.status, 2) << beyond.out;
    EXPECT_TRUE(has(beyond.out, "--max-theta-deg 88 deg is beyond")) << beyond.out;
    EXPECT_TRUE(has(beyond.out, "geometry.max_theta_deg (85 deg)")) << beyond.out;

    const CliRun within =
        run_gonio("acquire --mode image --plan-only --max-theta-deg 84 --camera-px 96");
    EXPECT_EQ(within.status, 0) << within.out;
    EXPECT_TRUE(has(within.out, "camera 96x96")) << within.out;
    EXPECT_TRUE(has(within.out, "theta_i 84.0 deg, theta_o 84.0 deg")) << within.out;

    // The same rig with a calibrated camera model: --camera-px is refused.
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim-image.json");
    nlohmann::json rig = nlohmann::json::parse(in);
    rig["camera_model"] = {{"projection", "orthographic"},
                           {"width", 128},
                           {"height", 128},
                           {"fx", 2000.0},
                           {"fy", 2000.0},
                           {"cx", 63.5},
                           {"cy", 63.5},
                           {"rotation_world_to_camera", {0, 1, 0, 0, 0, -1, -1, 0, 0}},
                           {"translation_world_to_camera_m", {0, 0, 0.5}}};
    const std::string path = contract_dir() + "/rig-with-camera.json";
    std::ofstream(path) << rig.dump(2);
    const CliRun sized = run_gonio("acquire --mode image --plan-only --camera-px 96 --rig " + path);
    EXPECT_EQ(sized.status, 2) << sized.out;
    EXPECT_TRUE(has(sized.out, "--camera-px sizes the virtual rig's default camera")) << sized.out;
    EXPECT_TRUE(has(sized.out, "calibrated camera_model")) << sized.out;
    const CliRun calibrated = run_gonio("acquire --mode image --plan-only --rig " + path);
    EXPECT_EQ(calibrated.status, 0) << calibrated.out;
    EXPECT_TRUE(has(calibrated.out, "camera 128x128 (orthographic)")) << calibrated.out;
}

}  // namespace
