// Every option of a command does something or is refused (help_walk.h): the walk of fit, acquire,
// export, eval, check, convert, plot, preview and report.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../fitting/fit_test_util.h"
#include "cli_run.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/model_json.h"
#include "help_walk.h"

namespace {

namespace fs = std::filesystem;
using gonio::testing::BusyPort;
using gonio::testing::CliRun;
using gonio::testing::Proof;
using gonio::testing::prove;
using gonio::testing::run_gonio;

std::string walk_dir() {
    static const std::string d = gonio::testing::fresh_test_dir("help_walk").string();
    return d;
}

std::string walk_model() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = gonio::brdf::Rgbd(0.3, 0.2, 0.1);
    gonio::brdf::Lobe<double> l;
    l.distribution = gonio::brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.2;
    l.fresnel.type = gonio::brdf::FresnelType::kSchlick;
    l.fresnel.f0 = gonio::brdf::Rgbd::Constant(0.04);
    m.lobes.push_back(l);
    const std::string p = walk_dir() + "/m.json";
    std::ofstream(p) << gonio::brdf::model_to_json(m);
    return p;
}

std::string other_model_json() {
    gonio::brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = gonio::brdf::Rgbd(0.5, 0.5, 0.5);
    const std::string p = walk_dir() + "/m2.json";
    std::ofstream(p) << gonio::brdf::model_to_json(m);
    return p;
}

std::string dirs_csv(const std::string& name, const std::string& row) {
    const std::string p = walk_dir() + "/" + name;
    std::ofstream(p) << "theta_i,phi_i,theta_o,phi_o\n" << row << "\n";
    return p;
}

/// A small real dataset: the GGX model of walk_model() on the fitting tests' measurement grid,
/// 2 % relative noise drawn from seed 1, and every 40th value twice what it should be (outliers,
/// which a robust loss and its scale treat differently from the rest).
std::string noisy_csv() {
    const std::string p = walk_dir() + "/noisy.csv";
    const gonio::brdf::ModelD m = *gonio::brdf::load_model_json(walk_model());
    gonio::brdf::Dataset d = gonio::fitting::testing::noisy_measurement(m, 1);
    for (std::size_t k = 0; k < d.samples.size(); k += 40) {
        d.samples[k].value *= 2.0;
    }
    EXPECT_TRUE(gonio::brdf::write_dataset_csv(p, d));
    return p;
}

TEST(HelpWalk, FitEveryOptionHonouredOrRefused) {
    // Every pair fits the same small real dataset and compares what the fits wrote (the model
    // file: parameters and verdict); the printed request line, which echoes every option, is not
    // the outcome.
    const std::string data = noisy_csv();
    const std::string w = walk_dir() + "/fit-walk.json";
    // Without --model the fit is auto; the options of one family's fit are walked with ggx.
    const std::string p = "fit " + data + " --out " + w;
    const std::string f = p + " --model ggx";
    const std::string report = walk_dir() + "/fit-walk.report.json";
    // A manifest that exists (one that does not is refused before any work, naming only itself).
    const std::string manifest = walk_dir() + "/m.csv";
    std::ofstream(manifest) << "not a manifest\n";
    prove(
        "fit",
        {
            {"data", "fit --manifest " + manifest + " " + data, "", "data"},
            {"--model", p + " --compare ggx --model beckmann", ""},
            {"--model", p, p + " --model beckmann", "", w},
            {"--template", p + " --compare ggx --template t.json", ""},
            {"--no-diffuse", p + " --model auto --no-diffuse", ""},
            {"--no-diffuse", f, f + " --no-diffuse", "", w},
            {"--fresnel", p + " --model auto --fresnel none", ""},
            {"--fresnel", f, f + " --fresnel none", "", w},
            {"--shadowing", p + " --model auto --shadowing v-groove", ""},
            {"--shadowing", f, f + " --shadowing v-groove", "", w},
            {"--anisotropic", p + " --model auto --anisotropic", ""},
            {"--anisotropic", f, f + " --anisotropic", "", w},
            {"--lobes", p + " --model auto --lobes 2", ""},
            {"--lobes", f, f + " --lobes 2", "", w},
            {"--roughness", p + " --model auto --roughness rgb", ""},
            {"--roughness", f, f + " --roughness rgb", "", w},
            {"--residual", f, f + " --residual relative", "", w},
            {"--loss", f, f + " --loss huber", "", w},
            {"--loss-scale", f + " --loss huber", f + " --loss huber --loss-scale 0.05", "", w},
            {"--max-samples", f, f + " --max-samples 100", "", w},
            // Fewer starts may end in the same optimum: the report says how many were scored.
            {"--starts", f, f + " --starts 2", "", report},
            // The seed draws the reduction's samples.
            {"--seed", f + " --max-samples 300", f + " --max-samples 300 --seed 9", "", w},
            // One iteration does not converge: exit status 1 and no model file.
            {"--max-iterations", f, f + " --max-iterations 1", "", w, {}, "", nullptr, false, 1},
            // The solver's passes give the same result on any number of threads (documented in
            // docs/fitting-guide.md): the proof is that the results are equal.
            {"--threads", f + " --threads 1", f + " --threads 2", "", w, {}, "", nullptr, true},
            {"--out",
             f,
             "fit " + data + " --model ggx --out " + walk_dir() + "/elsewhere.json",
             "",
             w},
            {"--truth", f, f + " --truth " + walk_model(), "", report},
            // The request as run, printed only when asked for.
            {"--verbose", f, f + " --verbose"},
            {"--compare", "fit --manifest " + manifest + " --out o --compare ggx", ""},
            {"--manifest", "fit --manifest " + manifest + " --out o --model ggx", "", "--manifest"},
            {"--shard", f + " --shard 0/2", ""},
            // A misfit (one lobe without its diffuse part on data that has one) exits 1 only
            // with --strict.
            {"--strict",
             f + " --no-diffuse",
             f + " --no-diffuse --strict",
             "",
             w,
             {},
             "",
             nullptr,
             false,
             1},
        });
}

TEST(HelpWalk, AcquireEveryOptionHonouredOrRefused) {
    const BusyPort busy;
    ASSERT_GT(busy.port(), 0);
    // A folder to resume (refused options are refused before it is read).
    const std::string r = "acquire --resume " + walk_dir() + "/camp";
    fs::create_directories(walk_dir() + "/camp");
    const std::string camp = walk_dir() + "/c.json";
    const std::string zoom_rig = std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim-image-zoom.json";
    std::ofstream(camp) << R"({"plan": {"kind": "uniform", "n_theta": 3, "n_dphi": 2}})";
    // An image campaign of two light positions (its frame limit) to resume.
    const std::string two_frames = walk_dir() + "/two-frames";
    const CliRun two = run_gonio("acquire --mode image --max-frames 2 --out " + two_frames);
    ASSERT_TRUE(fs::exists(two_frames + "/dataset.csv")) << two.out;
    prove("acquire",
          {
              {"campaign", "acquire --mode image " + camp, "", "campaign.json"},
              {"--rig", r + " --rig x.json", ""},
              {"--out", r + " --out x", ""},
              {"--out", "acquire --plan-only --out x", ""},
              {"--campaigns-dir", r + " --campaigns-dir x", ""},
              {"--material", r + " --material gold", ""},
              {"--brdf", r + " --brdf x.json", ""},
              {"--scene", "acquire --mode image --scene s.json", ""},
              {"--sample", r + " --sample s", ""},
              {"--operator", r + " --operator o", ""},
              {"--plan", "acquire --plan-only", "acquire --plan-only --plan half-diff"},
              {"--n-theta", "acquire --plan-only", "acquire --plan-only --n-theta 3"},
              {"--n-dphi", "acquire --plan-only", "acquire --plan-only --n-dphi 3"},
              {"--n-theta", "acquire --plan-only --plan half-diff --n-theta 3", ""},
              {"--n-dphi", "acquire --plan-only --plan half-diff --n-dphi 3", ""},
              {"--adaptive", "acquire --mode image --adaptive 2", ""},
              {"--adaptive", "acquire --plan-only --anisotropic --adaptive 2", ""},
              {"--anisotropic", "acquire --plan-only", "acquire --plan-only --anisotropic"},
              {"--anisotropic",
               "acquire --mode image --plan-only --camera-px 64",
               "acquire --mode image --plan-only --camera-px 64 --anisotropic"},
              {"--grid", "acquire --mode image --plan-only --anisotropic --grid 30x30x60", ""},
              {"--anisotropic", "acquire --plan-only --anisotropic --plan half-diff", ""},
              {"--symmetry",
               "acquire --plan-only --anisotropic",
               "acquire --plan-only --anisotropic --symmetry 2-fold"},
              {"--symmetry", "acquire --plan-only --symmetry mirror", ""},
              {"--symmetry", "acquire --mode image --symmetry mirror", ""},
              {"--symmetry", "acquire --plan-only --plan vndf --anisotropic --symmetry mirror", ""},
              {"--anisotropic",
               "acquire --plan-only --plan vndf",
               "acquire --plan-only --plan vndf --anisotropic"},
              {"--vndf-theta-i",
               "acquire --plan-only --plan vndf",
               "acquire --plan-only --plan vndf --vndf-theta-i 4"},
              {"--vndf-theta-i", "acquire --plan-only --vndf-theta-i 4", ""},
              {"--vndf-theta-i", "acquire --mode image --vndf-theta-i 4", ""},
              {"--vndf-resolution",
               "acquire --plan-only --plan vndf",
               "acquire --plan-only --plan vndf --vndf-resolution 8"},
              {"--vndf-resolution", "acquire --plan-only --vndf-resolution 8", ""},
              {"--vndf-resolution", "acquire --mode image --vndf-resolution 8", ""},
              {"--vndf-phi-i",
               "acquire --plan-only --plan vndf --anisotropic",
               "acquire --plan-only --plan vndf --anisotropic --vndf-phi-i 4"},
              {"--vndf-phi-i", "acquire --plan-only --plan vndf --vndf-phi-i 4", ""},
              {"--vndf-phi-i", "acquire --mode image --vndf-phi-i 4", ""},
              {"--time-scale", r + " --time-scale 2", ""},
              {"--accept-drift", "acquire --mode image --accept-drift", ""},
              {"--until", "acquire --mode image --until sigma=0.01", ""},
              {"--until", "acquire --plan-only --until sigma=0.01", ""},
              {"--until", r + " --until sigma=0.01", ""},
              {"--until", "acquire --plan-only --plan vndf --until sigma=0.01", ""},
              {"--fly", "acquire --mode image --fly", ""},
              {"--fly", "acquire --plan-only --fly", ""},
              {"--fly-smear", "acquire --plan-only --fly-smear 2", ""},
              {"--fly-smear", "acquire --mode image --fly-smear 2", ""},
              {"--mode", "acquire --plan-only", "acquire --plan-only --mode image"},
              {"--coverage-target", "acquire --plan-only --coverage-target 0.3", ""},
              {"--coverage-target",
               "acquire --mode image --plan-only",
               "acquire --mode image --plan-only --coverage-target 0.3"},
              {"--max-frames", "acquire --plan-only --max-frames 3", ""},
              {"--max-frames",
               "acquire --mode image --plan-only",
               "acquire --mode image --plan-only --max-frames 3"},
              {"--grid", "acquire --plan-only --grid 15x15x30", ""},
              {"--camera-px", "acquire --plan-only --camera-px 128", ""},
              {"--camera-px",
               "acquire --mode image --plan-only",
               "acquire --mode image --plan-only --camera-px 128"},
              {"--max-theta-deg", "acquire --plan-only --max-theta-deg 70", ""},
              {"--max-theta-deg",
               "acquire --mode image --plan-only",
               "acquire --mode image --plan-only --max-theta-deg 70"},
              {"--grid",
               "acquire --mode image --plan-only",
               "acquire --mode image --plan-only --grid 15x15x30"},
              // Zoomed placements: only a rig that has them (the default rig has none), only
              // isotropic image campaigns, never on resume.
              {"--no-zoom", "acquire --plan-only --no-zoom", ""},
              {"--no-zoom", "acquire --mode image --plan-only --camera-px 64 --no-zoom", ""},
              {"--no-zoom",
               "acquire --mode image --plan-only --camera-px 64 --rig " + zoom_rig,
               "acquire --mode image --plan-only --camera-px 64 --no-zoom --rig " + zoom_rig},
              {"--no-zoom",
               "acquire --mode image --plan-only --anisotropic --no-zoom --rig " + zoom_rig,
               ""},
              {"--no-zoom", r + " --no-zoom", ""},
              // Image mode serves its live page: given an address already in use, it says so
              // and stops before it writes anything; without the option the campaign runs.
              {"--serve",
               "acquire --mode image --max-frames 1 --out " + walk_dir() +
                   "/served --serve 127.0.0.1:" + std::to_string(busy.port()),
               "acquire --mode image --max-frames 1 --out " + walk_dir() + "/served"},
              {"--serve", "acquire --plan-only --serve 0", ""},
              // The campaign the --serve proof just ran (one light position, its frame limit)
              // and one of two light positions, resumed: each read from its folder, with
              // nothing left to measure (a command that ignored --resume would run the same new
              // campaign twice); a folder that holds no campaign is refused, naming it.
              {"--resume",
               "acquire --mode image --resume " + walk_dir() + "/served",
               "acquire --mode image --resume " + two_frames},
              {"--resume", "acquire --mode image --resume " + walk_dir() + "/no-campaign", ""},
              {"--plan-only", r + " --plan-only", ""},
          });
}

TEST(HelpWalk, ExportEvalCheckEveryOptionHonouredOrRefused) {
    const std::string m = walk_model();
    const std::string m2 = other_model_json();
    const std::string blinn_phong = std::string(GONIO_SOURCE_DIR) + "/data/models/blinn-phong.json";
    prove("export",
          {
              {"input", "export " + m + " --to mitsuba", "export " + m2 + " --to mitsuba"},
              {"--to", "export " + m + " --to mitsuba", "export " + m + " --to pbrt"},
              {"--name", "export " + m + " --to mitsuba", "export " + m + " --to mitsuba --name x"},
              {"out_file", "export " + m + " --to pbrt a.pbrt --out b.pbrt", ""},
              {"--out",
               "export " + m + " --to pbrt",
               "export " + m + " --to pbrt --out " + walk_dir() + "/x.pbrt"},
              {"--approximate",
               "export " + blinn_phong + " --to blender",
               "export " + blinn_phong + " --to blender --approximate"},
              {"--approximate", "export " + m + " --to mitsuba --approximate", ""},
          });
    const std::string in1 = dirs_csv("d1.csv", "0.3,0,0.4,3.1");
    const std::string in2 = dirs_csv("d2.csv", "0.5,0,0.2,3.1");
    prove("eval",
          {
              {"brdf", "eval " + m + " -i " + in1, "eval " + m2 + " -i " + in1},
              {"--input", "eval " + m + " -i " + in1, "eval " + m + " -i " + in2},
              {"--output",
               "eval " + m + " -i " + in1,
               "eval " + m + " -i " + in1 + " -o " + walk_dir() + "/e.csv"},
          });
    const std::string c = "check " + m + " --pairs 200";
    // A measured dataset: two samples 0.7 deg from each other's reciprocal.
    const std::string data = walk_dir() + "/measured.csv";
    std::ofstream(data) << "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.5236,0,0.7854,3.1416,0.5,0.5,0.5\n"
                           "0.7976,0,0.5236,3.1416,0.52,0.5,0.5\n";
    prove("check",
          {
              {"brdf", c, "check " + m2 + " --pairs 200"},
              {"--seed", c, c + " --seed 5"},
              {"--pairs", c, "check " + m + " --pairs 300"},
              {"--reciprocity-tol", c, c + " --reciprocity-tol 0.5"},
              {"--isotropy-tol", c, c + " --isotropy-tol 0.5"},
              {"--energy-tol", c, c + " --energy-tol 0.5"},
              {"--noise", c + " --noise 0.1", "", "--noise"},
              {"--noise-from", c + " --noise-from " + data, "", "--noise-from"},
              {"--match-tol", c + " --match-tol 2", ""},
              {"--match-tol", "check " + data, "check " + data + " --match-tol 2"},
              {"--seed", "check " + data + " --seed 5", ""},
              {"--pairs", "check " + data + " --pairs 300", ""},
              {"--reciprocity-tol", "check " + data + " --reciprocity-tol 0.5", ""},
              {"--isotropy-tol", "check " + data + " --isotropy-tol 0.5", ""},
              {"--energy-tol", "check " + data + " --energy-tol 0.5", ""},
              {"--noise", "check " + data + " --noise 0.1", ""},
          });
}

TEST(HelpWalk, ConvertEveryOptionHonouredOrRefused) {
    const std::string m = walk_model();
    const std::string m2 = other_model_json();
    const std::string d = walk_dir();
    // A table and a sample CSV to convert from (made by the command itself).
    ASSERT_EQ(run_gonio("convert " + m + " " + d + "/t.gtab --grid 6x6x12").status, 0);
    ASSERT_EQ(run_gonio("convert " + m + " " + d + "/s.csv --grid 6x6x12").status, 0);
    const std::string out = d + "/o.gtab";
    const std::string csv = d + "/o.csv";
    prove("convert",
          {
              {"input",
               "convert " + m + " " + out + " --grid 4x4x8",
               "convert " + m2 + " " + out + " --grid 4x4x8",
               "",
               out},
              {"output", "convert " + m + " " + csv, "convert " + m + " " + out},
              {"--grid",
               "convert " + m + " " + out + " --grid 4x4x8",
               "convert " + m + " " + out + " --grid 5x4x8",
               "",
               out},
              {"--grid", "convert " + m + " " + d + "/o.binary --grid 4x4x8", ""},
              {"--grid", "convert " + d + "/t.gtab " + csv + " --grid 4x4x8", ""},
              {"--interpolation",
               "convert " + d + "/t.gtab " + out + " --grid 5x5x10",
               "convert " + d + "/t.gtab " + out + " --grid 5x5x10 --interpolation trilinear",
               "",
               out},
              {"--interpolation", "convert " + m + " " + out + " --interpolation trilinear", ""},
              {"--interpolation",
               "convert " + d + "/t.gtab " + csv + " --interpolation trilinear",
               ""},
              {"--interpolation", "convert " + m + " " + d + "/o.bsdf --interpolation nearest", ""},
              {"--threads", "convert " + d + "/t.gtab " + csv + " --threads 2", ""},
              {"--threads", "convert " + d + "/s.csv " + out + " --threads 2", ""},
              {"--threads", "convert " + m + " " + d + "/o.bsdf --threads 2", ""},
              {"--radius",
               "convert " + d + "/s.csv " + out + " --grid 8x8x16 --radius 0.5",
               "convert " + d + "/s.csv " + out + " --grid 8x8x16 --radius 4",
               "",
               out},
              {"--radius", "convert " + m + " " + out + " --radius 2", ""},
              {"--phi-i",
               "convert " + m + " " + d + "/o.bsdf",
               "convert " + m + " " + d + "/o.bsdf --phi-i 4"},
              {"--phi-i", "convert " + m + " " + csv + " --phi-i 4", ""},
              {"--phi-i", "convert " + m + " " + out + " --phi-i 4", ""},
          });
}

TEST(HelpWalk, PlotPreviewReportEveryOptionHonouredOrRefused) {
    const std::string m = walk_model();
    const std::string m2 = other_model_json();
    const std::string d = walk_dir();
    ASSERT_EQ(run_gonio("convert " + m + " " + d + "/s.csv --grid 6x6x12").status, 0);
    ASSERT_EQ(run_gonio("convert " + m2 + " " + d + "/s2.csv --grid 6x6x12").status, 0);
    const std::string plots = d + "/plots";
    const std::string p = "plot " + d + "/s.csv --out " + plots;
    prove("plot",
          {
              {"data", p, "plot " + d + "/s2.csv --out " + plots, "", plots},
              {"--fit", p, p + " --fit " + m2, "", plots},
              // The pictures go to the named folder, not to the one before.
              {"--out", p, "plot " + d + "/s.csv --out " + d + "/plots2", "", plots},
              {"--scale", p + " --scale linear", p + " --scale log", "", plots},
              {"--log", p + " --scale linear", p + " --log", "", plots},
              {"--log", p + " --log --scale linear", "", "--log"},
              {"--width", p, p + " --width 500", "", plots},
              {"--theta-i", p, p + " --theta-i 10,50", "", plots},
          });
    const std::string png = d + "/p.png";
    const std::string v = "preview " + m + " --out " + png + " --size 24 --samples 12";
    prove(
        "preview",
        {
            {"brdf", v, "preview " + m2 + " --out " + png + " --size 24 --samples 12", "", png},
            {"--vs", v, v + " --vs " + m2, "", png},
            {"--out", v, "preview " + m + " --out " + d + "/q.png --size 24 --samples 12", "", png},
            {"--size", v, "preview " + m + " --out " + png + " --size 32 --samples 12", "", png},
            {"--samples", v, "preview " + m + " --out " + png + " --size 24 --samples 48", "", png},
        });
    // A campaign folder: a dataset and a fit.
    const std::string camp = d + "/camp";
    fs::create_directories(camp);
    fs::copy_file(d + "/s.csv", camp + "/dataset.csv");
    fs::copy_file(m, camp + "/fit.json");
    const std::string r = "report " + camp + " --preview-size 24 --preview-samples 12";
    ASSERT_EQ(run_gonio(r).status, 0);
    prove("report",
          {
              {"dir", r, "report " + d + "/absent"},
              {"--regenerate", r, r + " --regenerate"},
              {"--preview-size",
               r + " --regenerate",
               "report " + camp + " --regenerate --preview-size 32 --preview-samples 12",
               "",
               camp + "/previews"},
              {"--preview-samples",
               r + " --regenerate",
               "report " + camp + " --regenerate --preview-size 24 --preview-samples 48",
               "",
               camp + "/previews"},
              // The Blender rendering and its measured difference join the previews.
              {"--blender",
               r + " --regenerate",
               r + " --regenerate --blender",
               "",
               camp + "/previews"},
          });
}

}  // namespace
