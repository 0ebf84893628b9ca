// Zoomed camera placements in image mode, end to end on the virtual rig (Modbus TCP motors and
// coils, the GigE Vision camera through Aravis): data/rigs/sim-image-zoom.json's four placements
// (8 times the wide view's magnification, the camera moved across its axis) let the campaign put
// pixels on the narrow first theta_h rows that the wide view leaves "finer than a pixel". A
// campaign with them covers more of the table than the same rig's wide view alone, the bins only
// the zoomed frames filled agree with the ground truth within their stated sigma, a campaign
// killed (SIGKILL) right after a zoomed frame and in the middle of a later one resumes without
// losing or repeating a frame, and --no-zoom is refused (exit 2) wherever it cannot apply.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_run.h"
#include "embedded_rig.h"
#include "gonio/acquisition/image/image_journal.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/brdf/analytic_brdf.h"
#include "image_test_support.h"

namespace gonio::tools {
namespace {

namespace fs = std::filesystem;
using gonio::testing::run_gonio;

std::string zoom_dir(const std::string& name) {
    return gonio::testing::test_folder("test_tools_image_zoom", name, true);
}

using gonio::testing::read_text;

std::string zoom_rig() {
    return std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim-image-zoom.json";
}

/// Ground truth: Lambert (0.5, 0.4, 0.3) + GGX alpha 0.3 (image_test_support.h), as the rig's
/// model file.
std::string write_truth(const std::string& dir) {
    const std::string path = dir + "/truth.json";
    std::ofstream(path) << R"({"diffuse": [0.5, 0.4, 0.3], "lobes": [{"distribution": "ggx",
        "alpha": 0.3, "shadowing": "smith-correlated", "fresnel": {"type": "none"},
        "scale": [0.3, 0.3, 0.3]}]})";
    return path;
}

std::shared_ptr<const brdf::Brdf> truth() {
    return brdf::make_analytic_brdf(image_test::lambert_ggx(brdf::Rgbd(0.5, 0.4, 0.3), 0.3));
}

/// The campaign of these tests: a 15 x 15 x 30 table on a 128 px camera (the first theta_h row
/// is 0.4 degrees wide, the wide view's pixels about 1.1 degrees of normal), run to the stop
/// rule.
struct ZoomCampaign {
    acquisition::ImageRigOptions rig;
    bool zoom = true;
    int max_frames = 400;
};

ZoomCampaign campaign(const std::string& model, std::uint64_t seed) {
    ZoomCampaign o;
    o.rig.rig_path = zoom_rig();
    o.rig.brdf_path = model;
    o.rig.image_size = 128;
    o.rig.supersample = 2;
    o.rig.seed = seed;
    o.rig.time_scale = 1000;
    return o;
}

acquisition::ImageCampaignConfig zoom_config_of(const ZoomCampaign& o,
                                                const acquisition::ImageRig& rig) {
    // Target beyond reach: the campaign runs until no light position (or placement) adds a bin.
    acquisition::ImageCampaignConfig cfg =
        acquisition::image_campaign_config(rig.rig, rig.camera, 6, 0.999, o.max_frames);
    if (!o.zoom) {
        cfg.placements.clear();
    }
    return cfg;
}

/// sim-image-zoom.json as a quiet rig (no instrument term), written into `dir`: the test below
/// compares the wide-only campaign's choices with the zoomed one's frame by frame and the bins with
/// the truth at their standard errors, which the reference budget's fresh draws per exposure and
/// per move would blur.
std::string write_quiet_zoom_rig(const std::string& dir) {
    std::ifstream in(zoom_rig());
    nlohmann::json j = nlohmann::json::parse(in);
    j["error_budget"] = "quiet";
    const std::string path = dir + "/quiet-rig.json";
    std::ofstream(path) << j.dump(2);
    return path;
}

TEST(ImageZoom, ZoomedPlacementsFillBinsTheWideViewCannot) {
    const std::string dir = zoom_dir("coverage");
    const std::string model = write_truth(dir);
    const std::string quiet_rig = write_quiet_zoom_rig(dir);
    const auto f = truth();

    // The wide view alone.
    ZoomCampaign wide = campaign(model, 5);
    wide.rig.rig_path = quiet_rig;
    wide.zoom = false;
    double wide_coverage = 0;
    {
        auto rig = acquisition::start_image_rig(wide.rig, embedded_rig_starter());
        ASSERT_TRUE(rig) << rig.error().message;
        const acquisition::ImageCampaignConfig cfg = zoom_config_of(wide, **rig);
        ASSERT_TRUE(cfg.placements.empty());
        auto r = acquisition::run_image_campaign(
            acquisition::image_rig_capture(**rig, cfg.detector_arm_rad), cfg);
        ASSERT_TRUE(r) << r.error().message;
        EXPECT_EQ(r->stop_reason, "no light position adds enough bins");
        wide_coverage = r->coverage_fraction();
        for (const auto& fr : r->frames) {
            EXPECT_EQ(fr.placement, 0);
        }
    }

    // With the zoomed placements, journaled (the journal tells which frame filled which bin).
    ZoomCampaign zoom = campaign(model, 5);
    zoom.rig.rig_path = quiet_rig;
    const std::string journal = dir + "/frames.journal";
    auto rig = acquisition::start_image_rig(zoom.rig, embedded_rig_starter());
    ASSERT_TRUE(rig) << rig.error().message;
    const acquisition::ImageCampaignConfig cfg = zoom_config_of(zoom, **rig);
    ASSERT_EQ(cfg.placements.size(), 4u);
    auto r = acquisition::run_image_campaign(
        acquisition::image_rig_capture(**rig, cfg.detector_arm_rad), cfg, {}, journal);
    ASSERT_TRUE(r) << r.error().message;
    const double zoom_coverage = r->coverage_fraction();
    std::printf("sphere centre found at (%.2f, %.2f, %.2f) um, rms %.3f px\n",
                r->sphere.centre.x() * 1e6,
                r->sphere.centre.y() * 1e6,
                r->sphere.centre.z() * 1e6,
                r->sphere.rms_residual_px);
    std::printf(
        "coverage of the %zu valid bins: wide view %.2f %%, with zoomed placements %.2f %%\n",
        r->valid_bins(),
        100 * wide_coverage,
        100 * zoom_coverage);
    EXPECT_GT(zoom_coverage, wide_coverage + 0.03);

    // The wide frames come first, then the zoomed ones; every zoomed frame was rendered through
    // its placement by the camera (the arms and coils as the campaign set them).
    std::size_t first_zoomed = r->frames.size();
    for (std::size_t k = 0; k < r->frames.size(); ++k) {
        if (r->frames[k].placement > 0 && first_zoomed == r->frames.size()) {
            first_zoomed = k;
        }
        if (k > first_zoomed) {
            EXPECT_GT(r->frames[k].placement, 0) << "frame " << k << " wide after a zoomed one";
        }
    }
    ASSERT_LT(first_zoomed, r->frames.size()) << "no zoomed frame";
    EXPECT_GE(r->frames.size() - first_zoomed, 4u);
    // Up to the first zoomed frame the campaign is the wide-only campaign (same seed, same
    // choices): the zoomed frames add what it could not reach.
    EXPECT_NEAR(r->frames[first_zoomed - 1].coverage_after, wide_coverage, 1e-3);

    // Bins only zoomed frames filled: against the ground truth at their mean position.
    auto j = acquisition::ImageJournal::open(journal);
    ASSERT_TRUE(j) << j.error().message;
    ASSERT_EQ(j->frames().size(), r->frames.size());
    std::set<std::uint32_t> by_wide;
    std::set<std::uint32_t> by_zoom;
    for (const acquisition::ImageJournalFrame& fr : j->frames()) {
        for (const acquisition::BinAggregate& a : fr.bins) {
            (fr.placement > 0 ? by_zoom : by_wide).insert(a.bin);
        }
        if (fr.placement > 0) {
            EXPECT_EQ(fr.magnification, 8);
            EXPECT_EQ(fr.offset_m, cfg.placements[fr.placement - 1].offset_m);
        }
    }
    std::size_t zoom_only = 0;
    std::size_t small_theta_h = 0;
    std::size_t values = 0;
    std::size_t within1 = 0;
    std::size_t within3 = 0;
    std::vector<double> rel;
    for (std::uint32_t b : by_zoom) {
        if (by_wide.count(b) != 0 || r->table.count(b) < 2) {
            continue;
        }
        ++zoom_only;
        const brdf::HalfDiff<double> hd = r->table.mean_position(b);
        small_theta_h += hd.theta_h < 5 * brdf::kPi / 180 ? 1 : 0;
        const auto [wi, wo] = brdf::from_half_diff(hd);
        const brdf::Rgbd want = f->eval(wi, wo);
        const brdf::Rgbd got = r->table.mean(b);
        const brdf::Rgbd sigma = r->table.standard_error(b);
        for (int c = 0; c < 3; ++c) {
            const double z = std::abs(got[c] - want[c]) / sigma[c];
            ++values;
            within1 += z <= 1 ? 1 : 0;
            within3 += z <= 3 ? 1 : 0;
            rel.push_back(std::abs(got[c] / want[c] - 1));
        }
    }
    std::printf(
        "%zu bins filled by zoomed frames only (%zu below theta_h 5 deg): %.1f %% of their "
        "values within 1 sigma of the truth, %.1f %% within 3, median relative error %.3f %%\n",
        zoom_only,
        small_theta_h,
        100.0 * within1 / std::max<std::size_t>(values, 1),
        100.0 * within3 / std::max<std::size_t>(values, 1),
        100 * image_test::median(rel));
    EXPECT_GT(zoom_only, r->valid_bins() / 50);
    EXPECT_GT(small_theta_h, zoom_only / 2);
    EXPECT_GE(within3, values * 95 / 100);
    EXPECT_GE(within1, values * 55 / 100);
    fs::remove_all(dir);
}

// ---- resume after SIGKILL ------------------------------------------------------------------

/// The campaign in a child process killed with SIGKILL right after its first zoomed frame is
/// journaled (after_zoomed), or at the `kill_exposure`-th exposure the camera renders.
int killed_child(const ZoomCampaign& o,
                 const std::string& journal,
                 bool after_zoomed,
                 std::uint64_t kill_exposure) {
    return image_test::campaign_in_child(o.rig, kill_exposure, [&](acquisition::ImageRig& rig) {
        const acquisition::ImageCampaignConfig cfg = zoom_config_of(o, rig);
        auto progress = [after_zoomed](std::size_t, const acquisition::FrameRecord& rec) {
            if (after_zoomed && rec.placement > 0) {
                ::raise(SIGKILL);
            }
        };
        return acquisition::run_image_campaign(
                   acquisition::image_rig_capture(rig, cfg.detector_arm_rad),
                   cfg,
                   progress,
                   journal)
            .has_value();
    });
}

TEST(ImageZoom, KillNineAroundZoomedFramesLosesNoFrameAndRepeatsNone) {
    const std::string dir = zoom_dir("resume");
    const std::string model = write_truth(dir);
    const std::string journal = dir + "/frames.journal";
    ZoomCampaign o = campaign(model, 11);

    // 1. Right after the first zoomed frame is journaled.
    int st = killed_child(o, journal, true, 0);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    const std::string after_first = read_text(journal);
    std::size_t wide_frames = 0;
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        ASSERT_GE(j->frames().size(), 2u);
        EXPECT_GT(j->frames().back().placement, 0);
        wide_frames = j->frames().size() - 1;
        for (std::size_t k = 0; k < wide_frames; ++k) {
            EXPECT_EQ(j->frames()[k].placement, 0);
        }
    }
    // Three more zoomed frames at most from here, so that the test stays short.
    o.max_frames = static_cast<int>(wide_frames) + 4;

    // 2. In the middle of the next zoomed frame (its third exposure: the resume takes no set-up).
    st = killed_child(o, journal, false, 3);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    const std::string after_second = read_text(journal);
    ASSERT_GE(after_second.size(), after_first.size());
    EXPECT_EQ(after_second.substr(0, after_first.size()), after_first)
        << "a journaled frame was lost";
    std::size_t frames_at_kill = 0;
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        frames_at_kill = j->frames().size();
        EXPECT_EQ(frames_at_kill, wide_frames + 1) << "the kill came after a whole frame";
    }

    // 3. To the end, in this process.
    auto rig = acquisition::start_image_rig(o.rig, embedded_rig_starter());
    ASSERT_TRUE(rig) << rig.error().message;
    const acquisition::ImageCampaignConfig cfg = zoom_config_of(o, **rig);
    auto r = acquisition::run_image_campaign(
        acquisition::image_rig_capture(**rig, cfg.detector_arm_rad), cfg, {}, journal);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(r->resumed_frames, frames_at_kill);
    EXPECT_EQ(r->stop_reason, "frame limit");
    ASSERT_EQ(r->frames.size(), static_cast<std::size_t>(o.max_frames));
    EXPECT_EQ(read_text(journal).substr(0, after_second.size()), after_second);

    auto j = acquisition::ImageJournal::open(journal);
    ASSERT_TRUE(j) << j.error().message;
    ASSERT_EQ(j->frames().size(), r->frames.size());
    // No (light position, placement) twice; the zoomed frames kept their placement; every
    // journaled sample in the table once.
    std::set<std::pair<double, int>> taken;
    std::size_t zoomed = 0;
    std::uint64_t used = 0;
    std::uint64_t in_bins = 0;
    for (std::size_t k = 0; k < j->frames().size(); ++k) {
        const acquisition::ImageJournalFrame& f = j->frames()[k];
        EXPECT_TRUE(taken.insert({f.light_arm_rad, f.placement}).second)
            << "light " << f.light_arm_rad << " rad at placement " << f.placement << " twice";
        EXPECT_EQ(f.light_arm_rad, r->frames[k].light_arm_rad);
        EXPECT_EQ(f.placement, r->frames[k].placement);
        zoomed += f.placement > 0 ? 1 : 0;
        used += f.counts.used;
        for (const acquisition::BinAggregate& a : f.bins) {
            in_bins += a.count;
        }
    }
    EXPECT_EQ(zoomed, 4u);
    EXPECT_EQ(used, in_bins);
    EXPECT_EQ(r->table.total_samples(), in_bins);
    EXPECT_EQ(r->counts.used, used);
    fs::remove_all(dir);
}

// ---- the option ------------------------------------------------------------------------------

TEST(ImageZoom, NoZoomIsRefusedWhereItCannotApply) {
    int st = 0;
    // Point mode.
    std::string out = run_gonio("acquire --no-zoom --plan-only", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--no-zoom"), std::string::npos) << out;
    // Anisotropic image mode takes every frame in the wide view.
    out = run_gonio("acquire --mode image --anisotropic --no-zoom --plan-only --rig " + zoom_rig(),
                    &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--no-zoom cannot be combined with --anisotropic"), std::string::npos)
        << out;
    // A rig without zoomed placements (the default sim-image.json).
    out = run_gonio("acquire --mode image --no-zoom --plan-only --camera-px 64", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("no zoomed camera placements"), std::string::npos) << out;
    // A resume takes the folder's settings.
    const std::string dir = zoom_dir("option");
    out = run_gonio("acquire --mode image --rig " + zoom_rig() + " --camera-px 48 --out " + dir +
                        "/run --max-frames 2 --grid 6x6x12 --time-scale 1000",
                    &st);
    EXPECT_EQ(st, 1) << out;  // two frames do not reach the default target
    out = run_gonio("acquire --resume " + dir + "/run --no-zoom", &st);
    EXPECT_EQ(st, 2) << out;
    EXPECT_NE(out.find("--no-zoom cannot be combined with --resume"), std::string::npos) << out;
    // Where it applies, the plan has no zoomed placement.
    out = run_gonio("acquire --mode image --plan-only --camera-px 64 --rig " + zoom_rig(), &st);
    EXPECT_EQ(st, 0) << out;
    EXPECT_NE(out.find("zoomed camera placements: zoom-1 x8"), std::string::npos) << out;
    out = run_gonio("acquire --mode image --plan-only --camera-px 64 --no-zoom --rig " + zoom_rig(),
                    &st);
    EXPECT_EQ(st, 0) << out;
    EXPECT_EQ(out.find("zoomed camera placements"), std::string::npos) << out;
    fs::remove_all(dir);
}

}  // namespace
}  // namespace gonio::tools
