#include "acquire_image_mode.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::tools {

std::shared_ptr<SimulatedImageRig> make_simulated_image_rig(
    std::shared_ptr<const brdf::Brdf> sample,
    const acquisition::CameraModel* camera,
    int image_size,
    bool perspective,
    std::uint64_t seed) {
    auto rig = std::make_shared<SimulatedImageRig>();
    if (camera != nullptr) {
        rig->camera = *camera;
    } else {
        acquisition::CameraIntrinsics k;
        k.width = image_size;
        k.height = image_size;
        k.cx = (image_size - 1) / 2.0;
        k.cy = (image_size - 1) / 2.0;
        k.pixel_size_um = 5.5;
        // A 20 mm sphere filling about 80% of the frame.
        const double fill_px = 0.4 * image_size;
        if (perspective) {
            // 0.5 m away: angular radius asin(0.02 / 0.5), image radius f tan(angle).
            k.fx = k.fy = fill_px / std::tan(std::asin(0.02 / 0.5));
        } else {
            k.fx = k.fy = fill_px / 0.02;  // px per metre
        }
        rig->camera = acquisition::camera_on_detector_arm(
            k,
            perspective ? acquisition::Projection::kPerspective
                        : acquisition::Projection::kOrthographic,
            0.0,
            0.5);
    }
    const acquisition::CameraModel& c = rig->camera;
    sim::SphereCamera& sc = rig->scene.camera;
    sc.projection = c.projection == acquisition::Projection::kPerspective
                        ? sim::SphereProjection::kPerspective
                        : sim::SphereProjection::kOrthographic;
    sc.width = c.intrinsics.width;
    sc.height = c.intrinsics.height;
    sc.fx = c.intrinsics.fx;
    sc.fy = c.intrinsics.fy;
    sc.cx = c.intrinsics.cx;
    sc.cy = c.intrinsics.cy;
    sc.distortion = c.intrinsics.distortion;
    sc.rotation = c.rotation;
    sc.translation = c.translation;
    rig->scene.centre = brdf::Vec3d::Zero();
    rig->scene.radius_m = 0.02;
    rig->scene.irradiance_w_m2 = 1.0;
    rig->scene.supersample = 2;
    sim::SensorParams p;
    p.width = sc.width;
    p.height = sc.height;
    p.seed = seed;
    rig->sensor = std::make_unique<sim::SensorModel>(p);
    rig->settings.exposure_us = 10000;
    rig->sample = std::move(sample);
    brdf::ModelD white;
    white.has_diffuse = true;
    white.diffuse = brdf::Rgbd::Constant(0.99);
    rig->reference = brdf::make_analytic_brdf(white);
    return rig;
}

acquisition::CaptureFn simulated_capture(std::shared_ptr<SimulatedImageRig> rig) {
    return [rig](const acquisition::CaptureRequest& r) -> Expected<devices::Frame> {
        if (r.channel < 0 || r.channel > 2) {
            return make_error("simulated camera: no filter " + std::to_string(r.channel));
        }
        sim::SphereScene scene = rig->scene;
        scene.light_world = brdf::arm_direction(r.light_arm_rad);
        scene.shutter_open = r.shutter_open;
        scene.filter = brdf::Rgbd::Zero();
        scene.filter[r.channel] = 1.0;
        sim::ExposureSettings s = rig->settings;
        s.exposure_us = r.exposure_us;
        const brdf::Brdf& f = r.reference ? *rig->reference : *rig->sample;
        return sim::render_sphere_frame(f, scene, *rig->sensor, s);
    };
}

acquisition::ImageCampaignConfig simulated_campaign_config(const SimulatedImageRig& rig,
                                                           int table_factor,
                                                           double coverage_target,
                                                           int max_frames) {
    acquisition::ImageCampaignConfig cfg;
    cfg.camera = rig.camera;
    cfg.layout = table_factor <= 1 ? acquisition::TableLayout::merl()
                                   : acquisition::coarse_layout(table_factor);
    cfg.detector_arm_rad = 0;
    cfg.lights.min_rad = -brdf::kPi;
    cfg.lights.max_rad = brdf::kPi;
    cfg.lights.step_rad = brdf::kPi / 180;
    cfg.lights.blind_zone_rad = 5 * brdf::kPi / 180;
    cfg.coverage_target = coverage_target;
    cfg.max_frames = max_frames;
    cfg.silhouette.radius_m = rig.scene.radius_m;
    cfg.exposure_us = rig.settings.exposure_us;
    cfg.electrons_per_count = rig.sensor->e_per_count(rig.settings);
    cfg.read_noise_counts = rig.sensor->params().read_noise_e / cfg.electrons_per_count;
    cfg.reference_albedo = 0.99;
    return cfg;
}

namespace {

std::string new_output_dir(const std::string& material) {
    for (int n = 1;; ++n) {
        const std::string d = "image-" + material + "-" + std::to_string(n);
        if (!std::filesystem::exists(d)) {
            return d;
        }
    }
}

}  // namespace

int run_acquire_image_mode(const AcquireImageOptions& o) {
    std::shared_ptr<const brdf::Brdf> sample;
    std::string truth_name = o.material;
    if (!o.brdf_path.empty()) {
        auto b = brdf::load_brdf(o.brdf_path);
        if (!b) {
            std::fprintf(stderr, "gonio acquire: %s\n", b.error().message.c_str());
            return 1;
        }
        sample = std::move(*b);
        truth_name = std::filesystem::path(o.brdf_path).stem().string();
    } else {
        auto m = brdf::load_material(o.material);
        if (!m) {
            std::fprintf(stderr, "gonio acquire: %s\n", m.error().message.c_str());
            return 1;
        }
        sample = brdf::make_analytic_brdf(*m);
    }
    if (!sample->isotropic()) {
        std::fprintf(stderr,
                     "gonio acquire: image mode bins into an isotropic half/difference table; "
                     "%s is anisotropic\n",
                     sample->describe().c_str());
        return 1;
    }
    std::optional<acquisition::CameraModel> camera;
    if (!o.rig_path.empty()) {
        auto c = acquisition::read_camera_model(o.rig_path);
        if (!c) {
            std::fprintf(stderr, "gonio acquire: %s\n", c.error().message.c_str());
            return 1;
        }
        camera = *c;
    }
    if (o.table_factor < 1 || 90 % o.table_factor != 0) {
        std::fprintf(stderr,
                     "gonio acquire: --table-factor %d must divide 90 (1 = MERL resolution)\n",
                     o.table_factor);
        return 1;
    }
    auto rig = make_simulated_image_rig(
        sample, camera ? &*camera : nullptr, o.image_size, o.perspective, o.seed);
    const acquisition::ImageCampaignConfig cfg =
        simulated_campaign_config(*rig, o.table_factor, o.coverage_target, o.max_frames);
    const std::string dir = o.out_dir.empty() ? new_output_dir(truth_name) : o.out_dir;
    if (!o.quiet) {
        std::printf("image mode: %s sphere on the simulated rig, %dx%dx%d table, target %.0f%%\n",
                    truth_name.c_str(),
                    cfg.layout.n_theta_h,
                    cfg.layout.n_theta_d,
                    cfg.layout.n_phi_d,
                    100 * cfg.coverage_target);
    }
    auto progress = [&](std::size_t i, const acquisition::FrameRecord& r) {
        if (!o.quiet) {
            std::printf("frame %zu: light %.1f deg, %llu samples, coverage %.1f%%\n",
                        i + 1,
                        r.light_arm_rad * 180 / brdf::kPi,
                        static_cast<unsigned long long>(r.counts.used),
                        100 * r.coverage_after);
            std::fflush(stdout);
        }
    };
    auto result = acquisition::run_image_campaign(simulated_capture(rig), cfg, progress);
    if (!result) {
        std::fprintf(stderr, "gonio acquire: %s\n", result.error().message.c_str());
        return 1;
    }
    nlohmann::json extra;
    extra["sample"] = truth_name;
    extra["ground_truth"] = sample->describe();
    extra["rig"] = o.rig_path.empty() ? "embedded simulated rig" : o.rig_path;
    extra["seed"] = o.seed;
    if (auto w = acquisition::write_image_campaign(dir, *result, cfg, extra.dump()); !w) {
        std::fprintf(stderr, "gonio acquire: %s\n", w.error().message.c_str());
        return 1;
    }
    const acquisition::PixelCounts& c = result->counts;
    std::printf(
        "%s: %zu frames, %llu pixel samples in %zu bins; coverage %.1f%% of %zu valid bins "
        "(reachable %zu)\n",
        dir.c_str(),
        result->frames.size(),
        static_cast<unsigned long long>(c.used),
        result->table.filled_bins(),
        100 * result->coverage.fraction(),
        result->coverage.valid_bins(),
        result->reachable_bins);
    std::printf(
        "excluded pixels: edge %llu, grazing view %llu, shadow %llu, grazing light %llu, "
        "saturated %llu\n",
        static_cast<unsigned long long>(c.edge),
        static_cast<unsigned long long>(c.grazing_view),
        static_cast<unsigned long long>(c.shadow),
        static_cast<unsigned long long>(c.grazing_light),
        static_cast<unsigned long long>(c.saturated));
    std::size_t hole_bins = 0;
    for (const auto& h : result->holes) {
        hole_bins += h.bins;
    }
    std::printf(
        "holes: %zu empty valid bins in %zu groups (dataset.json lists them); stopped: %s\n",
        hole_bins,
        result->holes.size(),
        result->stop_reason.c_str());
    if (!result->target_met) {
        std::fprintf(stderr,
                     "gonio acquire: coverage target %.1f%% not met (%.1f%%)\n",
                     100 * cfg.coverage_target,
                     100 * result->coverage.fraction());
        return 1;
    }
    return 0;
}

}  // namespace gonio::tools
