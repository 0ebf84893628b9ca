// Fly scans on the virtual rig (real Modbus TCP drives with their touch probes, the GigE Vision
// camera emulator): the rig time a fly campaign records equals the simulated drives' moves into
// each sweep, the sweeps at their cruise speed (the drives' own trapezoids, sim/motor_sim.h), the
// standing moves and the exposures the camera integrated while everything stood; the frames taken
// during the sweeps add nothing. The same plan measured stop-and-go costs more rig time. Each
// swept value carries its exposure's path, latched by the drive around its mid-exposure angle.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign_fixture.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/brdf/dataset.h"
#include "gonio/sim/motor_sim.h"

namespace gonio::acquisition {
namespace {

using testing::make_campaign_fixture;
using testing::quiet_hooks;
using testing::start_live_rig;

const char* kGgx = R"({"diffuse": [0.02, 0.02, 0.02],
    "lobes": [{"distribution": "ggx", "alpha": 0.05, "shadowing": "smith-correlated",
               "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]})";

using testing::read_json;
using testing::sim_move_s;

/// A uniform in-plane plan (delta_phi 0 and 180 deg): one detector sweep per incidence.
CampaignSpec in_plane_spec(bool fly) {
    CampaignSpec spec = default_campaign_spec("fly-ggx");
    spec.uniform.n_theta = 8;
    spec.uniform.n_dphi = 2;
    spec.adaptive = false;
    spec.drift_every = 0;
    spec.fly.enabled = fly;
    return spec;
}

struct Kinematics {
    double motion = 0;
    double settle = 0;
    int sweeps = 0;
};

/// The rig's motion from the journal alone: from the sim's power-up pose, a move (the slowest
/// axis's simulated profile, then the slowest settle of the axes that moved) into each standing
/// pose and each sweep's lead-in, and each sweep from its lead-in to its lead-out at its speed.
/// Values measured during a sweep take no motion of their own.
Kinematics journal_kinematics(const std::string& dir) {
    auto jn = Journal::open(dir + "/journal.log");
    EXPECT_TRUE(jn) << jn.error().message;
    const nlohmann::json rig = read_json(dir + "/rig.json");
    std::array<double, 4> pose = {0, 45, 0, 0};
    Kinematics k;
    auto move_to = [&](const std::array<double, 4>& to) {
        double m = 0, st = 0;
        for (int a = 0; a < 4; ++a) {
            const double d = std::abs(to[a] - pose[a]);
            if (d <= 0.002) {
                continue;
            }
            const nlohmann::json& axis = rig["axes"][a];
            m = std::max(m,
                         sim_move_s(d,
                                    axis["speed_deg_per_s"].get<double>(),
                                    axis["accel_deg_per_s2"].get<double>()));
            st = std::max(st, axis["settle_ms"].get<double>() / 1000);
        }
        k.motion += m;
        k.settle += st;
        pose = to;
    };
    for (const JournalRecord& r : jn->records()) {
        if (r.type == RecordType::kNote || (r.type == RecordType::kMeasurement && r.has_path)) {
            continue;
        }
        move_to(r.pose_deg);
        if (r.type == RecordType::kSweep) {
            int a = 0;
            for (int b = 0; b < 4; ++b) {
                a = std::abs(r.path_end_deg[b] - r.path_start_deg[b]) > 1e-9 ? b : a;
            }
            k.motion += sim_move_s(std::abs(r.path_end_deg[a] - r.path_start_deg[a]),
                                   r.speed_deg_per_s,
                                   rig["axes"][a]["accel_deg_per_s2"].get<double>());
            pose = r.path_end_deg;
            ++k.sweeps;
        }
    }
    return k;
}

TEST(FlyCampaign, RigTimeIsTheSimulatedSweepsAndStandingTimeAndBeatsStopAndGo) {
    auto f =
        make_campaign_fixture("fly_rig_time", kGgx, in_plane_spec(true), true, "sim4-mono.json");
    auto live = start_live_rig(f, 5);
    ASSERT_TRUE(live.sim);
    auto res = run_campaign(f.dir, live.dev, quiet_hooks());
    ASSERT_TRUE(res) << res.error().message;
    ASSERT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    EXPECT_GT(res->sweeps, 4u);
    EXPECT_GT(res->swept, res->measured_now / 2) << res->standing << " measured standing";

    const Kinematics k = journal_kinematics(f.dir);
    EXPECT_EQ(static_cast<std::size_t>(k.sweeps), res->sweeps);
    const nlohmann::json meta = read_json(f.dir + "/metadata.json");
    const nlohmann::json& run = meta["runs"][0];
    const nlohmann::json& fly = run["fly"];
    // Only the frames taken standing (white reference, dark frames, standing measurements) add
    // exposure and readout: the sweeps' frames overlap their motion.
    const double exposure =
        live.sim->camera().exposure_s_rendered() - fly["moving_exposure_s"].get<double>();
    const double frames = static_cast<double>(live.sim->camera().frames_rendered()) -
                          fly["moving_frames"].get<double>();
    const double readout = frames * f.rig.camera_readout_ms / 1000;
    EXPECT_GT(fly["moving_frames"].get<double>(), 0);
    const nlohmann::json& parts = run["rig_time"];
    EXPECT_NEAR(parts["motion_s"].get<double>(), k.motion, 1e-3 * k.motion);
    EXPECT_NEAR(parts["settle_s"].get<double>(), k.settle, 1e-9);
    EXPECT_NEAR(parts["exposure_s"].get<double>(), exposure, 1e-6 * exposure);
    EXPECT_NEAR(parts["readout_s"].get<double>(), readout, 1e-9);
    const double total = k.motion + k.settle + exposure + readout;
    EXPECT_NEAR(run["rig_time_s"].get<double>(), total, 1e-3 * total);

    // The same plan measured standing.
    auto g =
        make_campaign_fixture("still_rig_time", kGgx, in_plane_spec(false), true, "sim4-mono.json");
    auto still_rig = start_live_rig(g, 200);
    ASSERT_TRUE(still_rig.sim);
    auto still = run_campaign(g.dir, still_rig.dev, quiet_hooks());
    ASSERT_TRUE(still) << still.error().message;
    ASSERT_EQ(still->outcome, Outcome::kCompleted) << still->message;
    EXPECT_EQ(still->measured_total, res->measured_total);
    const double still_s = read_json(g.dir + "/metadata.json")["rig_time_s"].get<double>();
    std::printf("rig time: fly %.1f s, stop-and-go %.1f s (%zu configurations, %zu swept)\n",
                run["rig_time_s"].get<double>(),
                still_s,
                res->measured_total,
                res->swept);
    EXPECT_LT(run["rig_time_s"].get<double>(), still_s);
}

TEST(FlyCampaign, SweptValuesCarryTheLatchedPathAroundTheirDirections) {
    auto f = make_campaign_fixture("fly_paths", kGgx, in_plane_spec(true), true, "sim4-mono.json");
    auto live = start_live_rig(f, 5);
    ASSERT_TRUE(live.sim);
    auto res = run_campaign(f.dir, live.dev, quiet_hooks());
    ASSERT_TRUE(res) << res.error().message;
    ASSERT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    auto ds = brdf::read_dataset_csv(f.dir + "/dataset.csv");
    ASSERT_TRUE(ds) << ds.error().message;
    EXPECT_TRUE(ds->has_path);
    std::size_t swept = 0;
    for (const brdf::Sample& s : ds->samples) {
        if (!s.has_path) {
            continue;
        }
        ++swept;
        // One arm stood; the other's direction ran along an arc of at most the smear bound (1
        // deg), and the value's own direction is the arc's middle.
        const brdf::Vec3d wi0 = brdf::spherical_to_cartesian(s.path_start[0], s.path_start[1]);
        const brdf::Vec3d wi1 = brdf::spherical_to_cartesian(s.path_end[0], s.path_end[1]);
        const brdf::Vec3d wo0 = brdf::spherical_to_cartesian(s.path_start[2], s.path_start[3]);
        const brdf::Vec3d wo1 = brdf::spherical_to_cartesian(s.path_end[2], s.path_end[3]);
        const bool light_swept = (wi0 - wi1).norm() > 1e-9;
        const brdf::Vec3d a0 = light_swept ? wi0 : wo0;
        const brdf::Vec3d a1 = light_swept ? wi1 : wo1;
        const brdf::Vec3d mid = light_swept ? s.wi() : s.wo();
        const brdf::Vec3d stood = light_swept ? s.wo() : s.wi();
        EXPECT_LT(((light_swept ? wo0 : wi0) - stood).norm(), 1e-6);
        EXPECT_LT(((light_swept ? wo1 : wi1) - stood).norm(), 1e-6);
        const double arc = std::acos(std::min(1.0, a0.dot(a1)));
        EXPECT_GT(arc, 0);
        EXPECT_LE(arc, 1.0 * brdf::kPi / 180 + 1e-6);
        EXPECT_NEAR(std::acos(std::min(1.0, a0.dot(mid))), 0.5 * arc, 1e-6);
        EXPECT_NEAR(std::acos(std::min(1.0, a1.dot(mid))), 0.5 * arc, 1e-6);
    }
    EXPECT_EQ(swept, res->swept);
    EXPECT_GT(swept, 20u);
}

}  // namespace
}  // namespace gonio::acquisition
