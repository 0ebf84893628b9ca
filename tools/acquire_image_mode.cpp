#include "acquire_image_mode.h"

#include <cstdio>

#include "embedded_rig.h"
#include "gonio/brdf/coords.h"

namespace gonio::tools {

namespace {

int print_plan(const acquisition::CampaignRequest& request) {
    auto plan = acquisition::plan_image_campaign(request);
    if (!plan) {
        std::fprintf(stderr, "gonio acquire: %s\n", plan.error().message.c_str());
        return 1;
    }
    const acquisition::ImageCampaignConfig& c = plan->config;
    std::printf(
        "image mode plan on %s: %dx%dx%d table, coverage target %.0f%%, at most %d light "
        "positions in [%.1f, %.1f] deg, detector arm %.1f deg\n",
        plan->embedded ? "the embedded virtual rig" : plan->rig_name.c_str(),
        c.layout.n_theta_h,
        c.layout.n_theta_d,
        c.layout.n_phi_d,
        100 * c.coverage_target,
        c.max_frames,
        c.lights.min_rad * 180 / brdf::kPi,
        c.lights.max_rad * 180 / brdf::kPi,
        c.detector_arm_rad * 180 / brdf::kPi);
    return 0;
}

}  // namespace

int run_acquire_image_mode(const acquisition::CampaignRequest& request) {
    if (request.plan_only) {
        return print_plan(request);
    }
    auto started = [](const acquisition::ImageCampaignRun& r) {
        std::printf(
            "image mode: %s sphere on %s (motors %s, camera %s), %dx%dx%d table, "
            "target %.0f%%\n",
            r.sample.c_str(),
            r.embedded ? "the virtual rig" : r.rig_name.c_str(),
            r.motor_address.c_str(),
            r.camera_address.c_str(),
            r.config.layout.n_theta_h,
            r.config.layout.n_theta_d,
            r.config.layout.n_phi_d,
            100 * r.config.coverage_target);
        std::fflush(stdout);
    };
    auto progress = [](std::size_t i, const acquisition::FrameRecord& r) {
        std::printf("frame %zu: light %.1f deg, %llu samples, coverage %.1f%%\n",
                    i + 1,
                    r.light_arm_rad * 180 / brdf::kPi,
                    static_cast<unsigned long long>(r.counts.used),
                    100 * r.coverage_after);
        std::fflush(stdout);
    };
    auto run = acquisition::run_image_request(request, embedded_rig_starter(), started, progress);
    if (!run) {
        std::fprintf(stderr, "gonio acquire: %s\n", run.error().message.c_str());
        return 1;
    }
    const acquisition::ImageCampaignResult& result = *run->result;
    const acquisition::PoseCheckLog& poses = run->poses;
    const acquisition::PixelCounts& c = result.counts;
    std::printf(
        "%s: %zu frames, %llu pixel samples in %zu bins; coverage %.1f%% of %zu valid bins "
        "(reachable %zu)\n",
        run->dir.c_str(),
        result.frames.size(),
        static_cast<unsigned long long>(c.used),
        result.table.filled_bins(),
        100 * result.coverage.fraction(),
        result.coverage.valid_bins(),
        result.reachable_bins);
    std::printf(
        "excluded pixels: edge %llu, grazing view %llu, shadow %llu, grazing light %llu, "
        "saturated %llu\n",
        static_cast<unsigned long long>(c.edge),
        static_cast<unsigned long long>(c.grazing_view),
        static_cast<unsigned long long>(c.shadow),
        static_cast<unsigned long long>(c.grazing_light),
        static_cast<unsigned long long>(c.saturated));
    std::size_t hole_bins = 0;
    for (const auto& h : result.holes) {
        hole_bins += h.bins;
    }
    std::printf(
        "holes: %zu empty valid bins in %zu groups (dataset.json lists them); stopped: %s\n",
        hole_bins,
        result.holes.size(),
        result.stop_reason.c_str());
    std::printf(
        "captures: %llu through %s (%zu retried after a camera error); pose checks: %zu "
        "exposures repeated, %zu poses corrected\n",
        static_cast<unsigned long long>(result.captures),
        run->camera_address.c_str(),
        poses.capture_retries,
        poses.repeats,
        poses.corrections);
    if (!result.target_met) {
        std::fprintf(stderr,
                     "gonio acquire: coverage target %.1f%% not met (%.1f%%)\n",
                     100 * run->config.coverage_target,
                     100 * result.coverage.fraction());
        return 1;
    }
    return 0;
}

}  // namespace gonio::tools
