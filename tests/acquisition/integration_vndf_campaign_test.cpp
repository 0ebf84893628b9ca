// A vndf campaign on the virtual rig (real Modbus TCP stack and camera emulator on 127.0.0.1):
// killed with SIGKILL inside its second pass and resumed, it measures every configuration of both
// passes exactly once, places the same second pass again from its journal, lists that pass's
// unreachable nodes in metadata.json, and writes dataset.bsdf; the same for an anisotropic sample.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "campaign_fixture.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::acquisition {
namespace {

namespace fs = std::filesystem;
using brdf::kPi;

const char* kVndfModel = R"({
    "diffuse": [0.1, 0.1, 0.1],
    "lobes": [{"distribution": "ggx", "alpha": 0.15, "shadowing": "smith-correlated",
               "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]
})";

using Fixture = testing::CampaignFixture;
using testing::LiveRig;

/// A small vndf plan: 12 retro-reflection nodes, 4 theta_i nodes of 6 x 6; anisotropic: the
/// retro-reflection at 8 azimuths and 4 incident azimuths in the file.
Fixture make_campaign(const std::string& name,
                      const char* model = kVndfModel,
                      bool anisotropic = false) {
    CampaignSpec spec = default_campaign_spec("vndf-test");
    spec.plan_kind = "vndf";
    spec.adaptive = false;
    spec.vndf.retro_count = 12;
    spec.vndf.theta_i_count = 4;
    spec.vndf.resolution = 6;
    if (anisotropic) {
        spec.vndf.phi_i_count = 4;
        spec.vndf.retro_phi_count = 8;
        spec.vndf.ndf_resolution = 32;
        // The drift reference is held at one spin (an anisotropic sample reads differently at
        // every spin); checked every 40 measurements.
        spec.drift_every = 40;
    } else {
        spec.drift_every = 0;
    }
    // The quiet rig: the file's values are compared with the truth at the detector's noise.
    return testing::make_campaign_fixture(name, model, spec, /*quiet_rig=*/true);
}

LiveRig start_vndf_rig(const Fixture& f) {
    return testing::start_live_rig(f, 1000);
}

TEST(VndfCampaign, KilledInItsSecondPassResumesToTheSameNodesAndWritesTheFile) {
    Fixture f = make_campaign("vndf_kill9");
    auto pass0 = build_plan(f.spec, f.rig);
    ASSERT_TRUE(pass0) << pass0.error().message;
    const std::size_t n0 = pass0->configs.size();
    ASSERT_EQ(n0, 11u);  // nodes 0 .. 10 of 12; the horizon node is not planned
    // First run: killed once 10 configurations of the second pass are in the journal.
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        LiveRig r = start_vndf_rig(f);
        RunHooks h;
        h.out = nullptr;
        h.on_measurement = [n0](const brdf::Sample&, std::size_t measured, std::size_t) {
            if (measured == n0 + 10) {
                ::raise(SIGKILL);
            }
        };
        auto res = run_campaign(f.dir, r.dev, h);
        _exit(res ? 3 : 4);
    }
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "exit " << WEXITSTATUS(status);
    ASSERT_EQ(WTERMSIG(status), SIGKILL);
    EXPECT_FALSE(fs::exists(f.dir + "/dataset.bsdf"));
    // The second pass as the journal places it now (pass 0 complete).
    VndfNdf ndf;
    auto pass1 = vndf_second_pass(f.dir, f.spec, f.rig, &ndf);
    ASSERT_TRUE(pass1) << pass1.error().message;
    EXPECT_EQ(ndf.measured, n0);
    // Resume.
    {
        LiveRig r = start_vndf_rig(f);
        RunHooks h;
        h.out = nullptr;
        auto res = run_campaign(f.dir, r.dev, h);
        ASSERT_TRUE(res) << res.error().message;
        EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
        EXPECT_NE(res->message.find("RGL material file"), std::string::npos) << res->message;
    }
    // Every configuration of both passes exactly once, the second pass placed as before.
    auto j = Journal::open(f.dir + "/journal.log");
    ASSERT_TRUE(j);
    std::map<std::pair<int, std::uint32_t>, int> count;
    std::map<std::uint32_t, brdf::Canonical<double>> measured_at;
    for (const JournalRecord& r : j->records()) {
        if (r.type == RecordType::kMeasurement) {
            count[{r.pass, r.index}]++;
            if (r.pass == 1) {
                measured_at[r.index] = brdf::to_canonical(r.wi, r.wo);
            }
        }
    }
    std::set<std::pair<int, std::uint32_t>> want;
    for (std::uint32_t k = 0; k < n0; ++k) {
        want.insert({0, k});
    }
    for (const PlannedConfig& c : pass1->plan.configs) {
        want.insert({1, c.index});
    }
    std::set<std::pair<int, std::uint32_t>> got;
    for (const auto& [k, n] : count) {
        EXPECT_EQ(n, 1) << "configuration " << k.first << ":" << k.second;
        got.insert(k);
    }
    EXPECT_EQ(got, want);
    // The resumed run measured the same second pass: each record's canonical angles (isotropy and
    // reciprocity folded: the rig may turn the pair about the normal and swap the arms) are the
    // planned configuration's, to the stages' 0.001 deg steps.
    for (const PlannedConfig& c : pass1->plan.configs) {
        ASSERT_TRUE(measured_at.count(c.index)) << c.index;
        const brdf::Canonical<double> want_c = brdf::to_canonical(c.wi, c.wo);
        const brdf::Canonical<double>& got_c = measured_at[c.index];
        EXPECT_NEAR(got_c.theta_i, want_c.theta_i, 1e-3) << c.index;
        EXPECT_NEAR(got_c.theta_r, want_c.theta_r, 1e-3) << c.index;
        if (want_c.theta_i > 1e-2) {
            EXPECT_NEAR(got_c.delta_phi, want_c.delta_phi, 1e-2) << c.index;
        }
    }
    // metadata.json lists the second pass and its unreachable nodes with why.
    std::ifstream meta_in(f.dir + "/metadata.json");
    const nlohmann::json meta = nlohmann::json::parse(meta_in);
    ASSERT_TRUE(meta.contains("vndf")) << meta.dump(2);
    EXPECT_EQ(meta["vndf"]["configurations"].get<std::size_t>(), pass1->plan.configs.size());
    EXPECT_EQ(meta["vndf"]["unreachable"].size(), pass1->plan.unreachable.size());
    for (const auto& u : meta["vndf"]["unreachable"]) {
        EXPECT_FALSE(u["reason"].get<std::string>().empty());
    }
    // The file: 4 theta_i nodes of 6 x 6, read back by gonio's reader.
    auto file = brdf::read_rgl_bsdf(f.dir + "/dataset.bsdf");
    ASSERT_TRUE(file) << file.error().message;
    EXPECT_EQ(file->theta_i().size(), 4u);
    EXPECT_EQ(file->resolution(), 6u);
    auto truth = brdf::load_brdf(f.model);
    ASSERT_TRUE(truth);
    // At the measured nodes the file returns the measurement: the rig's value at the node's pair.
    std::size_t checked = 0;
    for (const brdf::RglNode& node : file->nodes()) {
        if (!file->node_valid(node) || node.wo.z() < 0.2 || node.wi.z() < 0.2) {
            continue;
        }
        const double t = (*truth)->eval(node.wi, node.wo).mean();
        const double v = (file->stored(node) * node.factor / node.wo.z()).mean();
        EXPECT_NEAR(v, t, 5e-3 * t + 1e-4) << "theta_i node " << node.theta_index << ", row "
                                           << node.row << ", column " << node.column;
        ++checked;
    }
    EXPECT_GT(checked, 20u);
}

// Brushed metal mounted at 30 degrees (anisotropic GGX 0.1 x 0.3): the anisotropic vndf plan
// turns the sample with its spin axis, so its retro-reflection follows the lobe over every
// azimuth, and killed inside its second pass and resumed it measures each configuration once and
// writes an anisotropic file whose measured nodes are the truth at their directions. The drift
// reference, held at one spin, does not pause the campaign.
TEST(VndfCampaign, AnisotropicSampleKilledAndResumedWritesAnAnisotropicFile) {
    const char* brushed = R"({
    "diffuse": [0.05, 0.05, 0.05],
    "lobes": [{"distribution": "ggx", "alpha_x": 0.1, "alpha_y": 0.3, "orientation_deg": 30,
               "shadowing": "smith-correlated",
               "fresnel": {"type": "schlick", "f0": [0.9, 0.8, 0.6]}}]
})";
    Fixture f = make_campaign("vndf_aniso", brushed, true);
    auto pass0 = build_plan(f.spec, f.rig);
    ASSERT_TRUE(pass0) << pass0.error().message;
    const std::size_t n0 = pass0->configs.size();
    // 11 elevations below the horizon node; the pole once, the others at 8 azimuths.
    EXPECT_EQ(n0 + pass0->unreachable.size(), 1u + 10 * 8);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        LiveRig r = start_vndf_rig(f);
        RunHooks h;
        h.out = nullptr;
        h.on_measurement = [n0](const brdf::Sample&, std::size_t measured, std::size_t) {
            if (measured == n0 + 25) {
                ::raise(SIGKILL);
            }
        };
        auto res = run_campaign(f.dir, r.dev, h);
        _exit(res ? 3 : 4);
    }
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "exit " << WEXITSTATUS(status);
    VndfNdf ndf;
    auto pass1 = vndf_second_pass(f.dir, f.spec, f.rig, &ndf);
    ASSERT_TRUE(pass1) << pass1.error().message;
    EXPECT_EQ(ndf.ndf.rows, 32u);  // the NDF over the whole square
    // The recovered NDF is wider along the lobe's y axis (120 deg) than along its x axis.
    auto d_at = [&](double theta, double phi) {
        const double h = 1.0 / 31.0;
        const auto c = static_cast<std::size_t>(std::lround(brdf::rgl_theta_to_u(theta) / h));
        const auto r = static_cast<std::size_t>(std::lround(brdf::rgl_phi_to_u(phi) / h));
        return ndf.ndf.d[r * 32 + c];
    };
    EXPECT_LT(d_at(15 * kPi / 180, 30 * kPi / 180), 0.8 * d_at(15 * kPi / 180, 120 * kPi / 180));
    {
        LiveRig r = start_vndf_rig(f);
        RunHooks h;
        h.out = nullptr;
        auto res = run_campaign(f.dir, r.dev, h);
        ASSERT_TRUE(res) << res.error().message;
        EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    }
    auto j = Journal::open(f.dir + "/journal.log");
    ASSERT_TRUE(j);
    std::map<std::pair<int, std::uint32_t>, int> count;
    for (const JournalRecord& r : j->records()) {
        if (r.type == RecordType::kMeasurement) {
            count[{r.pass, r.index}]++;
        }
    }
    EXPECT_EQ(count.size(), n0 + pass1->plan.configs.size());
    for (const auto& [k, n] : count) {
        EXPECT_EQ(n, 1) << "configuration " << k.first << ":" << k.second;
    }
    auto file = brdf::read_rgl_bsdf(f.dir + "/dataset.bsdf");
    ASSERT_TRUE(file) << file.error().message;
    EXPECT_FALSE(file->isotropic());
    EXPECT_EQ(file->phi_i().size(), 5u);
    auto truth = brdf::load_brdf(f.model);
    ASSERT_TRUE(truth);
    std::size_t checked = 0;
    std::set<std::size_t> azimuths;
    for (const brdf::RglNode& node : file->nodes()) {
        if (!file->node_valid(node) || node.wo.z() < 0.2 || node.wi.z() < 0.2) {
            continue;
        }
        const double t = (*truth)->eval(node.wi, node.wo).mean();
        const double v = (file->stored(node) * node.factor / node.wo.z()).mean();
        EXPECT_NEAR(v, t, 5e-3 * t + 1e-4)
            << "phi_i node " << node.phi_index << ", theta_i node " << node.theta_index << ", row "
            << node.row << ", column " << node.column;
        azimuths.insert(node.phi_index);
        ++checked;
    }
    EXPECT_GT(checked, 60u);
    EXPECT_EQ(azimuths.size(), 4u);
}

}  // namespace
}  // namespace gonio::acquisition
