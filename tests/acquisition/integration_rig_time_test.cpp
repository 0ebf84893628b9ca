// The virtual rig as a real one: rig time and the error budget.
// - The seconds a point campaign records in metadata.json equal the moves the simulated drives
//   make (their own trapezoidal profiles, sim/motor_sim.h, not acquisition's), their settling and
//   the exposures the simulated camera integrated; and each run says why it stopped.
// - On the reference error budget (lamp, arms, stray light, non-linearity) the sigmas the
//   campaign states cover its values: at least 95 % within 3 sigma of the ground truth, on a
//   glossy GGX 0.05 truth whose peak makes the angular terms count.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign_fixture.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/sim/motor_sim.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::acquisition {
namespace {

namespace fs = std::filesystem;

using testing::read_json;
using testing::sim_move_s;

TEST(RigTime, EqualsTheSimulatedMovesSettlesAndExposures) {
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_campaigns/rig_time_" + std::to_string(::getpid());
    fs::remove_all(dir);
    fs::create_directories(dir);
    auto rig = read_rig_config(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    ASSERT_TRUE(rig) << rig.error().message;
    CampaignSpec spec = default_campaign_spec("rig-time");
    spec.uniform.n_theta = 3;
    spec.uniform.n_dphi = 2;
    spec.adaptive = false;
    spec.drift_every = 0;
    spec.rig = "rig.json";
    spec.json = campaign_spec_json(spec);
    ASSERT_TRUE(create_campaign_dir(dir, spec, *rig));
    sim::SimRigOptions so;
    so.material = "red-plastic";
    so.time_scale = 200;
    auto s = sim::SimRig::start(rig->json, so);
    ASSERT_TRUE(s) << s.error().message;
    auto dev = open_rig(with_addresses(*rig, (*s)->motor_address(), (*s)->camera_address()));
    ASSERT_TRUE(dev) << dev.error().message;
    RunHooks hooks;
    hooks.out = nullptr;
    auto res = run_campaign(dir, *dev, hooks);
    ASSERT_TRUE(res) << res.error().message;
    ASSERT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    ASSERT_EQ(res->pose_repeats + res->pose_corrections + res->outages, 0u);

    // Independently: the moves between the poses the journal records (white reference, then the
    // measurements, in order), from the sim's power-up pose, each as long as the slowest axis's
    // simulated profile, then the slowest settle of the axes that moved (an axis moved when it
    // changed by more than two steps of the generic profile).
    auto jn = Journal::open(dir + "/journal.log");
    ASSERT_TRUE(jn) << jn.error().message;
    const nlohmann::json rig_json = read_json(dir + "/rig.json");
    std::array<double, 4> pose = {0, 45, 0, 0};
    double motion = 0, settle = 0;
    int moves = 0;
    for (const JournalRecord& r : jn->records()) {
        if (r.type == RecordType::kNote) {
            continue;
        }
        double m = 0, st = 0;
        for (int k = 0; k < 4; ++k) {
            const double d = std::abs(r.pose_deg[k] - pose[k]);
            if (d <= 0.002) {
                continue;
            }
            const nlohmann::json& axis = rig_json["axes"][k];
            m = std::max(m,
                         sim_move_s(d,
                                    axis["speed_deg_per_s"].get<double>(),
                                    axis["accel_deg_per_s2"].get<double>()));
            st = std::max(st, axis["settle_ms"].get<double>() / 1000);
        }
        moves += m > 0;
        motion += m;
        settle += st;
        pose = r.pose_deg;
    }
    ASSERT_GT(moves, 5);
    // The exposures the camera integrated and the frames it read out.
    const double exposure = (*s)->camera().exposure_s_rendered();
    const double frames = static_cast<double>((*s)->camera().frames_rendered());
    const double readout = frames * rig_json["camera"]["readout_ms"].get<double>() / 1000;
    ASSERT_GT(exposure, 0);
    ASSERT_GT(readout, 0);

    const nlohmann::json meta = read_json(dir + "/metadata.json");
    ASSERT_EQ(meta["runs"].size(), 1u);
    const nlohmann::json& run = meta["runs"][0];
    EXPECT_EQ(run["stopped"], "plan end");
    const nlohmann::json& parts = run["rig_time"];
    // Quantised read-back poses differ from the commanded ones by under a step (1e-3 deg): a
    // microsecond or so per move.
    EXPECT_NEAR(parts["motion_s"].get<double>(), motion, 1e-3 * motion);
    EXPECT_NEAR(parts["settle_s"].get<double>(), settle, 1e-9);
    EXPECT_NEAR(parts["exposure_s"].get<double>(), exposure, 1e-6 * exposure);
    EXPECT_NEAR(parts["readout_s"].get<double>(), readout, 1e-9);
    const double total = motion + settle + exposure + readout;
    EXPECT_NEAR(run["rig_time_s"].get<double>(), total, 1e-3 * total);
    EXPECT_NEAR(meta["rig_time_s"].get<double>(), total, 1e-3 * total);

    // A resume of the completed campaign adds a run that spends nothing and says so.
    auto again = run_campaign(dir, *dev, hooks);
    ASSERT_TRUE(again) << again.error().message;
    const nlohmann::json meta2 = read_json(dir + "/metadata.json");
    ASSERT_EQ(meta2["runs"].size(), 2u);
    EXPECT_EQ(meta2["runs"][1]["stopped"], "plan end");
    EXPECT_NEAR(meta2["rig_time_s"].get<double>(), meta["rig_time_s"].get<double>(), 0.05);
}

TEST(Campaign, StatedSigmasCoverTheReferenceErrorBudget) {
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_campaigns/budget_" + std::to_string(::getpid());
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string model = dir + "_model.json";
    std::ofstream(model) << R"({"diffuse": [0.05, 0.05, 0.05],
        "lobes": [{"distribution": "ggx", "alpha": 0.05, "shadowing": "smith-correlated",
                   "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]},
                   "scale": [1, 1, 1]}]})";
    auto rig = read_rig_config(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    ASSERT_TRUE(rig) << rig.error().message;
    ASSERT_EQ(rig->error_budget.profile, "reference");
    // The uniform grid and an adaptive pass that goes where the values change fastest: the
    // flanks of the peak, where an arm's angle error moves the value most.
    CampaignSpec spec = default_campaign_spec("ggx-0.05");
    spec.uniform.n_theta = 6;
    spec.uniform.n_dphi = 4;
    spec.adaptive = true;
    spec.adaptive_passes = 1;
    spec.refine.budget = 40;
    spec.drift_every = 0;
    spec.rig = "rig.json";
    spec.json = campaign_spec_json(spec);
    ASSERT_TRUE(create_campaign_dir(dir, spec, *rig));
    sim::SimRigOptions so;
    so.brdf_path = model;
    so.time_scale = 500;
    so.seed = 11;
    auto s = sim::SimRig::start(rig->json, so);
    ASSERT_TRUE(s) << s.error().message;
    auto dev = open_rig(with_addresses(*rig, (*s)->motor_address(), (*s)->camera_address()));
    ASSERT_TRUE(dev) << dev.error().message;
    RunHooks hooks;
    hooks.out = nullptr;
    auto res = run_campaign(dir, *dev, hooks);
    ASSERT_TRUE(res) << res.error().message;
    ASSERT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    auto ds = brdf::read_dataset_csv(dir + "/dataset.csv");
    ASSERT_TRUE(ds) << ds.error().message;
    auto truth = brdf::load_brdf(model);
    ASSERT_TRUE(truth);
    ASSERT_GT(ds->samples.size(), 50u);
    int within3 = 0, outside_detector_noise = 0, n = 0;
    for (const brdf::Sample& smp : ds->samples) {
        const brdf::Rgbd t = (*truth)->eval(smp.wi(), smp.wo());
        for (int c = 0; c < 3; ++c) {
            ++n;
            const double err = std::abs(smp.value[c] - t[c]);
            within3 += err <= 3 * smp.sigma[c];
            // The instrument's errors are there to cover: the detector noise alone (a few 1e-5
            // relative) leaves many values outside their 3 sigma.
            outside_detector_noise += err > 1e-3 * t[c];
        }
    }
    EXPECT_GE(within3, 0.95 * n) << within3 << " of " << n << " within 3 sigma";
    EXPECT_GT(outside_detector_noise, n / 4) << "the reference budget does not show in the data";
}

}  // namespace
}  // namespace gonio::acquisition
