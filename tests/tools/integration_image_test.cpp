// Image-mode acquisition end to end on the virtual rig, through the device path of a real rig:
// motor controllers on Modbus TCP (127.0.0.1), the camera a GigE Vision device on a loopback
// address of its own opened through Aravis, the sphere rendered by the camera at trigger time. A
// sphere of a known material, the campaign's table against the ground truth within the noise
// statistics, a fit of the dataset recovering the parameters, agreement with point measurements
// through the same sensor model, and the command's outputs (in process and through the binary).

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
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "cli_run.h"
#include "embedded_rig.h"
#include "gonio/acquisition/image/bin_uncertainty.h"
#include "gonio/acquisition/image/image_journal.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"
#include "gonio/sim/camera_render.h"
#include "gonio/sim/sim_rig.h"
#include "image_test_support.h"

namespace gonio::tools {
namespace {

using brdf::kPi;

brdf::ModelD truth_model() {
    return image_test::lambert_ggx(brdf::Rgbd(0.35, 0.22, 0.12), 0.12);
}

constexpr std::uint64_t kSeed = 4242;

/// The text of a shipped rig file, data/rigs/`name`.
std::string shipped_image_rig_text(const std::string& name) {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/" + name);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// The shipped image rigs run with the reference error budget (docs/error-budget.md), as the
// point rig does; a quiet rig is a rig file naming "quiet".
TEST(ImageRigFiles, ShippedImageRigsNameTheReferenceBudget) {
    for (const char* name : {"sim-image.json", "sim-image-zoom.json", "sim-image-5mp.json"}) {
        auto rig = acquisition::parse_rig_config(shipped_image_rig_text(name), name);
        ASSERT_TRUE(rig) << rig.error().message;
        EXPECT_EQ(rig->error_budget.profile, "reference") << name;
        EXPECT_EQ(rig->error_budget.lamp_fluctuation,
                  brdf::reference_error_budget().lamp_fluctuation)
            << name;
    }
}

/// The fixture below compares the bins with the truth and with point measurements at the
/// detector's noise, and states the bins' standard errors: it runs data/rigs/sim-image.json as a
/// quiet rig (no instrument term; ImageBudgetTest below runs it as shipped).
std::string quiet_image_rig_json() {
    nlohmann::json j = nlohmann::json::parse(shipped_image_rig_text("sim-image.json"));
    j["error_budget"] = "quiet";
    return j.dump(2);
}

/// One GGX lobe without Fresnel (Smith correlated shadowing) fitted to `data` with `seed`, in
/// `model`.
void fit_ggx_one_lobe(const brdf::Dataset& data, std::uint64_t seed, brdf::ModelD* model) {
    fitting::ModelOptions mo;
    mo.distribution = brdf::Distribution::kGgx;
    mo.fresnel = brdf::FresnelType::kNone;
    mo.shadowing = brdf::Shadowing::kSmithCorrelated;
    auto spec = fitting::make_fit_spec(mo);
    ASSERT_TRUE(spec) << spec.error().message;
    spec->options.seed = seed;
    spec->options.num_threads = 1;
    spec->options.max_samples = 6000;
    auto fit = fitting::fit(data, *spec);
    ASSERT_TRUE(fit) << fit.error().message;
    ASSERT_TRUE(fit->usable()) << fit->solver.message;
    ASSERT_EQ(fit->model.lobes.size(), 1u);
    *model = fit->model;
}

/// The fitted one-lobe model against the truth: alpha and the diffuse within 5%, the lobe's
/// scale within 10%.
void expect_recovered_material(const brdf::ModelD& m, const brdf::ModelD& truth) {
    EXPECT_NEAR(m.lobes[0].alpha_x, truth.lobes[0].alpha_x, 0.05 * truth.lobes[0].alpha_x);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(m.diffuse[c], truth.diffuse[c], 0.05 * truth.diffuse[c]) << "channel " << c;
        EXPECT_NEAR(m.lobes[0].scale[c], truth.lobes[0].scale[c], 0.1 * truth.lobes[0].scale[c])
            << "channel " << c;
    }
}

class ImageCampaignTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        truth_ = new std::shared_ptr<const brdf::Brdf>(brdf::make_analytic_brdf(truth_model()));
        const std::string stem =
            std::string(GONIO_BINARY_DIR) + "/image_" + std::to_string(::getpid());
        const std::string model = stem + "_truth.json";
        const std::string quiet_rig = stem + "_quiet_rig.json";
        std::ofstream(model) << brdf::model_to_json(truth_model());
        std::ofstream(quiet_rig) << quiet_image_rig_json();
        acquisition::ImageRigOptions o;
        o.rig_path = quiet_rig;
        o.brdf_path = model;
        o.image_size = 200;
        o.supersample = 1;
        o.seed = kSeed;
        o.time_scale = 200;
        auto rig = acquisition::start_image_rig(o, embedded_rig_starter());
        std::filesystem::remove(model);
        std::filesystem::remove(quiet_rig);
        if (!rig) {
            error_ = new std::string(rig.error().message);
            return;
        }
        rig_ = rig->release();
        config_ = new acquisition::ImageCampaignConfig(
            acquisition::image_campaign_config(rig_->rig, rig_->camera, 3, 0.5, 60));
        auto r =
            acquisition::run_image_campaign(acquisition::image_rig_capture(*rig_, 0.0), *config_);
        for (const std::string& n : rig_->pose_log.notes) {
            std::printf("note: %s\n", n.c_str());
        }
        if (r) {
            result_ = new acquisition::ImageCampaignResult(std::move(*r));
        } else {
            error_ = new std::string(r.error().message);
        }
    }
    static void TearDownTestSuite() {
        delete result_;
        delete config_;
        delete rig_;
        delete truth_;
        delete error_;
        result_ = nullptr;
        error_ = nullptr;
    }
    void SetUp() override {
        ASSERT_EQ(error_, nullptr) << *error_ << " (seed " << kSeed << ")";
        ASSERT_NE(result_, nullptr);
    }

    static std::shared_ptr<const brdf::Brdf>* truth_;
    static acquisition::ImageRig* rig_;
    static acquisition::ImageCampaignConfig* config_;
    static acquisition::ImageCampaignResult* result_;
    static std::string* error_;
};

std::shared_ptr<const brdf::Brdf>* ImageCampaignTest::truth_ = nullptr;
acquisition::ImageRig* ImageCampaignTest::rig_ = nullptr;
acquisition::ImageCampaignConfig* ImageCampaignTest::config_ = nullptr;
acquisition::ImageCampaignResult* ImageCampaignTest::result_ = nullptr;
std::string* ImageCampaignTest::error_ = nullptr;

TEST_F(ImageCampaignTest, EveryFrameCameThroughTheGigECameraWithArmsOnTarget) {
    // The camera the campaign opened is the virtual rig's GigE Vision device (gige://127.x.y.z),
    // and it rendered every frame the campaign captured.
    EXPECT_EQ(rig_->rig.camera_address.rfind("gige://127.", 0), 0u) << rig_->rig.camera_address;
    EXPECT_EQ(simulator(*rig_)->camera().frames_rendered(),
              result_->captures + rig_->pose_log.capture_retries);
    EXPECT_EQ(rig_->pose_log.repeats + rig_->pose_log.corrections, 0u);
    // The arms stand where the campaign left them: detector at 0, light at the last position.
    const sim::RigUnits& u = simulator(*rig_)->units();
    EXPECT_NEAR(simulator(*rig_)->motors().position_deg(u.detector), 0.0, 0.01);
    EXPECT_NEAR(simulator(*rig_)->motors().position_deg(u.light),
                result_->frames.back().light_arm_rad * 180 / kPi,
                0.01);
}

TEST_F(ImageCampaignTest, SphereFoundWhereItWasRendered) {
    const double px_per_m = config_->camera.intrinsics.fx;
    // Rendered at the origin with radius 20 mm.
    EXPECT_LT(result_->sphere.centre.norm() * px_per_m, 0.3);
    EXPECT_NEAR(result_->sphere.radius_m * px_per_m, 0.02 * px_per_m, 0.3);
    EXPECT_LT(result_->reference_sphere.centre.norm() * px_per_m, 0.3);
    // Per-pixel normals against the renderer's own truth (its own ray casting and frame).
    sim::SphereImaging imaging;
    imaging.camera = to_sphere_camera(rig_->camera);
    imaging.radius_m = 0.02;
    const sim::SphereScene scene = sim::sphere_scene(imaging, sim::SceneState{});
    const std::vector<sim::SpherePixelTruth> truth = sim::sphere_truth(scene);
    const std::vector<acquisition::SpherePixel> px =
        acquisition::sphere_pixels(config_->camera, result_->sphere, config_->rules, nullptr);
    ASSERT_GT(px.size(), 5000u);
    double worst = 0;
    for (const auto& p : px) {
        const sim::SpherePixelTruth& t = truth[p.y * scene.camera.width + p.x];
        ASSERT_TRUE(t.hit);
        worst = std::max(worst, std::acos(std::min(1.0, t.normal_world.dot(p.normal))));
    }
    // A 0.3 px error in centre and radius tilts the normals near the silhouette (80 degrees) by
    // about 0.3 / (r cos 80) rad: 0.02 rad for r = 80 px.
    EXPECT_LT(worst, 0.05);
}

TEST_F(ImageCampaignTest, CoverageTargetMetAndExclusionsCounted) {
    EXPECT_TRUE(result_->target_met)
        << result_->frames.size() << " frames, reachable " << result_->reachable_bins << " of "
        << result_->coverage.valid_bins() << " valid bins, covered "
        << result_->coverage.covered_bins();
    EXPECT_GE(result_->coverage.fraction(), 0.5);
    EXPECT_EQ(result_->stop_reason, "coverage target met");
    // The bins the sphere's pixels cannot reach (the smallest theta_h bins of the square-root
    // spacing, grazing ones) are not in the planner's reachable set; the target is below it.
    EXPECT_GE(result_->reachable_bins, result_->coverage.covered_bins() * 9 / 10);
    const acquisition::PixelCounts& c = result_->counts;
    EXPECT_GT(c.used, 50000u);
    EXPECT_GT(c.shadow, 0u);
    EXPECT_GT(c.edge, 0u);
    EXPECT_EQ(c.nonfinite, 0u);
    // Every pixel on the sphere has exactly one fate per frame.
    EXPECT_EQ(
        c.on_sphere,
        c.edge + c.grazing_view + c.shadow + c.grazing_light + c.saturated + c.nonfinite + c.used);
    // Each frame fills one theta_d slice: half the angle between light and camera.
    for (const auto& f : result_->frames) {
        EXPECT_GE(std::abs(brdf::wrap_pi(f.light_arm_rad)), 5 * kPi / 180 - 1e-9);
    }
    // Holes: the blind zone's theta_d < 2.5 degrees cannot be measured.
    bool blind = false;
    for (const auto& h : result_->holes) {
        blind = blind || h.reason == "blind zone";
    }
    EXPECT_TRUE(blind);
}

// The coverage predicted without capturing (the nominal sphere, the campaign's own choice of light
// positions) is what the campaign then reaches through the camera: the same first light position,
// as many positions within one and the same covered fraction within 2 % (the fitted sphere is a
// fraction of a pixel off the nominal one).
TEST_F(ImageCampaignTest, PredictedCoverageIsWhatTheCampaignReached) {
    auto p = acquisition::predict_image_coverage(*config_);
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->valid_bins, result_->coverage.valid_bins());
    EXPECT_TRUE(p->target_met);
    EXPECT_EQ(p->stop_reason, "coverage target met");
    EXPECT_NEAR(static_cast<double>(p->light_arm_rad.size()),
                static_cast<double>(result_->frames.size()),
                1.0);
    ASSERT_FALSE(p->light_arm_rad.empty());
    EXPECT_NEAR(p->light_arm_rad.front(), result_->frames.front().light_arm_rad, 1e-9);
    EXPECT_NEAR(static_cast<double>(p->covered_bins) / static_cast<double>(p->valid_bins),
                result_->coverage.fraction(),
                0.02);
    // Both runs stop at the same target, so the final fractions agree whatever the prediction:
    // the coverage after each light position the two share is compared on its own, from the
    // first position on (far below the target).
    ASSERT_EQ(p->predicted_coverage.size(), p->light_arm_rad.size());
    std::size_t compared = 0;
    for (std::size_t k = 0; k < std::min(p->light_arm_rad.size(), result_->frames.size()); ++k) {
        if (std::abs(p->light_arm_rad[k] - result_->frames[k].light_arm_rad) > 1e-9) {
            break;
        }
        EXPECT_NEAR(p->predicted_coverage[k], result_->frames[k].coverage_after, 0.02)
            << "after light position " << k + 1;
        ++compared;
    }
    EXPECT_GE(compared, 2u) << "the prediction and the campaign part at the second position";
    EXPECT_LT(result_->frames.front().coverage_after, 0.8 * config_->coverage_target);
    // The campaign plans on every second pixel row and column, the prediction on every pixel: it
    // reaches a few more bins, never fewer, and at least every bin the campaign filled.
    EXPECT_GE(p->reachable_bins, result_->reachable_bins);
    EXPECT_LE(p->reachable_bins, result_->reachable_bins * 11 / 10);
    EXPECT_GE(p->reachable_bins, result_->coverage.covered_bins());
    // Its holes tell the blind zone apart, as the campaign's do.
    std::size_t blind = 0;
    for (const auto& h : p->holes) {
        blind += h.reason == "blind zone" ? h.bins : 0;
    }
    EXPECT_GT(blind, 0u);
}

TEST_F(ImageCampaignTest, BinsMatchGroundTruthWithinNoise) {
    const acquisition::BinnedTable& t = result_->table;
    std::size_t bins = 0;
    std::array<std::size_t, 3> within{};
    std::vector<double> rel;
    for (std::size_t b = 0; b < t.size(); ++b) {
        if (t.count(b) < 10) {
            continue;
        }
        const auto [wi, wo] = brdf::from_half_diff(t.mean_position(b));
        if (wi.z() < 0.2 || wo.z() < 0.2) {
            continue;
        }
        ++bins;
        const brdf::Rgbd f = (*truth_)->eval(wi, wo);
        const brdf::Rgbd m = t.mean(b);
        const brdf::Rgbd se = t.standard_error(b);
        for (int c = 0; c < 3; ++c) {
            within[c] += std::abs(m[c] - f[c]) < 3 * se[c] ? 1 : 0;
        }
        rel.push_back(std::abs(m[0] - f[0]) / f[0]);
    }
    ASSERT_GT(bins, 1000u);
    for (int c = 0; c < 3; ++c) {
        // 3 sigma holds for 99.7% of a normal population; the bin mean is compared with the
        // value at the bin's mean position, which differs from the bin average where the BRDF
        // curves (the specular peak), hence a looser 97%.
        EXPECT_GT(static_cast<double>(within[c]) / bins, 0.97) << "channel " << c;
    }
    EXPECT_LT(image_test::median(rel), 0.01);
}

TEST_F(ImageCampaignTest, FitOfTheDatasetRecoversTheMaterial) {
    const brdf::Dataset data = result_->table.to_dataset("image campaign", 3, result_->bracketed);
    brdf::ModelD m;
    ASSERT_NO_FATAL_FAILURE(fit_ggx_one_lobe(data, kSeed, &m));
    expect_recovered_material(m, truth_model());
}

// A rig file naming the quiet profile: the dataset's sigmas are the bins' standard errors, to
// the bit; the reference budget on the same bins states more for every value.
TEST_F(ImageCampaignTest, QuietRigStatesTheStandardErrors) {
    EXPECT_EQ(config_->error_budget.profile, "quiet");
    const brdf::Dataset stated = acquisition::image_campaign_dataset(*result_, *config_);
    const brdf::Dataset plain =
        result_->table.to_dataset("plain", config_->min_count, result_->bracketed);
    const brdf::Dataset reference =
        acquisition::stated_dataset(result_->table,
                                    "reference",
                                    config_->min_count,
                                    result_->bracketed,
                                    brdf::reference_error_budget(),
                                    acquisition::image_rig_hours(*result_, *config_));
    ASSERT_EQ(stated.samples.size(), plain.samples.size());
    ASSERT_EQ(reference.samples.size(), plain.samples.size());
    ASSERT_GT(plain.samples.size(), 1000u);
    std::size_t differ = 0, larger = 0;
    for (std::size_t i = 0; i < plain.samples.size(); ++i) {
        for (int c = 0; c < 3; ++c) {
            differ += stated.samples[i].sigma[c] != plain.samples[i].sigma[c] ? 1 : 0;
            larger += reference.samples[i].sigma[c] > plain.samples[i].sigma[c] ? 1 : 0;
        }
    }
    EXPECT_EQ(differ, 0u);
    EXPECT_EQ(larger, 3 * plain.samples.size());
}

TEST_F(ImageCampaignTest, AgreesWithPointMeasurementsThroughTheSameSensor) {
    // Point mode stand-in: a flat patch of 64 pixels at the bin's mean configuration, exposed
    // through the same sensor model, dark-corrected with the model's expectation and calibrated
    // with the sensor's known responsivity and the beam's irradiance.
    sim::SensorParams p = simulator(*rig_)->camera().config().sensor;
    p.width = 8;
    p.height = 8;
    p.seed = kSeed + 1;
    sim::SensorModel sensor(p);
    sim::ExposureSettings s;
    const double e_per_count = sensor.e_per_count(s);
    const acquisition::BinnedTable& t = result_->table;
    std::size_t compared = 0;
    std::size_t agree = 0;
    for (std::size_t b = 0; b < t.size(); b += 7) {
        if (t.count(b) < 10) {
            continue;
        }
        const auto [wi, wo] = brdf::from_half_diff(t.mean_position(b));
        if (wi.z() < 0.2 || wo.z() < 0.2) {
            continue;
        }
        const int c = static_cast<int>(compared % 3);
        brdf::Rgbd filter = brdf::Rgbd::Zero();
        filter[c] = 1;
        const double radiance = sim::patch_radiance(**truth_, wi, wo, 1.0, filter);
        s.exposure_us = 10000;
        // Shorten the exposure until the patch is below saturation.
        while (sensor.mean_counts(radiance, s) > 0.8 * sensor.saturation_level(s.format)) {
            s.exposure_us /= 4;
        }
        cv::Mat img = sensor.expose(cv::Mat(8, 8, CV_32F, cv::Scalar(radiance)), s);
        const double t_s = s.exposure_us * 1e-6;
        const double dark =
            sensor.black_level(s.format) + p.dark_current_e_per_s * t_s / e_per_count;
        const double mean = cv::mean(img)[0] - dark;
        const double to_f = e_per_count / (p.responsivity_e_per_s * t_s * 1.0 * wi.z());
        const double f_point = mean * to_f;
        const double sigma_point = std::sqrt(sensor.variance_counts(radiance, s) / 64.0) * to_f;
        const double diff = t.mean(b)[c] - f_point;
        const double sigma = std::hypot(t.standard_error(b)[c], sigma_point);
        agree += std::abs(diff) < 3 * sigma ? 1 : 0;
        ++compared;
    }
    ASSERT_GT(compared, 200u);
    // Both are unbiased estimates of the same BRDF; the image bin averages over its cell (see
    // BinsMatchGroundTruthWithinNoise).
    EXPECT_GT(static_cast<double>(agree) / compared, 0.95);
}

TEST(ImagePerspective, PerspectiveCameraThroughGigEFindsTheSphereAndTheMaterial) {
    // The default perspective camera (0.5 m from the sphere) instead of the telecentric one: the
    // rays, the silhouette's 3D fit with the known radius and the binning through the same device
    // path.
    const std::string model = std::string(GONIO_BINARY_DIR) + "/image_persp_truth_" +
                              std::to_string(::getpid()) + ".json";
    std::ofstream(model) << brdf::model_to_json(truth_model());
    acquisition::ImageRigOptions o;
    o.brdf_path = model;
    o.image_size = 128;
    o.perspective = true;
    o.supersample = 1;
    o.seed = 77;
    o.time_scale = 500;
    auto rig = acquisition::start_image_rig(o, embedded_rig_starter());
    std::filesystem::remove(model);
    ASSERT_TRUE(rig) << rig.error().message;
    EXPECT_EQ((*rig)->camera.projection, acquisition::Projection::kPerspective);
    const acquisition::ImageCampaignConfig cfg =
        acquisition::image_campaign_config((*rig)->rig, (*rig)->camera, 6, 0.5, 30);
    auto r = acquisition::run_image_campaign(acquisition::image_rig_capture(**rig, 0.0), cfg);
    ASSERT_TRUE(r) << r.error().message;
    // Centre within 1 mm of the origin, radius as given (the fit uses it to fix the distance).
    EXPECT_LT(r->sphere.centre.norm(), 1e-3) << r->sphere.centre.transpose();
    const auto truth = brdf::make_analytic_brdf(truth_model());
    const std::vector<double> rel = image_test::table_relative_errors(r->table, *truth, 0);
    ASSERT_GT(rel.size(), 200u);
    EXPECT_LT(image_test::median(rel), 0.02);
}

TEST(ImageCommand, RigWithoutSimSectionIsOpenedAtItsAddresses) {
    // A rig served elsewhere (here: a virtual image rig started by the test) described with its
    // addresses, its calibrated camera model and no "sim" section: the command opens those
    // devices and starts no rig of its own.
    const acquisition::CameraModel camera = acquisition::default_image_camera(96, false, 0.02);
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/data/rigs/sim-image.json");
    std::stringstream text;
    text << in.rdbuf();
    sim::SimRigOptions so;
    so.material = "yellow-plastic";
    so.time_scale = 500;
    so.seed = 9;
    sim::SphereImaging sphere;
    sphere.camera = to_sphere_camera(camera);
    sphere.supersample = 1;
    so.sphere = sphere;
    auto served = sim::SimRig::start(text.str(), so);
    ASSERT_TRUE(served) << served.error().message;
    auto desc = acquisition::parse_rig_config(text.str(), "sim-image.json");
    ASSERT_TRUE(desc) << desc.error().message;
    const acquisition::RigConfig at =
        acquisition::with_addresses(*desc, (*served)->motor_address(), (*served)->camera_address());
    nlohmann::json j = nlohmann::json::parse(at.json);
    j.erase("sim");
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_tools_image/elsewhere_" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    // First without the camera model: an error naming it, nothing started.
    std::ofstream(dir + "/rig-nocam.json") << j.dump(2);
    acquisition::CampaignRequest o;
    o.mode = acquisition::CampaignMode::kImage;
    o.rig_path = dir + "/rig-nocam.json";
    o.out_dir = dir + "/run";
    o.table_factor = 6;
    o.coverage_target = 0.5;
    o.max_frames = 40;
    auto refused = acquisition::run_image_request(o, embedded_rig_starter());
    ASSERT_FALSE(refused);
    EXPECT_NE(refused.error().message.find("camera_model: missing"), std::string::npos)
        << refused.error().message;
    j["camera_model"] = nlohmann::json::parse(acquisition::camera_model_to_json(camera));
    std::ofstream(dir + "/rig.json") << j.dump(2);
    o.rig_path = dir + "/rig.json";
    auto ran = acquisition::run_image_request(o, embedded_rig_starter());
    ASSERT_TRUE(ran) << ran.error().message;
    ASSERT_TRUE(ran->result->target_met);
    // Every frame came from the rig served by the test.
    EXPECT_GT((*served)->camera().frames_rendered(), 20u);
    auto data = brdf::read_dataset_csv(dir + "/run/dataset.csv");
    ASSERT_TRUE(data) << data.error().message;
    const auto truth = (*served)->sample();
    std::vector<double> rel;
    for (const brdf::Sample& smp : data->samples) {
        if (smp.wi().z() < 0.2 || smp.wo().z() < 0.2) {
            continue;
        }
        rel.push_back(std::abs(smp.value[0] / truth->eval(smp.wi(), smp.wo())[0] - 1));
    }
    ASSERT_GT(rel.size(), 500u);
    EXPECT_LT(image_test::median(rel), 0.03);
    std::ifstream meta(dir + "/run/dataset.json");
    std::stringstream ms;
    ms << meta.rdbuf();
    EXPECT_NE(ms.str().find("\"embedded_virtual_rig\": false"), std::string::npos);
    EXPECT_EQ(ms.str().find("ground_truth"), std::string::npos);
    std::filesystem::remove_all(dir);
}

TEST(ImageCommand, WritesDatasetTableAndCoverageMap) {
    const std::string dir = (std::filesystem::temp_directory_path() /
                             ("gonio_image_command_test_" + std::to_string(::getpid())))
                                .string();
    std::filesystem::remove_all(dir);
    acquisition::CampaignRequest o;
    o.mode = acquisition::CampaignMode::kImage;
    o.out_dir = dir;
    o.material = "yellow-plastic";
    o.table_factor = 6;
    o.image_size = 96;
    o.coverage_target = 0.6;
    o.max_frames = 40;
    o.seed = 5;
    auto ran = acquisition::run_image_request(o, embedded_rig_starter());
    ASSERT_TRUE(ran) << ran.error().message;
    ASSERT_TRUE(ran->result->target_met);
    auto data = brdf::read_dataset_csv(dir + "/dataset.csv");
    ASSERT_TRUE(data) << data.error().message;
    EXPECT_TRUE(data->rejected.empty());
    EXPECT_GT(data->samples.size(), 1000u);
    EXPECT_TRUE(data->has_sigma);
    auto table = brdf::load_brdf(dir + "/table.gtab");
    ASSERT_TRUE(table) << table.error().message;
    const cv::Mat png = cv::imread(dir + "/coverage.png");
    EXPECT_EQ(png.cols, 15 * 4);
    EXPECT_EQ(png.rows, 15 * 4);
    EXPECT_TRUE(std::filesystem::exists(dir + "/dataset.json"));
    // A bad option is an error naming it.
    acquisition::CampaignRequest bad = o;
    bad.table_factor = 7;
    auto refused = acquisition::run_image_request(bad, embedded_rig_starter());
    ASSERT_FALSE(refused);
    EXPECT_NE(refused.error().message.find("table factor 7: must divide 90"), std::string::npos)
        << refused.error().message;
    EXPECT_EQ(refused.error().message.find("--table-factor"), std::string::npos);
    bad = o;
    bad.material = "no-such-material";
    EXPECT_FALSE(acquisition::run_image_request(bad, embedded_rig_starter()));
    std::filesystem::remove_all(dir);
}

TEST(ImageCommand, GonioAcquireImageModeThroughGigERecoversTheGroundTruth) {
    // The binary end to end: the virtual rig's motor controllers on Modbus TCP, its camera a GigE
    // Vision device on a loopback address of its own, opened through Aravis; every dataset row
    // (one per filled bin) against the ground truth at its direction pair.
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_tools_image/cli_" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string model = dir + "_truth.json";
    std::ofstream(model) << brdf::model_to_json(truth_model());
    const std::string cmd = std::string(GONIO_EXE) + " acquire --mode image --brdf " + model +
                            " --out " + dir + "/run --coverage-target 0.5 --time-scale 200 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::string out;
    char buf[4096];
    while (std::fgets(buf, sizeof buf, p)) {
        out += buf;
    }
    const int st = pclose(p);
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << out;
    EXPECT_NE(out.find("camera gige://127."), std::string::npos) << out;
    EXPECT_NE(out.find("0 exposures repeated, 0 poses corrected"), std::string::npos) << out;
    auto data = brdf::read_dataset_csv(dir + "/run/dataset.csv");
    ASSERT_TRUE(data) << data.error().message;
    ASSERT_TRUE(data->has_sigma);
    const auto truth = brdf::make_analytic_brdf(truth_model());
    std::size_t rows = 0;
    std::size_t within = 0;
    std::vector<double> rel;
    for (const brdf::Sample& smp : data->samples) {
        if (smp.wi().z() < 0.2 || smp.wo().z() < 0.2) {
            continue;
        }
        const brdf::Rgbd f = truth->eval(smp.wi(), smp.wo());
        for (int c = 0; c < 3; ++c) {
            ++rows;
            within += std::abs(smp.value[c] - f[c]) < 3 * smp.sigma[c] ? 1 : 0;
        }
        rel.push_back(std::abs(smp.value[1] / f[1] - 1));
    }
    ASSERT_GT(rel.size(), 5000u);
    // As BinsMatchGroundTruthWithinNoise: 3 standard errors, the bin average against the value at
    // the bin's mean position.
    EXPECT_GT(static_cast<double>(within) / rows, 0.97);
    EXPECT_LT(image_test::median(rel), 0.01);
    const std::string meta = [&] {
        std::ifstream in(dir + "/run/dataset.json");
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }();
    EXPECT_NE(meta.find("\"camera_address\": \"gige://127."), std::string::npos);
    std::filesystem::remove_all(dir);
    std::filesystem::remove(model);
}

/// Runs an image campaign with a frame journal in a child process (fresh rig, seeded); the child
/// kills itself with SIGKILL at the `kill_exposure`-th exposure the virtual camera renders or right
/// after frame `kill_after_frames` is journaled (0: never). Returns the wait status.
/// A journaled campaign: the rig and the campaign's table, coverage target and frame limit.
struct JournaledCampaign {
    acquisition::ImageRigOptions rig;
    int table_factor = 6;
    double coverage_target = 0.6;
    int max_frames = 40;
};

Expected<std::unique_ptr<acquisition::ImageRig>> start_rig(const JournaledCampaign& o) {
    return acquisition::start_image_rig(o.rig, embedded_rig_starter());
}

int journaled_child(const JournaledCampaign& o,
                    const std::string& journal,
                    std::uint64_t kill_exposure,
                    std::size_t kill_after_frames) {
    return image_test::campaign_in_child(o.rig, kill_exposure, [&](acquisition::ImageRig& rig) {
        const acquisition::ImageCampaignConfig cfg = acquisition::image_campaign_config(
            rig.rig, rig.camera, o.table_factor, o.coverage_target, o.max_frames);
        auto progress = [kill_after_frames](std::size_t i, const acquisition::FrameRecord&) {
            if (kill_after_frames > 0 && i + 1 == kill_after_frames) {
                ::raise(SIGKILL);
            }
        };
        auto r = acquisition::run_image_campaign(
            acquisition::image_rig_capture(rig, cfg.detector_arm_rad), cfg, progress, journal);
        if (!r) {
            std::fprintf(stderr, "child: %s\n", r.error().message.c_str());
        }
        return r.has_value();
    });
}

TEST(ImageResume, KillNineAtThreeMomentsLosesNoFrameAndRepeatsNone) {
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_tools_image/resume_" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string model = dir + "/truth.json";
    std::ofstream(model) << brdf::model_to_json(truth_model());
    const std::string journal = dir + "/frames.journal";
    JournaledCampaign o;
    o.rig.brdf_path = model;
    o.rig.image_size = 120;
    o.rig.supersample = 1;
    o.rig.seed = kSeed;
    o.rig.time_scale = 500;
    o.table_factor = 6;
    o.coverage_target = 0.6;
    o.max_frames = 40;

    // 1. Inside the set-up (the white reference's third exposure): nothing is journaled.
    int st = journaled_child(o, journal, 3, 0);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        EXPECT_FALSE(j->setup());
        EXPECT_TRUE(j->frames().empty());
    }
    // 2. Right after the second frame is journaled, before the arm moves on.
    st = journaled_child(o, journal, 0, 2);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    const std::string after_two = gonio::testing::read_text(journal);
    {
        auto j = acquisition::ImageJournal::open(journal);
        ASSERT_TRUE(j) << j.error().message;
        ASSERT_TRUE(j->setup());
        ASSERT_EQ(j->frames().size(), 2u);
    }
    // 3. In the middle of a later frame's captures (the resumed run takes no set-up exposures).
    st = journaled_child(o, journal, 20, 0);
    ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL) << "status " << st;
    const std::string after_three = gonio::testing::read_text(journal);
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
    auto rig = start_rig(o);
    ASSERT_TRUE(rig) << rig.error().message;
    const acquisition::ImageCampaignConfig cfg = acquisition::image_campaign_config(
        (*rig)->rig, (*rig)->camera, o.table_factor, o.coverage_target, o.max_frames);
    const std::uint64_t rendered_before = simulator(**rig)->camera().frames_rendered();
    auto r = acquisition::run_image_campaign(
        acquisition::image_rig_capture(**rig, cfg.detector_arm_rad), cfg, {}, journal);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_TRUE(r->target_met) << r->stop_reason;
    EXPECT_EQ(r->resumed_frames, frames_at_kill);
    const std::uint64_t rendered_now =
        simulator(**rig)->camera().frames_rendered() - rendered_before;
    const std::string final_bytes = gonio::testing::read_text(journal);
    EXPECT_EQ(final_bytes.substr(0, after_three.size()), after_three);

    auto j = acquisition::ImageJournal::open(journal);
    ASSERT_TRUE(j) << j.error().message;
    ASSERT_EQ(j->frames().size(), r->frames.size());
    // Only new frames were captured: no reference, no silhouette. Every frame the camera rendered
    // in this run is a capture of a frame journaled after the kill (three channels at least, as
    // the journal counts them) or a capture taken again after a camera error; a repeated set-up
    // would add its own.
    const std::size_t new_frames = r->frames.size() - frames_at_kill;
    std::uint64_t new_frame_captures = 0;
    for (std::size_t k = frames_at_kill; k < j->frames().size(); ++k) {
        new_frame_captures += j->frames()[k].captures;
    }
    EXPECT_GE(new_frame_captures, 3 * new_frames);
    EXPECT_EQ(rendered_now, new_frame_captures + (*rig)->pose_log.capture_retries)
        << "rendered beyond the new frames' captures";
    // No light position measured twice; every journaled frame's samples are in the table once.
    std::vector<double> lights;
    std::uint64_t used = 0;
    std::uint64_t in_bins = 0;
    for (const acquisition::ImageJournalFrame& f : j->frames()) {
        lights.push_back(f.light_arm_rad);
        used += f.counts.used;
        for (const acquisition::BinAggregate& a : f.bins) {
            in_bins += a.count;
        }
    }
    std::sort(lights.begin(), lights.end());
    EXPECT_EQ(std::adjacent_find(lights.begin(), lights.end()), lights.end())
        << "a light position was measured twice";
    EXPECT_EQ(used, in_bins);
    EXPECT_EQ(r->table.total_samples(), used);
    EXPECT_EQ(r->counts.used, used);
    // The table rebuilt across four processes still measures the material.
    const auto truth = brdf::make_analytic_brdf(truth_model());
    const std::vector<double> rel = image_test::table_relative_errors(r->table, *truth, 1);
    ASSERT_GT(rel.size(), 200u);
    EXPECT_LT(image_test::median(rel), 0.02);

    // Resuming the finished campaign captures nothing.
    const std::uint64_t rendered_done = simulator(**rig)->camera().frames_rendered();
    auto again = acquisition::run_image_campaign(
        acquisition::image_rig_capture(**rig, cfg.detector_arm_rad), cfg, {}, journal);
    ASSERT_TRUE(again) << again.error().message;
    EXPECT_EQ(again->resumed_frames, r->frames.size());
    EXPECT_EQ(again->frames.size(), r->frames.size());
    EXPECT_EQ(simulator(**rig)->camera().frames_rendered(), rendered_done);
    EXPECT_EQ(gonio::testing::read_text(journal), final_bytes);
    std::filesystem::remove_all(dir);
}

TEST(ImageResume, JournalOfAnotherTableIsRefused) {
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_tools_image/other_" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    acquisition::ImageJournalSetup s;
    s.layout = acquisition::coarse_layout(3);
    s.calibration = {1, 1, 1};
    {
        auto j = acquisition::ImageJournal::open(dir + "/frames.journal");
        ASSERT_TRUE(j);
        ASSERT_TRUE(j->append_setup(s));
    }
    acquisition::ImageRigOptions o;
    o.material = "yellow-plastic";
    o.image_size = 96;
    o.supersample = 1;
    o.time_scale = 500;
    auto rig = acquisition::start_image_rig(o, embedded_rig_starter());
    ASSERT_TRUE(rig) << rig.error().message;
    const acquisition::ImageCampaignConfig cfg =
        acquisition::image_campaign_config((*rig)->rig, (*rig)->camera, 6, 0.5, 10);
    auto r = acquisition::run_image_campaign(
        acquisition::image_rig_capture(**rig, 0.0), cfg, {}, dir + "/frames.journal");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("30x30x60"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("15x15x30"), std::string::npos) << r.error().message;
    EXPECT_EQ(simulator(**rig)->camera().frames_rendered(), 0u);
    std::filesystem::remove_all(dir);
}

TEST(ImageCommand, RequestResumesFromTheFolderWhoseSettingsAreReadStrictly) {
    // The library runs the whole campaign a front end asks for: folder, settings, journal and
    // resume (the command only prints).
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_tools_image/reqresume_" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string model = dir + "/truth.json";
    std::ofstream(model) << brdf::model_to_json(truth_model());
    acquisition::CampaignRequest r;
    r.mode = acquisition::CampaignMode::kImage;
    r.brdf_path = model;
    r.out_dir = dir + "/camp";
    r.grid = {15, 15, 30};
    r.coverage_target = 0.5;
    r.max_frames = 2;
    r.time_scale = 500;
    r.image_size = 96;
    // A front end that cannot start (its live page's address in use): nothing is written.
    acquisition::ImageRunHooks refuse;
    refuse.started = [](const acquisition::ImageCampaignRun&) -> Expected<void> {
        return make_error("address in use");
    };
    auto stopped = acquisition::run_image_request(r, embedded_rig_starter(), refuse);
    ASSERT_FALSE(stopped);
    EXPECT_EQ(stopped.error().message, "address in use");
    EXPECT_FALSE(std::filesystem::exists(r.out_dir));
    // Two frames do not reach the target; the folder keeps the settings and the journal.
    auto first = acquisition::run_image_request(r, embedded_rig_starter());
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_FALSE(first->resumed);
    EXPECT_FALSE(first->result->target_met);
    ASSERT_EQ(first->result->frames.size(), 2u);
    EXPECT_TRUE(acquisition::is_image_campaign_dir(r.out_dir));
    EXPECT_EQ(first->journal, r.out_dir + "/frames.journal");
    const std::string settings_path = r.out_dir + "/image_campaign.json";
    nlohmann::json settings;
    {
        std::ifstream in(settings_path);
        settings = nlohmann::json::parse(in);
    }
    EXPECT_EQ(settings.at("max_frames"), 2);
    EXPECT_EQ(settings.at("brdf"), "ground_truth.json");
    auto resume_with = [&](const nlohmann::json& j) {
        std::ofstream(settings_path) << j.dump(2);
        acquisition::CampaignRequest again;
        again.mode = acquisition::CampaignMode::kImage;
        again.resume_dir = r.out_dir;
        return acquisition::run_image_request(again, embedded_rig_starter());
    };
    // The settings file is read like every other: an unknown key or a wrong type is refused with
    // the file and the key path, before any device is touched.
    nlohmann::json misspelt = settings;
    misspelt["max_frame"] = 60;
    auto bad = resume_with(misspelt);
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("image_campaign.json: max_frame: unknown key"),
              std::string::npos)
        << bad.error().message;
    nlohmann::json typed = settings;
    typed["max_frames"] = "60";
    bad = resume_with(typed);
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("max_frames: expected a whole number, got string"),
              std::string::npos)
        << bad.error().message;
    // More frames allowed: the resume reads the two journaled frames back and goes on.
    nlohmann::json more = settings;
    more["max_frames"] = 4;
    auto resumed = resume_with(more);
    ASSERT_TRUE(resumed) << resumed.error().message;
    EXPECT_TRUE(resumed->resumed);
    EXPECT_EQ(resumed->dir, r.out_dir);
    EXPECT_EQ(resumed->result->resumed_frames, 2u);
    EXPECT_GT(resumed->result->frames.size(), 2u);
    EXPECT_LE(resumed->result->frames.size(), 4u);
    std::filesystem::remove_all(dir);
}

TEST(ImageCommand, InterruptedCampaignResumesThroughTheCommand) {
    // A journal holding the set-up and a few frames (the campaign stopped there) continued by
    // `gonio acquire --resume DIR`, which reads the folder's settings and ground truth.
    const std::string dir =
        std::string(GONIO_BINARY_DIR) + "/test_tools_image/cmdresume_" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    const std::string model = dir + "_truth.json";
    std::filesystem::create_directories(std::filesystem::path(dir).parent_path());
    std::ofstream(model) << brdf::model_to_json(truth_model());
    const std::string base = std::string(GONIO_EXE) + " acquire --mode image --brdf " + model +
                             " --out " + dir + " --grid 15x15x30 --coverage-target 0.5 " +
                             "--time-scale 500 --max-frames 3 2>&1";
    auto run = [](const std::string& cmd, std::string* out) {
        FILE* p = popen(cmd.c_str(), "r");
        char buf[4096];
        while (p != nullptr && std::fgets(buf, sizeof buf, p)) {
            *out += buf;
        }
        return p == nullptr ? -1 : pclose(p);
    };
    std::string out;
    int st = run(base, &out);
    // Three frames do not reach the target: exit 1, the folder holds the journal.
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 1) << out;
    ASSERT_TRUE(std::filesystem::exists(dir + "/frames.journal")) << out;
    ASSERT_TRUE(std::filesystem::exists(dir + "/ground_truth.json")) << out;
    // Starting again over it is refused.
    out.clear();
    st = run(base, &out);
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 1) << out;
    EXPECT_NE(out.find("already holds an image campaign"), std::string::npos) << out;
    // Raise the frame limit in the stored settings (an operator allowing more frames) and resume.
    {
        std::ifstream in(dir + "/image_campaign.json");
        nlohmann::json j = nlohmann::json::parse(in);
        j["max_frames"] = 60;
        std::ofstream(dir + "/image_campaign.json") << j.dump(2);
    }
    out.clear();
    st = run(std::string(GONIO_EXE) + " acquire --resume " + dir + " 2>&1", &out);
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << out;
    EXPECT_NE(out.find("resumed: 3 frames"), std::string::npos) << out;
    EXPECT_NE(out.find("valid bins"), std::string::npos) << out;
    auto data = brdf::read_dataset_csv(dir + "/dataset.csv");
    ASSERT_TRUE(data) << data.error().message;
    EXPECT_GT(data->samples.size(), 1000u);
    // A malformed grid is a usage error naming the option.
    out.clear();
    st = run(
        std::string(GONIO_EXE) + " acquire --mode image --grid 90x90 --out " + dir + "_bad 2>&1",
        &out);
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 2) << out;
    EXPECT_NE(out.find("--grid"), std::string::npos) << out;
    out.clear();
    st = run(std::string(GONIO_EXE) + " acquire --grid 30x30x60 --plan-only 2>&1", &out);
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 2) << out;
    EXPECT_NE(out.find("--grid cannot be combined with --mode point"), std::string::npos) << out;
    std::filesystem::remove_all(dir);
    std::filesystem::remove(model);
}

// An image campaign on the virtual rig with the reference error budget (docs/error-budget.md):
// its instrument fluctuates, drifts and points its arms off as a real one does, and the sigmas
// the campaign's dataset states cover it: the bins' values within 3 sigma of the ground truth,
// the bins of the highest signal too, where the bins' standard errors alone fall far short.

brdf::ModelD budget_truth() {
    return image_test::lambert_ggx(brdf::Rgbd(0.30, 0.20, 0.10), 0.25);
}

constexpr std::uint64_t kBudgetSeed = 606;

/// data/rigs/sim-image.json without its "error_budget": the reference profile, the default (the
/// shipped file names it; ImageRigFiles above).
std::string reference_rig_json() {
    nlohmann::json j = nlohmann::json::parse(shipped_image_rig_text("sim-image.json"));
    j.erase("error_budget");
    return j.dump(2);
}

class ImageBudgetTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        dir_ = new std::string(std::string(GONIO_BINARY_DIR) + "/test_tools_image/budget_" +
                               std::to_string(::getpid()));
        std::filesystem::remove_all(*dir_);
        std::filesystem::create_directories(*dir_);
        std::ofstream(*dir_ + "/rig.json") << reference_rig_json();
        std::ofstream(*dir_ + "/truth.json") << brdf::model_to_json(budget_truth());
        acquisition::ImageRigOptions o;
        o.rig_path = *dir_ + "/rig.json";
        o.brdf_path = *dir_ + "/truth.json";
        // Enough pixels per bin (hundreds in a 15 x 15 x 30 table) that the brightest bins' standard
        // errors fall well below the budget's relative terms.
        o.image_size = 800;
        o.supersample = 1;
        o.seed = kBudgetSeed;
        o.time_scale = 200;
        auto rig = acquisition::start_image_rig(o, embedded_rig_starter());
        if (!rig) {
            error_ = new std::string(rig.error().message);
            return;
        }
        rig_ = rig->release();
        config_ = new acquisition::ImageCampaignConfig(
            acquisition::image_campaign_config(rig_->rig, rig_->camera, 6, 0.5, 60));
        auto r =
            acquisition::run_image_campaign(acquisition::image_rig_capture(*rig_, 0.0), *config_);
        if (!r) {
            error_ = new std::string(r.error().message);
            return;
        }
        result_ = new acquisition::ImageCampaignResult(std::move(*r));
        if (auto w = acquisition::write_image_campaign(*dir_ + "/run", *result_, *config_); !w) {
            error_ = new std::string(w.error().message);
        }
    }
    static void TearDownTestSuite() {
        if (dir_ != nullptr) {
            std::filesystem::remove_all(*dir_);
        }
        delete result_;
        delete config_;
        delete rig_;
        delete error_;
        delete dir_;
        result_ = nullptr;
        error_ = nullptr;
    }
    void SetUp() override {
        ASSERT_EQ(error_, nullptr) << *error_ << " (seed " << kBudgetSeed << ")";
        ASSERT_NE(result_, nullptr);
    }

    /// dataset.csv as the campaign wrote it.
    static brdf::Dataset written() {
        auto d = brdf::read_dataset_csv(*dir_ + "/run/dataset.csv");
        EXPECT_TRUE(d) << d.error().message;
        return d ? *d : brdf::Dataset{};
    }

    static std::string* dir_;
    static acquisition::ImageRig* rig_;
    static acquisition::ImageCampaignConfig* config_;
    static acquisition::ImageCampaignResult* result_;
    static std::string* error_;
};

std::string* ImageBudgetTest::dir_ = nullptr;
acquisition::ImageRig* ImageBudgetTest::rig_ = nullptr;
acquisition::ImageCampaignConfig* ImageBudgetTest::config_ = nullptr;
acquisition::ImageCampaignResult* ImageBudgetTest::result_ = nullptr;
std::string* ImageBudgetTest::error_ = nullptr;

// The campaign ran the reference profile on the rig and in its dataset; every value (channel by
// channel, directions at least acos(0.2) from the horizon) against the truth at its directions.
TEST_F(ImageBudgetTest, StatedSigmasCoverTheTruth) {
    EXPECT_EQ(config_->error_budget.profile, "reference");
    EXPECT_EQ(simulator(*rig_)->error_budget().profile, "reference");
    std::ifstream in(*dir_ + "/run/dataset.json");
    const nlohmann::json meta = nlohmann::json::parse(in);
    EXPECT_EQ(meta["stated_uncertainty"]["error_budget"], "reference");
    // The exposures and the light arm's moves between frames: a minute or two of rig time.
    const double hours = meta["stated_uncertainty"]["rig_hours_since_white"].get<double>();
    EXPECT_GT(hours * 3600, result_->exposure_time_s + 1.0);
    EXPECT_LT(hours, 0.5);
    const brdf::Dataset d = written();
    const auto truth = brdf::make_analytic_brdf(budget_truth());
    std::size_t within = 0, n = 0;
    for (const brdf::Sample& s : d.samples) {
        if (s.wi().z() < 0.2 || s.wo().z() < 0.2) {
            continue;
        }
        const brdf::Rgbd f = truth->eval(s.wi(), s.wo());
        for (int c = 0; c < 3; ++c) {
            ++n;
            within += std::abs(s.value[c] - f[c]) <= 3 * s.sigma[c] ? 1 : 0;
        }
    }
    std::printf("all values: %zu of %zu within 3 sigma\n", within, n);
    ASSERT_GT(n, 3000u);
    EXPECT_GE(static_cast<double>(within) / n, 0.95) << within << " of " << n;
}

// The brightest bins, with hundreds of pixels near full well each, have standard errors under
// 0.1 % of their values: there the instrument's terms (the lamp's 0.15 % per frame and in the
// white reference, the non-linearity, the arms) are what the values scatter by.
TEST_F(ImageBudgetTest, HighSignalBinsAreCoveredOnlyWithTheBudget) {
    const brdf::Dataset d = written();
    const brdf::Dataset plain = result_->table.to_dataset("plain", config_->min_count, false);
    ASSERT_EQ(plain.samples.size(), d.samples.size());
    const auto truth = brdf::make_analytic_brdf(budget_truth());
    std::size_t n = 0, stated = 0, se_only = 0;
    for (std::size_t i = 0; i < d.samples.size(); ++i) {
        const brdf::Sample& s = d.samples[i];
        if (s.wi().z() < 0.2 || s.wo().z() < 0.2) {
            continue;
        }
        const brdf::Rgbd f = truth->eval(s.wi(), s.wo());
        for (int c = 0; c < 3; ++c) {
            const double se = plain.samples[i].sigma[c];
            if (!(se < 1e-3 * f[c])) {
                continue;
            }
            const double err = std::abs(s.value[c] - f[c]);
            ++n;
            stated += err <= 3 * s.sigma[c] ? 1 : 0;
            se_only += err <= 3 * se ? 1 : 0;
        }
    }
    std::printf(
        "high-signal values: %zu (stated sigma) and %zu (standard error) of %zu within 3 "
        "sigma\n",
        stated,
        se_only,
        n);
    ASSERT_GT(n, 500u);
    EXPECT_GE(static_cast<double>(stated) / n, 0.95) << stated << " of " << n;
    // The standard errors alone leave far more outside.
    EXPECT_LT(static_cast<double>(se_only) / n, 0.75) << se_only << " of " << n;
}

TEST_F(ImageBudgetTest, FitOfTheDatasetRecoversTheMaterial) {
    const brdf::Dataset data = written();
    brdf::ModelD m;
    ASSERT_NO_FATAL_FAILURE(fit_ggx_one_lobe(data, kBudgetSeed, &m));
    const brdf::ModelD truth = budget_truth();
    std::printf("fit: alpha %.5f (truth %.2f)\n", m.lobes[0].alpha_x, truth.lobes[0].alpha_x);
    expect_recovered_material(m, truth);
}

}  // namespace
}  // namespace gonio::tools
