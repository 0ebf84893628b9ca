// Pose integrity and device outages during campaigns on the virtual rig (real Modbus TCP on
// 127.0.0.1, GGX + Lambert ground truth): a second Modbus client moves an axis in the middle of
// exposures, the motor gateway blips for less than the reconnect window, and it stays away for
// longer. Every configuration ends up in the dataset exactly once and agrees with the ground truth;
// the repeats and the outages are journalled and counted.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "campaign_fixture.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_bus.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::acquisition {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const char* kModel = R"({
    "diffuse": [0.3, 0.3, 0.3],
    "lobes": [{"distribution": "ggx", "alpha": 0.25, "shadowing": "smith-correlated",
               "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]
})";

using Fixture = testing::CampaignFixture;
using testing::LiveRig;

Fixture make_campaign(const std::string& name) {
    CampaignSpec spec = default_campaign_spec("pose-test");
    spec.uniform.n_theta = 5;
    spec.uniform.n_dphi = 4;
    spec.adaptive = false;
    spec.drift_every = 0;
    return testing::make_campaign_fixture(name, kModel, spec);
}

LiveRig start_rig(const Fixture& f, const std::string& motor_query = "") {
    return testing::start_live_rig(f, 500, motor_query);
}

RunHooks quiet() {
    RunHooks h = testing::quiet_hooks();
    h.outage_probe_s = 0.1;
    return h;
}

/// Every planned configuration measured exactly once, every value within the noise of the
/// ground truth (the same allowance as the end-to-end campaign test).
void expect_exact_and_true(const Fixture& f) {
    auto j = Journal::open(f.dir + "/journal.log");
    ASSERT_TRUE(j) << j.error().message;
    std::map<std::uint32_t, int> n;
    for (const JournalRecord& r : j->records()) {
        if (r.type == RecordType::kMeasurement) {
            n[r.index]++;
        }
    }
    auto plan = build_plan(f.spec, f.rig);
    ASSERT_TRUE(plan);
    EXPECT_EQ(n.size(), plan->configs.size());
    for (const auto& [index, count] : n) {
        EXPECT_EQ(count, 1) << "configuration " << index;
    }
    auto ds = brdf::read_dataset_csv(f.dir + "/dataset.csv");
    ASSERT_TRUE(ds) << ds.error().message;
    auto truth = brdf::load_brdf(f.model);
    ASSERT_TRUE(truth);
    int wrong = 0;
    double worst = 0;
    for (const brdf::Sample& s : ds->samples) {
        const double t = (*truth)->eval(s.wi(), s.wo()).mean();
        const double v = s.value.mean();
        const bool ok = std::abs(v - t) <= 6 * s.sigma.mean() + 2e-3 * t;
        wrong += ok ? 0 : 1;
        worst = std::max(worst, std::abs(v / t - 1));
    }
    EXPECT_EQ(wrong, 0) << "rows off the ground truth, worst relative error " << worst;
}

int journal_notes(const Fixture& f, const std::string& needle) {
    auto j = Journal::open(f.dir + "/journal.log");
    EXPECT_TRUE(j);
    int n = 0;
    for (const JournalRecord& r : j->records()) {
        n += r.type == RecordType::kNote && r.text.find(needle) != std::string::npos;
    }
    return n;
}

TEST(PoseIntegrity, SecondClientMovingAnAxisMidExposureRepeatsTheMeasurement) {
    Fixture f = make_campaign("intruder");
    LiveRig r = start_rig(f);
    // The intruder: its own Modbus connection, moving the sample tilt (unit 3) by 4 degrees during
    // exposures 15, 40 and 65.
    auto bus = devices::ModbusBus::open(*devices::parse_bus_address(r.sim->motor_address()));
    ASSERT_TRUE(bus) << bus.error().message;
    auto profile = devices::load_axis_profile("generic");
    ASSERT_TRUE(profile);
    devices::ModbusAxis intruder(
        *bus, 3, *profile, "intruder", devices::SoftLimits{-80, 80}, devices::Motion{20, 40, 0});
    std::mutex mu;
    int intrusions = 0;
    r.sim->world().set_exposure_hook([&](std::uint64_t n) {
        if (n != 15 && n != 40 && n != 65) {
            return;
        }
        std::lock_guard<std::mutex> lock(mu);
        auto at = intruder.position_deg();
        if (at && intruder.start_move(*at > 60 ? *at - 4 : *at + 4)) {
            ++intrusions;
        }
    });
    auto res = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(res) << res.error().message;
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    EXPECT_EQ(intrusions, 3);
    std::printf("intrusions %d: %zu exposures repeated, %zu poses corrected; %s\n",
                intrusions,
                res->pose_repeats,
                res->pose_corrections,
                res->message.c_str());
    // Each intrusion is seen once: during its exposure, or before the next one.
    EXPECT_EQ(res->pose_repeats + res->pose_corrections, 3u);
    EXPECT_GE(res->pose_repeats, 1u);
    EXPECT_EQ(journal_notes(f, "pose check"),
              static_cast<int>(res->pose_repeats + res->pose_corrections));
    expect_exact_and_true(f);
    std::ifstream meta(f.dir + "/metadata.json");
    std::stringstream ss;
    ss << meta.rdbuf();
    EXPECT_NE(ss.str().find("\"pose_repeats\": " + std::to_string(res->pose_repeats)),
              std::string::npos);
}

TEST(DeviceOutage, BlipShorterThanTheWindowIsRiddenThrough) {
    Fixture f = make_campaign("blip");
    LiveRig r = start_rig(f);
    r.sim->world().set_exposure_hook([&](std::uint64_t n) {
        if (n == 30) {
            r.sim->motors().blip(600ms);
        }
    });
    auto res = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(res) << res.error().message;
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    EXPECT_EQ(res->outages, 0u);
    // The blip did cut the link (found lost, re-opened); the campaign rode through it.
    std::uint64_t losses = 0, reconnects = 0;
    for (const auto& axis : r.dev.axes) {
        if (auto* m = dynamic_cast<devices::ModbusAxis*>(axis.get())) {
            losses = std::max(losses, m->bus()->stats().link_losses);
            reconnects = std::max(reconnects, m->bus()->stats().reconnects);
        }
    }
    EXPECT_GE(losses, 1u);
    EXPECT_GE(reconnects, 1u);
    expect_exact_and_true(f);
}

TEST(DeviceOutage, LongerOutagePausesAndResumesOnItsOwn) {
    Fixture f = make_campaign("outage");
    // Reconnect window 300 ms; the gateway stays away for 1.5 s.
    LiveRig r = start_rig(f, "?outage_ms=300");
    r.sim->world().set_exposure_hook([&](std::uint64_t n) {
        if (n == 30) {
            r.sim->motors().blip(1500ms);
        }
    });
    auto res = run_campaign(f.dir, r.dev, quiet());
    ASSERT_TRUE(res) << res.error().message;
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    EXPECT_GE(res->outages, 1u);
    EXPECT_GE(journal_notes(f, "devices unreachable"), 1);
    EXPECT_GE(journal_notes(f, "answer again"), 1);
    expect_exact_and_true(f);
}

}  // namespace
}  // namespace gonio::acquisition
