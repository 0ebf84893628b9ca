// Anisotropic image mode end to end on the virtual rig: a turned sphere of a brushed GGX material
// (alpha_x = 0.1, alpha_y = 0.3, no Fresnel term: the sphere's pixels stop at 80 degrees, where
// Schlick's f0 and the lobe's scale cannot be told apart) on the sample holder, rendered by the
// GigE Vision camera at every spin the plan asks for, binned into the 4-D table and fitted with
// `gonio fit --anisotropic`: the brushing at 0 and at 30 degrees gives back alpha_x, alpha_y and
// orientation_deg within 4 of the sigmas the fit reports, an isotropic truth fits alpha_x =
// alpha_y within 4 sigma of their difference. A campaign killed (SIGKILL) inside its set-up, after
// a journaled frame and in the middle of a frame resumes without losing or repeating a pose, and
// the options image mode cannot honour for anisotropic samples are refused with exit status 2.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_run.h"
#include "embedded_rig.h"
#include "gonio/acquisition/image/image_journal.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/brdf/dataset.h"
#include "image_test_support.h"

namespace gonio::tools {
namespace {

namespace fs = std::filesystem;
using gonio::testing::run_gonio;

std::string image_aniso_dir(const std::string& name) {
    return gonio::testing::test_folder("test_tools_image_aniso", name, true);
}

using gonio::testing::read_text;

std::string brushed_model(double ax, double ay, double phi_deg) {
    std::ostringstream m;
    m << R"({"diffuse": [0.05, 0.05, 0.05], "lobes": [{"distribution": "ggx", "alpha_x": )" << ax
      << R"(, "alpha_y": )" << ay << R"(, "orientation_deg": )" << phi_deg
      << R"(, "shadowing": "smith-correlated", "fresnel": {"type": "none"},
         "scale": [0.9, 0.9, 0.9]}]})";
    return m.str();
}

const char* kIsotropicModel =
    R"({"diffuse": [0.05, 0.05, 0.05], "lobes": [{"distribution": "ggx", "alpha": 0.15,
        "shadowing": "smith-correlated", "fresnel": {"type": "none"},
        "scale": [0.9, 0.9, 0.9]}]})";

/// The largest error allowed of a recovered width (relative) and orientation (degrees) on the turned sphere,
/// whatever the reported sigma.
constexpr double kRelativeCap = 0.02;
constexpr double kAngleCapDeg = 0.5;

struct Param {
    double value = 0;
    double sigma = -1;
};

/// Measures `truth` with the anisotropic image plan through the binary (the virtual rig's default
/// 256 x 256 telecentric camera) and fits the dataset; returns the fit report's parameters.
std::map<std::string, Param> measure_and_fit(const std::string& name, const std::string& truth) {
    const std::string dir = image_aniso_dir(name);
    const std::string model = dir + "/truth.json";
    std::ofstream(model) << truth;
    int st = 0;
    const std::string acq =
        run_gonio("acquire --mode image --anisotropic --brdf " + model + " --out " + dir +
                      "/run --coverage-target 0.3 "
                      "--time-scale 500",
                  &st);
    EXPECT_EQ(st, 0) << acq;
    EXPECT_NE(acq.find("valid bins"), std::string::npos) << acq;
    EXPECT_NE(acq.find("anisotropic: 12x24x8x12 (theta_h x phi_h x theta_d x phi_d) table"),
              std::string::npos)
        << acq;
    EXPECT_NE(acq.find("0 exposures repeated, 0 poses corrected"), std::string::npos) << acq;
    // The closing coverage line keeps its form.
    EXPECT_NE(acq.find("% of 20928 valid bins"), std::string::npos) << acq;
    // Several spins were used, each frame's spin in dataset.json.
    const nlohmann::json meta = nlohmann::json::parse(read_text(dir + "/run/dataset.json"));
    EXPECT_TRUE(meta.at("anisotropic").get<bool>());
    std::set<double> spins;
    for (const auto& f : meta.at("frames")) {
        spins.insert(f.at("spin_deg").get<double>());
    }
    EXPECT_GE(spins.size(), 4u);
    EXPECT_GE(meta.at("coverage").at("achieved").get<double>(), 0.3);
    // The dataset keeps both azimuths (the light is not at phi_i = 0).
    auto ds = brdf::read_dataset_csv(dir + "/run/dataset.csv");
    EXPECT_TRUE(ds) << ds.error().message;
    if (ds) {
        std::size_t off_axis = 0;
        for (const auto& s : ds->samples) {
            off_axis += std::abs(std::sin(s.phi_i)) > 0.3 && s.theta_i > 0.1;
        }
        EXPECT_GT(off_axis, ds->samples.size() / 4);
        EXPECT_GT(ds->samples.size(), 5000u);
    }
    const std::string fit = run_gonio("fit " + dir +
                                          "/run/dataset.csv --anisotropic --fresnel "
                                          "none --out " +
                                          dir + "/fit.json",
                                      &st);
    EXPECT_EQ(st, 0) << fit;
    std::map<std::string, Param> out;
    const nlohmann::json j = nlohmann::json::parse(read_text(dir + "/fit.report.json"));
    for (const auto& p : j.at("parameters")) {
        Param q;
        q.value = p.at("value").is_number() ? p.at("value").get<double>() : NAN;
        q.sigma = p.at("sigma").is_number() ? p.at("sigma").get<double>() : -1;
        out[p.at("name").get<std::string>()] = q;
    }
    fs::remove_all(dir);
    return out;
}

/// |value - truth| within k sigma, an orientation compared modulo 180 degrees.
/// Within `k` of the reported sigmas of the truth, and within `cap` of it whatever the sigma (a
/// sigma grown large would otherwise let any value pass): a relative cap for a width, degrees for
/// an angle.
void expect_within(const Param& p, double truth, double k, bool angle, const char* what) {
    ASSERT_GT(p.sigma, 0) << what;
    double d = p.value - truth;
    if (angle) {
        d -= 180 * std::round(d / 180);
    }
    EXPECT_LE(std::abs(d), k * p.sigma)
        << what << " = " << p.value << " +- " << p.sigma << ", truth " << truth;
    const double cap = angle ? kAngleCapDeg : kRelativeCap * std::abs(truth);
    EXPECT_LE(std::abs(d), cap) << what << " = " << p.value << ", truth " << truth
                                << ": off by more than " << cap;
}

void expect_recovered(const std::string& name, double phi_deg) {
    const auto p = measure_and_fit(name, brushed_model(0.1, 0.3, phi_deg));
    ASSERT_TRUE(p.count("lobes[0].alpha_x") && p.count("lobes[0].orientation_deg"));
    const Param ax = p.at("lobes[0].alpha_x");
    const Param ay = p.at("lobes[0].alpha_y");
    const Param phi = p.at("lobes[0].orientation_deg");
    expect_within(ax, 0.1, 4, false, "alpha_x");
    expect_within(ay, 0.3, 4, false, "alpha_y");
    expect_within(phi, phi_deg, 4, true, "orientation_deg");
    // Sigmas small enough to tell the lobe apart.
    EXPECT_LT(ax.sigma, 0.005);
    EXPECT_LT(ay.sigma, 0.01);
    EXPECT_LT(phi.sigma, 1);
}

TEST(ImageAnisotropic, TurnedSphereBrushedAlongTheHolderAxisIsRecovered) {
    expect_recovered("brushed0", 0);
}

TEST(ImageAnisotropic, TurnedSphereBrushedAt30DegreesIsRecovered) {
    expect_recovered("brushed30", 30);
}

TEST(ImageAnisotropic, PerspectiveCameraRecoversTheBrushingAt30Degrees) {
    // The default perspective camera (0.5 m from the sphere; its distance from the outline's
    // apparent radius): the run of the command in process, the fit through the binary.
    const std::string dir = image_aniso_dir("perspective");
    std::ofstream(dir + "/truth.json") << brushed_model(0.1, 0.3, 30);
    acquisition::CampaignRequest r;
    r.mode = acquisition::CampaignMode::kImage;
    r.anisotropic = true;
    r.perspective = true;
    r.brdf_path = dir + "/truth.json";
    r.out_dir = dir + "/run";
    r.coverage_target = 0.3;
    r.time_scale = 500;
    auto run = acquisition::run_image_request(r, embedded_rig_starter());
    ASSERT_TRUE(run) << run.error().message;
    ASSERT_TRUE(run->result->target_met) << run->result->stop_reason;
    EXPECT_EQ(run->config.camera.projection, acquisition::Projection::kPerspective);
    // The sphere within half a millimetre of the rig origin.
    EXPECT_LT(run->result->sphere.centre.norm(), 5e-4) << run->result->sphere.centre.transpose();
    int st = 0;
    const std::string fit = run_gonio("fit " + dir +
                                          "/run/dataset.csv --anisotropic --fresnel "
                                          "none --out " +
                                          dir + "/fit.json",
                                      &st);
    ASSERT_EQ(st, 0) << fit;
    const nlohmann::json j = nlohmann::json::parse(read_text(dir + "/fit.report.json"));
    std::map<std::string, Param> p;
    for (const auto& q : j.at("parameters")) {
        p[q.at("name").get<std::string>()] = {
            q.at("value").get<double>(),
            q.at("sigma").is_number() ? q.at("sigma").get<double>() : -1};
    }
    expect_within(p["lobes[0].alpha_x"], 0.1, 4, false, "alpha_x");
    expect_within(p["lobes[0].alpha_y"], 0.3, 4, false, "alpha_y");
    expect_within(p["lobes[0].orientation_deg"], 30, 4, true, "orientation_deg");
    fs::remove_all(dir);
}

TEST(ImageAnisotropic, IsotropicTruthFitsEqualSlopes) {
    const auto p = measure_and_fit("iso", kIsotropicModel);
    ASSERT_TRUE(p.count("lobes[0].alpha_x") && p.count("lobes[0].alpha_y"));
    const Param ax = p.at("lobes[0].alpha_x");
    const Param ay = p.at("lobes[0].alpha_y");
    ASSERT_GT(ax.sigma, 0);
    ASSERT_GT(ay.sigma, 0);
    EXPECT_LE(std::abs(ax.value - ay.value), 4 * std::hypot(ax.sigma, ay.sigma))
        << ax.value << " +- " << ax.sigma << " vs " << ay.value << " +- " << ay.sigma;
    expect_within(ax, 0.15, 4, false, "alpha_x");
    expect_within(ay, 0.15, 4, false, "alpha_y");
}

TEST(ImageAnisotropic, OptionsItCannotHonourAreRefused) {
    int st = 0;
    std::string out = run_gonio("acquire --mode image --anisotropic --symmetry 2-fold", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--symmetry cannot be combined with --mode image"), std::string::npos)
        << out;
    out = run_gonio("acquire --mode image --anisotropic --grid 30x30x60", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--grid cannot be combined with --anisotropic"), std::string::npos) << out;
    // An anisotropic truth without --anisotropic: the isotropic table cannot hold it.
    const std::string dir = image_aniso_dir("refused");
    std::ofstream(dir + "/truth.json") << brushed_model(0.1, 0.3, 0);
    out =
        run_gonio("acquire --mode image --brdf " + dir + "/truth.json --out " + dir + "/run", &st);
    EXPECT_EQ(st, 1) << out;
    EXPECT_NE(out.find("measure it with --anisotropic"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir + "/run/frames.journal"));
    // The plan is printed with its spins and poses.
    out = run_gonio("acquire --mode image --anisotropic --plan-only --camera-px 64", &st);
    EXPECT_EQ(st, 0) << out;
    EXPECT_NE(out.find("spin in [-180.0, 180.0] deg every 7.50 deg"), std::string::npos) << out;
    EXPECT_NE(out.find("candidate poses"), std::string::npos) << out;
    fs::remove_all(dir);
}

TEST(ImageAnisotropic, CommandResumesFromTheFolderSettings) {
    // A campaign stopped by its frame limit, continued with --resume: the folder's settings
    // (image_campaign.json) keep it anisotropic, the journal's poses are not taken again.
    const std::string dir = image_aniso_dir("cli_resume");
    std::ofstream(dir + "/truth.json") << brushed_model(0.15, 0.35, 20);
    int st = 0;
    std::string out = run_gonio("acquire --mode image --anisotropic --camera-px 64 --brdf " + dir +
                                    "/truth.json --out " + dir +
                                    "/run --max-frames 3 --coverage-target 0.1 --time-scale 500",
                                &st);
    EXPECT_EQ(st, 1) << out;  // the target is not met in 3 frames
    EXPECT_NE(out.find("stopped: frame limit"), std::string::npos) << out;
    const nlohmann::json settings =
        nlohmann::json::parse(read_text(dir + "/run/image_campaign.json"));
    EXPECT_TRUE(settings.at("anisotropic").get<bool>());
    out = run_gonio("acquire --resume " + dir + "/run", &st);
    // The frame limit is the campaign's own: the resume reads 3 frames and stops there too.
    EXPECT_NE(out.find("resumed: 3 frames"), std::string::npos) << out;
    EXPECT_NE(out.find("anisotropic: 12x24x8x12"), std::string::npos) << out;
    const nlohmann::json meta = nlohmann::json::parse(read_text(dir + "/run/dataset.json"));
    EXPECT_TRUE(meta.at("anisotropic").get<bool>());
    EXPECT_EQ(meta.at("frames").size(), 3u);
    out = run_gonio("acquire --resume " + dir + "/run --anisotropic", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--anisotropic cannot be combined with --resume"), std::string::npos) << out;
    fs::remove_all(dir);
}

// ---- resume after SIGKILL ------------------------------------------------------------------

struct AnisoCampaign {
    acquisition::ImageRigOptions rig;
    acquisition::AnisoLayout layout{8, 12, 6, 8};
    double coverage_target = 0.3;
    int max_frames = 60;
};

Expected<std::unique_ptr<acquisition::ImageRig>> start_aniso_rig(const AnisoCampaign& o) {
    return acquisition::start_image_rig(o.rig, embedded_rig_starter());
}

acquisition::ImageCampaignConfig aniso_config_of(const AnisoCampaign& o,
                                                 const acquisition::ImageRig& rig) {
    acquisition::ImageCampaignConfig cfg =
        acquisition::image_campaign_config(rig.rig, rig.camera, 6, o.coverage_target, o.max_frames);
    acquisition::make_anisotropic(&cfg, rig.rig, o.layout);
    return cfg;
}

/// The campaign in a child process killed with SIGKILL at the `kill_exposure`-th exposure the
/// virtual camera renders, or right after frame `kill_after_frames` is journaled (0: never).
int killed_child(const AnisoCampaign& o,
                 const std::string& journal,
                 std::uint64_t kill_exposure,
                 std::size_t kill_after_frames) {
    return image_test::campaign_in_child(o.rig, kill_exposure, [&](acquisition::ImageRig& rig) {
        const acquisition::ImageCampaignConfig cfg = aniso_config_of(o, rig);
        auto progress = [kill_after_frames](std::size_t i, const acquisition::FrameRecord&) {
            if (kill_after_frames > 0 && i + 1 == kill_after_frames) {
                ::raise(SIGKILL);
            }
        };
        return acquisition::run_image_campaign(
                   acquisition::image_rig_capture(rig, cfg.detector_arm_rad, true),
                   cfg,
                   progress,
                   journal)
            .has_value();
    });
}

TEST(ImageAnisotropic, KillNineAtThreeMomentsLosesNoPoseAndRepeatsNone) {
    const std::string dir = image_aniso_dir("resume");
    const std::string model = dir + "/truth.json";
    std::ofstream(model) << brushed_model(0.15, 0.35, 20);
    const std::string journal = dir + "/frames.journal";
    AnisoCampaign o;
    o.rig.brdf_path = model;
    o.rig.image_size = 96;
    o.rig.supersample = 1;
    o.rig.seed = 77;
    o.rig.time_scale = 500;

    // 1. Inside the set-up: nothing journaled.
    int st = killed_child(o, journal, 3, 0);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        EXPECT_FALSE(j->setup());
    }
    // 2. Right after the second frame is journaled.
    st = killed_child(o, journal, 0, 2);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    const std::string after_two = read_text(journal);
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        ASSERT_TRUE(j->setup());
        EXPECT_TRUE(j->setup()->anisotropic);
        ASSERT_EQ(j->frames().size(), 2u);
    }
    // 3. In the middle of a later frame's captures.
    st = killed_child(o, journal, 40, 0);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    const std::string after_three = read_text(journal);
    ASSERT_GE(after_three.size(), after_two.size());
    EXPECT_EQ(after_three.substr(0, after_two.size()), after_two) << "a journaled frame was lost";
    std::size_t frames_at_kill = 0;
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        frames_at_kill = j->frames().size();
        EXPECT_GT(frames_at_kill, 2u) << "the third kill came before a new frame";
    }

    // To the end, in this process.
    auto rig = start_aniso_rig(o);
    ASSERT_TRUE(rig) << rig.error().message;
    const acquisition::ImageCampaignConfig cfg = aniso_config_of(o, **rig);
    auto r = acquisition::run_image_campaign(
        acquisition::image_rig_capture(**rig, cfg.detector_arm_rad, true), cfg, {}, journal);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_TRUE(r->target_met) << r->stop_reason;
    EXPECT_EQ(r->resumed_frames, frames_at_kill);
    ASSERT_TRUE(r->aniso_table);
    EXPECT_EQ(read_text(journal).substr(0, after_three.size()), after_three);

    auto j = acquisition::ImageJournal::open(journal);
    ASSERT_TRUE(j) << j.error().message;
    ASSERT_EQ(j->frames().size(), r->frames.size());
    // No pose measured twice; several spins; every journaled sample in the table once.
    std::vector<std::pair<double, double>> poses;
    std::set<double> spins;
    std::uint64_t used = 0;
    std::uint64_t in_bins = 0;
    for (const acquisition::ImageJournalFrame& f : j->frames()) {
        EXPECT_TRUE(f.anisotropic);
        poses.emplace_back(f.light_arm_rad, f.spin_rad);
        spins.insert(f.spin_rad);
        used += f.counts.used;
        for (const acquisition::AnisoBinAggregate& a : f.aniso_bins) {
            in_bins += a.count;
        }
    }
    for (std::size_t k = 0; k < poses.size(); ++k) {
        EXPECT_EQ(poses[k].first, r->frames[k].light_arm_rad);
        EXPECT_EQ(poses[k].second, r->frames[k].spin_rad);
    }
    std::sort(poses.begin(), poses.end());
    EXPECT_EQ(std::adjacent_find(poses.begin(), poses.end()), poses.end())
        << "a pose was measured twice";
    EXPECT_GE(spins.size(), 3u);
    EXPECT_EQ(used, in_bins);
    EXPECT_EQ(r->aniso_table->total_samples(), used);
    EXPECT_EQ(r->counts.used, used);
    // The virtual rig's spin axis stands where the last pose put it.
    const sim::RigUnits& u = simulator(**rig)->units();
    EXPECT_NEAR(simulator(**rig)->motors().position_deg(u.spin),
                r->frames.back().spin_rad * 180 / brdf::kPi,
                0.01);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace gonio::tools
