// Colour campaigns on the virtual rig: the red, green and blue filters of the filter wheel (coils
// on the simulated Modbus controller, real TCP stack on 127.0.0.1) in front of the monochrome U3V
// camera emulator give per-channel BRDF values of a coloured ground truth (red-plastic from the
// material library); a rig without the wheel measures r = g = b.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/acquisition/point/campaign.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/material_library.h"
#include "gonio/sim/sim_rig.h"

namespace gonio::acquisition {
namespace {

namespace fs = std::filesystem;

struct ColourRun {
    std::string dir;
    brdf::Dataset ds;
    std::uint64_t seed = 0;
};

/// Runs a small uniform campaign of red-plastic on the sim4 rig (with or without its filter wheel).
ColourRun run_red_plastic(const std::string& name, bool with_wheel) {
    ColourRun out;
    out.dir = std::string(GONIO_BINARY_DIR) + "/test_campaigns/" + name + "_" +
              std::to_string(::getpid());
    fs::remove_all(out.dir);
    fs::create_directories(out.dir);
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim4.json");
    std::stringstream ss;
    ss << in.rdbuf();
    nlohmann::json j = nlohmann::json::parse(ss.str());
    EXPECT_TRUE(j.contains("filter_wheel"));
    if (!with_wheel) {
        j.erase("filter_wheel");
    }
    out.seed = j.at("sim").value("seed", std::uint64_t{1});
    auto rig = parse_rig_config(j.dump(2), "sim4.json");
    EXPECT_TRUE(rig) << rig.error().message;
    EXPECT_EQ(rig->filter_wheel.has_value(), with_wheel);
    CampaignSpec spec = default_campaign_spec("colour-test");
    spec.uniform.n_theta = 4;
    spec.uniform.n_dphi = 3;
    spec.adaptive = false;
    spec.drift_every = 0;
    spec.rig = "rig.json";
    spec.json = campaign_spec_json(spec);
    auto c = create_campaign_dir(out.dir, spec, *rig);
    EXPECT_TRUE(c) << c.error().message;
    sim::SimRigOptions so;
    so.material = "red-plastic";
    so.time_scale = 500;
    auto s = sim::SimRig::start(rig->json, so);
    EXPECT_TRUE(s) << s.error().message;
    auto dev = open_rig(with_addresses(*rig, (*s)->motor_address(), (*s)->camera_address()));
    EXPECT_TRUE(dev) << dev.error().message;
    EXPECT_EQ(dev->filter_wheel != nullptr, with_wheel);
    RunHooks h;
    h.out = nullptr;
    auto res = run_campaign(out.dir, *dev, h);
    EXPECT_TRUE(res) << res.error().message;
    EXPECT_EQ(res->outcome, Outcome::kCompleted) << res->message;
    auto ds = brdf::read_dataset_csv(out.dir + "/dataset.csv");
    EXPECT_TRUE(ds) << ds.error().message;
    out.ds = std::move(*ds);
    return out;
}

std::unique_ptr<brdf::Brdf> red_plastic() {
    auto m = brdf::load_material("red-plastic");
    EXPECT_TRUE(m) << m.error().message;
    return brdf::make_analytic_brdf(*m);
}

TEST(ColourCampaign, FilterWheelMeasuresEachChannelOfTheGroundTruth) {
    const ColourRun run = run_red_plastic("colour", true);
    SCOPED_TRACE("sim seed " + std::to_string(run.seed));
    const auto truth = red_plastic();
    ASSERT_TRUE(run.ds.rejected.empty());
    ASSERT_GT(run.ds.samples.size(), 10u);
    int within3[3] = {0, 0, 0};
    brdf::Rgbd sum_measured = brdf::Rgbd::Zero();
    for (const brdf::Sample& s : run.ds.samples) {
        const brdf::Rgbd t = truth->eval(s.wi(), s.wo());
        // The truth is coloured, so the channels must differ beyond their noise.
        ASSERT_GT(t[0], t[1]);
        for (int c = 0; c < 3; ++c) {
            EXPECT_GT(s.sigma[c], 0);
            // Noise plus the 1e-3 relative allowance for the directions the stages reach.
            const double tol = 3 * s.sigma[c] + 1e-3 * t[c];
            within3[c] += std::abs(s.value[c] - t[c]) <= tol;
            EXPECT_NEAR(s.value[c], t[c], 6 * s.sigma[c] + 2e-3 * t[c])
                << "channel " << c << " theta_i " << s.theta_i << " theta_o " << s.theta_o;
        }
        EXPECT_GT(s.value[0] - s.value[1], 6 * std::hypot(s.sigma[0], s.sigma[1]))
            << "theta_i " << s.theta_i << " theta_o " << s.theta_o;
        sum_measured += s.value;
    }
    for (int c = 0; c < 3; ++c) {
        EXPECT_GE(within3[c], static_cast<int>(0.9 * run.ds.samples.size())) << "channel " << c;
    }
    EXPECT_GT(sum_measured[0], sum_measured[1]);
    EXPECT_GT(sum_measured[1], sum_measured[2]);
    // The white reference is calibrated per channel.
    std::ifstream meta(run.dir + "/metadata.json");
    const nlohmann::json m = nlohmann::json::parse(meta);
    EXPECT_EQ(m.at("calibration").at("colour"), "filter_wheel");
    const auto& w = m.at("calibration").at("white_rate_counts_per_us");
    for (int c = 0; c < 3; ++c) {
        EXPECT_GT(w.at(c).get<double>(), 0);
    }
}

TEST(ColourCampaign, WithoutFilterWheelTheDatasetIsMonochrome) {
    const ColourRun run = run_red_plastic("mono", false);
    SCOPED_TRACE("sim seed " + std::to_string(run.seed));
    const auto truth = red_plastic();
    ASSERT_GT(run.ds.samples.size(), 10u);
    int within3 = 0;
    for (const brdf::Sample& s : run.ds.samples) {
        EXPECT_EQ(s.value[0], s.value[1]);
        EXPECT_EQ(s.value[1], s.value[2]);
        // The unfiltered sensor sees the mean of the three channels.
        const double t = truth->eval(s.wi(), s.wo()).mean();
        within3 += std::abs(s.value[0] - t) <= 3 * s.sigma[0] + 1e-3 * t;
        EXPECT_NEAR(s.value[0], t, 6 * s.sigma[0] + 2e-3 * t);
    }
    EXPECT_GE(within3, static_cast<int>(0.9 * run.ds.samples.size()));
    std::ifstream meta(run.dir + "/metadata.json");
    const nlohmann::json m = nlohmann::json::parse(meta);
    EXPECT_EQ(m.at("calibration").at("colour"), "mono");
}

}  // namespace
}  // namespace gonio::acquisition
