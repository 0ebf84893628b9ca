#include "acquire_image_mode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "embedded_rig.h"
#include "gonio/acquisition/image/image_planner.h"
#include "gonio/acquisition/shared/frame_picture.h"
#include "gonio/base/limits.h"
#include "gonio/brdf/coords.h"
#include "gonio/report/live_server.h"
#include "live_page.h"

namespace gonio::tools {

report::Image live_frame_picture(const devices::Frame& frame, int max_width) {
    const acquisition::FramePicture p = acquisition::frame_picture(frame, max_width);
    report::Image out;
    out.width = p.width;
    out.height = p.height;
    out.rgb.resize(p.grey.size() * 3);
    for (std::size_t i = 0; i < p.grey.size(); ++i) {
        out.rgb[3 * i] = out.rgb[3 * i + 1] = out.rgb[3 * i + 2] = p.grey[i];
    }
    return out;
}

std::string live_frame_description(const devices::Frame& frame,
                                   const report::Image& picture,
                                   const std::string& what) {
    return acquisition::frame_picture_caption(frame, picture.width, picture.height, what);
}

namespace {

/// The coverage per (theta_h, theta_d) cell (acquisition::coverage_cells) in the live page's
/// order (theta_h-major).
report::CoverageCells live_coverage_cells(const acquisition::CoverageMap& c) {
    const acquisition::TableLayout& lay = c.layout();
    const std::vector<double> rows = acquisition::coverage_cells(c);
    report::CoverageCells cells;
    cells.n_theta_h = lay.n_theta_h;
    cells.n_theta_d = lay.n_theta_d;
    cells.n_phi_d = lay.n_phi_d;
    cells.fraction.resize(rows.size());
    for (int ih = 0; ih < lay.n_theta_h; ++ih) {
        for (int id = 0; id < lay.n_theta_d; ++id) {
            cells.fraction[static_cast<std::size_t>(ih) * lay.n_theta_d + id] =
                rows[static_cast<std::size_t>(id) * lay.n_theta_h + ih];
        }
    }
    cells.measured_bins = c.covered_bins();
    cells.total_bins = c.valid_bins();
    cells.total_is_valid_bins = true;
    return cells;
}

void print_summary(const acquisition::ImageCampaignRun& run) {
    const acquisition::ImageCampaignResult& result = *run.result;
    const acquisition::PixelCounts& c = result.counts;
    if (result.resumed_frames > 0) {
        std::printf(
            "resumed: %zu frames read back from %s\n", result.resumed_frames, run.journal.c_str());
    }
    std::printf(
        "%s: %zu frames, %llu pixel samples in %zu bins; coverage %.1f%% of %zu valid bins "
        "(reachable %zu)\n",
        run.dir.c_str(),
        result.frames.size(),
        static_cast<unsigned long long>(c.used),
        result.filled_bins(),
        100 * result.coverage_fraction(),
        result.valid_bins(),
        result.reachable_bins);
    std::printf(
        "excluded pixels: edge %llu, grazing view %llu, shadow %llu, grazing light %llu, "
        "saturated %llu\n",
        static_cast<unsigned long long>(c.edge),
        static_cast<unsigned long long>(c.grazing_view),
        static_cast<unsigned long long>(c.shadow),
        static_cast<unsigned long long>(c.grazing_light),
        static_cast<unsigned long long>(c.saturated));
    const std::size_t zoomed = static_cast<std::size_t>(
        std::count_if(result.frames.begin(), result.frames.end(), [](const auto& f) {
            return f.placement != 0;
        }));
    if (!run.config.placements.empty()) {
        std::printf("zoomed frames: %zu of %zu (through %zu zoomed camera placements)\n",
                    zoomed,
                    result.frames.size(),
                    run.config.placements.size());
    }
    if (result.aniso_table) {
        std::printf("anisotropic: %s table in the material frame, %llu pixels in the pole caps\n",
                    result.aniso_table->layout().describe().c_str(),
                    static_cast<unsigned long long>(c.pole));
    }
    std::size_t hole_bins = 0;
    for (const auto& h : result.holes) {
        hole_bins += h.bins;
    }
    std::printf(
        "holes: %zu empty valid %sbins in %zu groups (dataset.json lists them); stopped: %s\n",
        hole_bins,
        result.aniso_table ? "half/difference " : "",
        result.holes.size(),
        result.stop_reason.c_str());
    // Empty valid bins by reason, in the order coverage_holes() tells them apart.
    std::vector<std::pair<std::string, std::size_t>> by_reason;
    for (const auto& h : result.holes) {
        auto it = std::find_if(
            by_reason.begin(), by_reason.end(), [&](const auto& p) { return p.first == h.reason; });
        if (it == by_reason.end()) {
            by_reason.emplace_back(h.reason, h.bins);
        } else {
            it->second += h.bins;
        }
    }
    std::string line;
    for (const auto& [reason, bins] : by_reason) {
        char pct[32];
        std::snprintf(
            pct,
            sizeof pct,
            "%.1f%%",
            100.0 * static_cast<double>(bins) /
                static_cast<double>(std::max<std::size_t>(1, result.coverage.valid_bins())));
        line += (line.empty() ? "" : ", ") + reason + " " + std::to_string(bins) + " (" + pct + ")";
    }
    if (!line.empty()) {
        std::printf("empty valid bins by reason: %s\n", line.c_str());
    }
    std::printf(
        "captures: %llu through %s (%zu retried after a camera error); pose checks: %zu "
        "exposures repeated, %zu poses corrected\n",
        static_cast<unsigned long long>(result.captures),
        run.camera_address.c_str(),
        run.poses.capture_retries,
        run.poses.repeats,
        run.poses.corrections);
}

/// The memory estimates of the plan and of the campaign it plans, against the budget.
void print_memory_estimate(const acquisition::CampaignRequest& request) {
    acquisition::CampaignRequest run = request;
    run.plan_only = false;
    auto plan = acquisition::estimate_image_request_memory(request);
    auto campaign = acquisition::estimate_image_request_memory(run);
    if (!plan || !campaign) {
        return;
    }
    std::printf("memory estimate: plan %s, campaign %s (%s); budget %s (--max-memory)\n",
                human_bytes(plan->total()).c_str(),
                human_bytes(campaign->total()).c_str(),
                campaign->describe().c_str(),
                human_bytes(static_cast<double>(max_memory_bytes())).c_str());
}

/// The plan's table, lights, camera and limits (and the spins of an anisotropic plan).
void print_plan_settings(const acquisition::ImagePlan& planned) {
    const acquisition::ImagePlan* plan = &planned;
    const acquisition::ImageCampaignConfig& c = plan->config;
    std::printf(
        "image mode plan on %s: %s table, coverage target %.0f%%, at most %d light "
        "positions in [%.1f, %.1f] deg, detector arm %.1f deg\n",
        plan->embedded ? "the embedded virtual rig" : plan->rig_name.c_str(),
        c.anisotropic
            ? c.aniso_layout.describe().c_str()
            : (std::to_string(c.layout.n_theta_h) + "x" + std::to_string(c.layout.n_theta_d) + "x" +
               std::to_string(c.layout.n_phi_d))
                  .c_str(),
        100 * c.coverage_target,
        c.max_frames,
        c.lights.min_rad * 180 / brdf::kPi,
        c.lights.max_rad * 180 / brdf::kPi,
        c.detector_arm_rad * 180 / brdf::kPi);
    std::printf(
        "camera %dx%d (%s), grazing limits theta_i %.1f deg, theta_o %.1f deg, light "
        "positions %.2f deg apart, blind zone %.1f deg\n",
        c.camera.intrinsics.width,
        c.camera.intrinsics.height,
        acquisition::to_string(c.camera.projection),
        c.rules.max_theta_i * 180 / brdf::kPi,
        c.rules.max_theta_o * 180 / brdf::kPi,
        c.lights.step_rad * 180 / brdf::kPi,
        c.lights.blind_zone_rad * 180 / brdf::kPi);
    if (c.anisotropic) {
        std::printf(
            "anisotropic: turned sphere, %s table in the material frame, spin in [%.1f, %.1f] "
            "deg every %.2f deg, pole caps %.1f deg\n",
            c.aniso_layout.describe().c_str(),
            c.spins.min_rad * 180 / brdf::kPi,
            c.spins.max_rad * 180 / brdf::kPi,
            c.spins.step_rad * 180 / brdf::kPi,
            c.pole_rad * 180 / brdf::kPi);
    }
}

/// The predicted frames, travel and coverage.
void print_predicted_coverage(const acquisition::ImageCampaignConfig& c,
                              const acquisition::ImageCoveragePrediction* p) {
    const double valid = static_cast<double>(std::max<std::size_t>(p->valid_bins, 1));
    char spin_buf[64] = "";
    if (c.anisotropic) {
        std::snprintf(
            spin_buf, sizeof spin_buf, ", %.1f deg of spin", p->spin_travel_rad * 180 / brdf::kPi);
    }
    const std::string spin_note = spin_buf;
    std::printf(
        "predicted from the nominal sphere (%zu pixels within the limits, %zu candidate "
        "%s): %zu %s (%.1f deg of light-arm travel%s), coverage %.1f%% of %zu valid bins; "
        "reachable %.1f%% (%s)\n",
        p->sphere_pixels,
        p->candidates,
        c.anisotropic ? "poses" : "light positions",
        p->light_arm_rad.size(),
        c.anisotropic ? "poses" : "light positions",
        p->light_travel_rad * 180 / brdf::kPi,
        spin_note.c_str(),
        100.0 * static_cast<double>(p->covered_bins) / valid,
        p->valid_bins,
        100.0 * static_cast<double>(p->reachable_bins) / valid,
        p->stop_reason.c_str());
}

/// The zoomed camera placements and how many frames use them.
void print_zoomed_placements(const acquisition::ImageCampaignConfig& c,
                             const acquisition::ImageCoveragePrediction* p) {
    if (!c.placements.empty()) {
        std::string names;
        for (const acquisition::Placement& z : c.placements) {
            char one[120];
            std::snprintf(one,
                          sizeof one,
                          "%s%s x%.3g at (%.2f, %.2f) mm",
                          names.empty() ? "" : ", ",
                          z.name.c_str(),
                          z.magnification,
                          z.offset_m[0] * 1e3,
                          z.offset_m[1] * 1e3);
            names += one;
        }
        std::printf(
            "zoomed camera placements: %s; %zu of the %zu candidates zoomed, %zu of the %zu "
            "planned light positions zoomed\n",
            names.c_str(),
            p->candidates_zoomed,
            p->candidates,
            p->zoomed_frames,
            p->light_arm_rad.size());
    }
}

/// The valid bins the prediction leaves empty, by reason.
void print_coverage_holes(const acquisition::ImageCampaignConfig& c,
                          const acquisition::ImageCoveragePrediction* p) {
    const double valid = static_cast<double>(std::max<std::size_t>(p->valid_bins, 1));
    std::map<std::string, std::size_t> by_reason;
    for (const acquisition::CoverageHole& h : p->holes) {
        by_reason[h.reason] += h.bins;
    }
    // An anisotropic plan's holes are half/difference bins none of whose phi_h bins is covered.
    const double hole_of =
        c.anisotropic ? static_cast<double>(std::max<std::size_t>(
                            acquisition::CoverageMap(c.aniso_layout.iso()).valid_bins(), 1))
                      : valid;
    for (const auto& [reason, n] : by_reason) {
        std::printf("  empty valid %sbins, %s: %zu (%.1f%%)\n",
                    c.anisotropic ? "half/difference " : "",
                    reason.c_str(),
                    n,
                    100.0 * static_cast<double>(n) / hole_of);
    }
}

/// The live page of an image campaign and what its progress is measured against.
struct ImageLivePage {
    std::unique_ptr<report::LiveServer> live;
    std::string dir;
    std::size_t max_frames = 0;
    double target = 0;
};

/// The campaign has started: the live page served (before anything is written, so that an
/// address that cannot be served leaves no folder behind) and the campaign announced.
Expected<void> announce_image_run(const acquisition::ImageCampaignRun& run,
                                  const std::string& serve_host,
                                  int serve_port,
                                  ImageLivePage* page) {
    page->max_frames = static_cast<std::size_t>(std::max(run.config.max_frames, 0));
    page->target = run.config.coverage_target;
    if (serve_port >= 0) {
        auto srv =
            start_live_page(serve_host,
                            serve_port,
                            "image campaign " + std::filesystem::path(run.dir).filename().string(),
                            "no camera frame yet (the first comes with the white reference)");
        if (!srv) {
            return tl::unexpected(srv.error());
        }
        page->live = std::move(*srv);
        page->dir = run.dir;
    }
    std::printf(
        "image mode: %s sphere on %s (motors %s, camera %s), %dx%dx%d table, target %.0f%%\n",
        run.sample.c_str(),
        run.embedded ? "the virtual rig" : run.rig_name.c_str(),
        run.motor_address.c_str(),
        run.camera_address.c_str(),
        run.config.layout.n_theta_h,
        run.config.layout.n_theta_d,
        run.config.layout.n_phi_d,
        100 * run.config.coverage_target);
    if (page->live) {
        page->live->publish_image_progress(0, page->max_frames, 0, page->target, "running");
    }
    std::fflush(stdout);
    return {};
}

/// One frame's line: its light (and spin or zoomed placement), samples and coverage.
void print_frame_progress(bool aniso, std::size_t i, const acquisition::FrameRecord& r) {
    char spin[40] = "";
    if (aniso) {
        std::snprintf(spin, sizeof spin, ", spin %.1f deg", r.spin_rad * 180 / brdf::kPi);
    } else if (r.placement > 0) {
        std::snprintf(spin, sizeof spin, ", zoomed placement %d", r.placement);
    }
    std::printf("frame %zu: light %.1f deg%s, %llu samples, coverage %.1f%%\n",
                i + 1,
                r.light_arm_rad * 180 / brdf::kPi,
                spin,
                static_cast<unsigned long long>(r.counts.used),
                100 * r.coverage_after);
    std::fflush(stdout);
}

/// The capture with a small picture of a frame (at most four a second) handed to the live page.
acquisition::CaptureFn with_live_frames(acquisition::CaptureFn inner, report::LiveServer* l) {
    if (l == nullptr) {
        return inner;
    }
    using Clock = std::chrono::steady_clock;
    return [inner = std::move(inner), l, last = Clock::time_point()](
               const acquisition::CaptureRequest& q) mutable -> Expected<devices::Frame> {
        auto f = inner(q);
        const Clock::time_point now = Clock::now();
        if (f && q.shutter_open && now - last >= std::chrono::milliseconds(250)) {
            last = now;
            static const char* const kFilters[] = {"red", "green", "blue"};
            char what[160];
            std::snprintf(what,
                          sizeof what,
                          "%s, light arm at %.1f deg, %s filter",
                          q.reference ? "white reference sphere" : "sample sphere",
                          q.light_arm_rad * 180 / brdf::kPi,
                          kFilters[std::clamp(q.channel, 0, 2)]);
            report::Image picture = live_frame_picture(*f, kLiveFrameWidth);
            std::string caption = live_frame_description(*f, picture, what);
            l->publish_frame(std::move(picture), std::move(caption));
        }
        return f;
    };
}

/// The run's summary and next commands, or its error; the exit status.
int report_image_run(const Expected<acquisition::ImageCampaignRun>& run) {
    int status = 0;
    if (!run) {
        std::fprintf(stderr, "gonio acquire: %s\n", run.error().message.c_str());
        status = 1;
    } else {
        print_summary(*run);
        std::printf("next: gonio fit %s/dataset.csv --out %s/fit.json\n      gonio report %s\n",
                    run->dir.c_str(),
                    run->dir.c_str(),
                    run->dir.c_str());
        std::fflush(stdout);
        if (!run->result->target_met) {
            std::fprintf(stderr,
                         "gonio acquire: coverage target %.1f%% not met (%.1f%%)\n",
                         100 * run->config.coverage_target,
                         100 * run->result->coverage_fraction());
            status = 1;
        }
    }
    return status;
}

}  // namespace

int run_acquire_image_mode(const acquisition::CampaignRequest& request,
                           const std::string& serve_host,
                           int serve_port) {
    ImageLivePage page;
    acquisition::ImageRunHooks hooks;
    hooks.started = [&](const acquisition::ImageCampaignRun& run) {
        return announce_image_run(run, serve_host, serve_port, &page);
    };
    const bool aniso = request.anisotropic;
    hooks.progress = [aniso](std::size_t i, const acquisition::FrameRecord& r) {
        print_frame_progress(aniso, i, r);
    };
    // The campaign thread hands the live page a small picture of a frame and the coverage per
    // (theta_h, theta_d) cell; the server draws them on its own thread.
    hooks.wrap_capture = [&page](acquisition::CaptureFn inner) {
        return with_live_frames(std::move(inner), page.live.get());
    };
    hooks.state = [&](const acquisition::ImageCampaignResult& so_far) {
        if (page.live) {
            page.live->publish_coverage(live_coverage_cells(so_far.coverage));
            page.live->publish_image_progress(so_far.frames.size(),
                                              page.max_frames,
                                              so_far.coverage_fraction(),
                                              page.target,
                                              "running");
        }
    };
    auto run = acquisition::run_image_request(request, embedded_rig_starter(), hooks);
    const acquisition::ImageCampaignResult* r = run ? &*run->result : nullptr;
    const std::string state = r == nullptr ? "failed: " + run.error().message
                              : r->target_met
                                  ? "completed"
                                  : "ended without reaching the target (" + r->stop_reason + ")";
    if (page.live) {
        page.live->publish_image_progress(r ? r->frames.size() : 0,
                                          page.max_frames,
                                          r ? r->coverage_fraction() : 0,
                                          page.target,
                                          state);
    }
    const int status = report_image_run(run);
    keep_live_page(page.live.get(), page.dir, state);
    return status;
}

int print_image_plan(const acquisition::CampaignRequest& request) {
    auto plan = acquisition::plan_image_campaign(request);
    if (!plan) {
        std::fprintf(stderr, "gonio acquire: %s\n", plan.error().message.c_str());
        return 1;
    }
    const acquisition::ImageCampaignConfig& c = plan->config;
    print_plan_settings(*plan);
    print_memory_estimate(request);
    std::fflush(stdout);
    auto p = acquisition::predict_image_coverage(c);
    if (!p) {
        std::fprintf(stderr, "gonio acquire: %s\n", p.error().message.c_str());
        return 1;
    }
    print_predicted_coverage(c, &*p);
    print_zoomed_placements(c, &*p);
    print_coverage_holes(c, &*p);
    return 0;
}

}  // namespace gonio::tools
