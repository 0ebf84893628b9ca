// Campaigns end to end on the virtual rig: the real Modbus TCP stack on 127.0.0.1 (ephemeral
// ports) and the USB3 Vision camera emulator, GGX + Lambert ground truth; kill -9 at seeded random
// exposures, Ctrl-C, drive alarms, dropped connections and frames, lamp drift.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <thread>

#include "campaign_fixture.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::acquisition {
namespace {

namespace fs = std::filesystem;
using brdf::kPi;

const char* kModel = R"({
    "diffuse": [0.3, 0.3, 0.3],
    "lobes": [{"distribution": "ggx", "alpha": 0.25, "shadowing": "smith-correlated",
               "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]
})";

using Fixture = testing::CampaignFixture;
using testing::LiveRig;

/// A fresh campaign folder with a small plan on the sim4 rig at a large time scale; with
/// `quiet_rig` the rig's error budget is the quiet one (the detector's noise only), for tests
/// that read exact levels.
Fixture make_campaign(
    const std::string& name, int n_theta, int n_dphi, int drift_every, bool quiet_rig = false) {
    CampaignSpec spec = default_campaign_spec("ggx-test");
    spec.uniform.n_theta = n_theta;
    spec.uniform.n_dphi = n_dphi;
    spec.adaptive = false;
    spec.drift_every = drift_every;
    return testing::make_campaign_fixture(name, kModel, spec, quiet_rig);
}

LiveRig start_rig(const Fixture& f, double time_scale = 500) {
    return testing::start_live_rig(f, time_scale);
}

RunHooks quiet() {
    return testing::quiet_hooks();
}

/// (pass, index) -> number of measurement records.
std::map<std::pair<int, std::uint32_t>, int> measured(const std::string& dir) {
    auto j = Journal::open(dir + "/journal.log");
    EXPECT_TRUE(j) << j.error().message;
    std::map<std::pair<int, std::uint32_t>, int> m;
    for (const JournalRecord& r : j->records()) {
        if (r.type == RecordType::kMeasurement) {
            m[{r.pass, r.index}]++;
        }
    }
    return m;
}

std::set<std::pair<int, std::uint32_t>> planned(const Fixture& f) {
    auto p = build_plan(f.spec, f.rig);
    EXPECT_TRUE(p);
    std::set<std::pair<int, std::uint32_t>> s;
    for (const PlannedConfig& c : p->configs) {
        s.insert({0, c.index});
    }
    return s;
}

void expect_exact(const Fixture& f) {
    const auto m = measured(f.dir);
    const auto want = planned(f);
    std::set<std::pair<int, std::uint32_t>> got;
    for (const auto& [k, n] : m) {
        EXPECT_EQ(n, 1) << "configuration " << k.first << ":" << k.second << " measured " << n
                        << " times";
        got.insert(k);
    }
    EXPECT_EQ(got, want);
}

TEST(Campaign, MeasuresTheGroundTruthWithinItsUncertainty) {
    Fixture f = make_campaign("e2e", 5, 4, 0);
    LiveRig r = start_rig(f);
    auto res = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(res) << res.error().message;
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    expect_exact(f);
    auto ds = brdf::read_dataset_csv(f.dir + "/dataset.csv");
    ASSERT_TRUE(ds) << ds.error().message;
    EXPECT_TRUE(ds->rejected.empty());
    auto truth = brdf::load_brdf(f.model);
    ASSERT_TRUE(truth);
    ASSERT_GT(ds->samples.size(), 30u);
    int within3 = 0;
    for (const brdf::Sample& s : ds->samples) {
        const double t = (*truth)->eval(s.wi(), s.wo()).mean();
        const double v = s.value.mean();
        // Noise (sigma from pixel statistics) plus the systematic part: the camera renders the
        // directions the stages reach (0.001 deg steps), so a 1e-3 relative allowance.
        const double tol = 3 * s.sigma.mean() + 1e-3 * t;
        within3 += std::abs(v - t) <= tol;
        EXPECT_NEAR(v, t, 6 * s.sigma.mean() + 2e-3 * t)
            << "theta_i " << s.theta_i << " theta_o " << s.theta_o;
        EXPECT_GT(s.sigma.mean(), 0);
    }
    // Gaussian errors: about 99.7% within 3 sigma; allow a few.
    EXPECT_GE(within3, static_cast<int>(0.95 * ds->samples.size()));
    // Metadata sidecar.
    std::ifstream meta(f.dir + "/metadata.json");
    std::stringstream ss;
    ss << meta.rdbuf();
    EXPECT_NE(ss.str().find("\"state\": \"completed\""), std::string::npos);
    EXPECT_NE(ss.str().find("white_rate_counts_per_us"), std::string::npos);
    // Resuming a completed campaign measures nothing.
    auto again = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(again);
    EXPECT_EQ(again->measured_now, 0u);
    EXPECT_EQ(again->outcome, Outcome::kCompleted);
}

TEST(Campaign, KillNineAtRandomMomentsLosesNothingAndRepeatsNothing) {
    Fixture f = make_campaign("kill9", 4, 3, 0);
    const std::uint64_t seed = 424242;
    std::mt19937_64 rng(seed);
    int kills = 0;
    for (int round = 0; round < 60; ++round) {
        // Each exposure is a moment inside a measurement: moves, dark frames, auto exposure.
        std::uniform_int_distribution<int> at(1, 16);
        const int kill_at = at(rng);
        const pid_t pid = fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            LiveRig r = start_rig(f);
            r.sim->world().set_exposure_hook([kill_at](std::uint64_t n) {
                if (n == static_cast<std::uint64_t>(kill_at)) {
                    ::raise(SIGKILL);
                }
            });
            auto res = run_campaign(f.dir, r.dev, quiet());
            if (!res || res->outcome != Outcome::kCompleted) {
                std::fprintf(stderr,
                             "child: %s\n",
                             res ? res->message.c_str() : res.error().message.c_str());
            }
            _exit(res && res->outcome == Outcome::kCompleted ? 0 : 2);
        }
        int status = 0;
        ASSERT_EQ(waitpid(pid, &status, 0), pid);
        if (WIFSIGNALED(status)) {
            ASSERT_EQ(WTERMSIG(status), SIGKILL) << "seed " << seed;
            ++kills;
            continue;
        }
        ASSERT_TRUE(WIFEXITED(status)) << "seed " << seed;
        ASSERT_EQ(WEXITSTATUS(status), 0) << "seed " << seed << " round " << round;
        break;
    }
    EXPECT_GE(kills, 5) << "seed " << seed;
    expect_exact(f);
    auto ds = brdf::read_dataset_csv(f.dir + "/dataset.csv");
    ASSERT_TRUE(ds);
    EXPECT_TRUE(ds->rejected.empty());
}

TEST(Campaign, StopRequestFinishesTheMeasurementThenResumes) {
    Fixture f = make_campaign("ctrlc", 4, 3, 0);
    std::atomic<bool> stop{false};
    {
        LiveRig r = start_rig(f);
        r.sim->world().set_exposure_hook([&stop](std::uint64_t n) {
            if (n == 25) {
                stop.store(true);
            }
        });
        RunHooks h = quiet();
        h.stop = &stop;
        auto res = run_campaign(f.dir, r.dev, h);
        ASSERT_TRUE(res);
        EXPECT_EQ(res->outcome, Outcome::kInterrupted);
        // The measurement under way when asked was finished and journaled.
        EXPECT_GE(res->measured_now, 1u);
    }
    LiveRig r = start_rig(f);
    auto res = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(res);
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    expect_exact(f);
}

TEST(Campaign, DriveAlarmPausesThenResumesAfterReset) {
    Fixture f = make_campaign("alarm", 4, 3, 0);
    {
        LiveRig r = start_rig(f);
        sim::Fault fault;
        fault.kind = sim::FaultKind::kAlarmMidMove;
        fault.unit = r.sim->units().detector;
        fault.alarm_code = 0x30;
        fault.fraction = 0.5;
        r.sim->world().set_exposure_hook([&r, fault](std::uint64_t n) {
            if (n == 20) {
                r.sim->motors().inject(fault);
            }
        });
        auto res = run_campaign(f.dir, r.dev, quiet());
        ASSERT_TRUE(res);
        EXPECT_EQ(res->outcome, Outcome::kPaused);
        EXPECT_NE(res->message.find("alarm code 48"), std::string::npos) << res->message;
        EXPECT_NE(res->message.find("detector"), std::string::npos) << res->message;
        auto ds = brdf::read_dataset_csv(f.dir + "/dataset.csv");
        ASSERT_TRUE(ds);
        EXPECT_TRUE(ds->rejected.empty());
        // The operator clears the alarm, then resumes.
        ASSERT_TRUE(r.dev.axes[1]->reset_alarm());
        auto res2 = run_campaign(f.dir, r.dev, quiet());
        ASSERT_TRUE(res2);
        EXPECT_EQ(res2->outcome, Outcome::kCompleted) << res2->message;
    }
    expect_exact(f);
}

TEST(Campaign, DroppedConnectionsAndFramesAreRecovered) {
    Fixture f = make_campaign("faults", 4, 3, 0);
    LiveRig r = start_rig(f);
    std::thread arm;
    r.sim->world().set_exposure_hook([&r, &arm](std::uint64_t n) {
        if (n == 15) {
            sim::Fault fault;
            fault.kind = sim::FaultKind::kDropConnection;
            fault.count = 2;
            r.sim->motors().inject(fault);
        }
        if (n == 30) {
            // The hook runs inside the camera's frame rendering, which holds the device: arm the
            // dropped frames from another thread, effective from the next frames on.
            arm = std::thread([&r]() {
                sim::GigeFaults cf;
                cf.drop_frames = 2;
                r.sim->camera().set_faults(cf);
            });
        }
    });
    auto res = run_campaign(f.dir, r.dev, quiet());
    if (arm.joinable()) {
        arm.join();
    }
    EXPECT_GE(r.sim->world().exposures(), 30u);
    // Both frames were withheld whole by the camera and taken again by the capture.
    EXPECT_EQ(r.sim->camera_server().stats().frames_dropped, 2u);
    ASSERT_TRUE(res) << res.error().message;
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    expect_exact(f);
}

TEST(Campaign, LampDriftPausesWithAClearMessage) {
    // Quiet: the drift it reads is the lamp's 20 %, not that and a fluctuation.
    Fixture f = make_campaign("drift", 4, 3, 4, true);
    LiveRig r = start_rig(f);
    r.sim->world().set_exposure_hook([&r](std::uint64_t n) {
        if (n == 40) {
            r.sim->world().set_lamp_factor(0.8);
        }
    });
    auto res = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(res);
    ASSERT_EQ(res->outcome, Outcome::kPaused);
    EXPECT_NE(res->message.find("lamp drift"), std::string::npos) << res->message;
    EXPECT_NE(res->message.find("-20"), std::string::npos) << res->message;
    // Resuming without accepting pauses again; accepting re-baselines and completes.
    auto again = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(again);
    EXPECT_EQ(again->outcome, Outcome::kPaused);
    RunHooks h = quiet();
    h.accept_drift = true;
    auto done = run_campaign(f.dir, r.dev, h);
    ASSERT_TRUE(done);
    EXPECT_EQ(done->outcome, Outcome::kCompleted) << done->message;
    expect_exact(f);
}

}  // namespace
}  // namespace gonio::acquisition
