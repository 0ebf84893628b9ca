// gonio acquire: run or resume a measurement campaign. With no description it measures a default
// material on the embedded virtual rig; with campaign.json it uses the rig that description names
// (a real rig, or a `gonio sim` process).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "acquire_fit_check.h"
#include "acquire_image_mode.h"
#include "command.h"
#include "embedded_rig.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/point/progress.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/report/live_server.h"
#include "live_page.h"
#include "option_checks.h"

namespace {

namespace acq = gonio::acquisition;
namespace fs = std::filesystem;

struct AcquireOptions {
    acq::CampaignRequest request;
    std::string mode = "point";
    std::string grid;  ///< --grid as typed (HxDxP)
};

std::atomic<bool> g_stop{false};

extern "C" void on_sigint(int) {
    g_stop.store(true);
    // A second Ctrl-C ends the process at once.
    std::signal(SIGINT, SIG_DFL);
}

int fail(const std::string& msg) {
    std::fprintf(stderr, "gonio acquire: %s\n", msg.c_str());
    return 1;
}

/// The option as typed for a request field.
std::string flag_of(const std::string& field) {
    if (field == "campaign_file") {
        return "campaign.json (the positional description)";
    }
    if (field == "mode") {
        return "--mode";
    }
    if (field == "isotropic_plan") {
        return "an isotropic plan";
    }
    return "--" + acq::option_key(field);
}

/// A refused combination: exit status 2, both options named.
int refuse(const acq::CampaignRequest& r, const acq::RequestConflict& c) {
    std::string with = flag_of(c.with);
    if (c.with == "mode") {
        with = r.mode == acq::CampaignMode::kImage ? "--mode image" : "--mode point";
    }
    return gonio::tools::usage_error(
        "acquire", flag_of(c.option) + " cannot be combined with " + with + ": " + c.rule);
}

/// Polar and azimuth angles of a direction, degrees.
std::pair<double, double> angles_deg(const gonio::brdf::Vec3d& w) {
    constexpr double kDeg = 180.0 / 3.14159265358979323846;
    const double theta = std::acos(std::clamp(w.z(), -1.0, 1.0)) * kDeg;
    const double phi = std::atan2(w.y(), w.x()) * kDeg;
    return {theta, phi};
}

/// The plan as it would be measured: a summary line, then one CSV row per configuration (its
/// index in the pass and the target directions in degrees, sample frame), then one row per
/// target that no arm position reaches, with why.
int print_point_plan(const acq::CampaignRequest& r) {
    acq::CampaignSpec spec;
    auto plan = acq::plan_point_campaign(r, &spec);
    if (!plan) {
        return fail(plan.error().message);
    }
    std::printf(
        "# %s plan: %zu configurations, %zu unreachable, %llu outside the ROI, naive 4D grid "
        "%llu\n",
        plan->kind.c_str(),
        plan->configs.size(),
        plan->unreachable.size(),
        static_cast<unsigned long long>(plan->outside_roi),
        static_cast<unsigned long long>(plan->naive_count));
    if (plan->kind == "vndf-retro") {
        const acq::VndfSpec& v = spec.vndf;
        std::printf(
            "# pass 0 of the vndf plan: retro-reflection; pass 1 (the VNDF-warped domain) is "
            "placed from its measurements\n");
        std::printf("# dataset.bsdf: %s%d theta_i x %d x %d nodes, NDF on %d%s nodes\n",
                    v.phi_i_count >= 2
                        ? ("anisotropic, " + std::to_string(v.phi_i_count) + " phi_i x ").c_str()
                        : "isotropic, ",
                    v.theta_i_count,
                    v.resolution,
                    v.resolution,
                    v.ndf_resolution,
                    v.phi_i_count >= 2 ? (" x " + std::to_string(v.ndf_resolution)).c_str() : "");
    }
    std::printf("status,index,theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,weight,reason\n");
    for (const acq::PlannedConfig& c : plan->configs) {
        const auto [ti, pi] = angles_deg(c.wi);
        const auto [to, po] = angles_deg(c.wo);
        std::printf("planned,%u,%.4f,%.4f,%.4f,%.4f,%.6g,\n", c.index, ti, pi, to, po, c.weight);
    }
    for (const acq::UnreachableConfig& u : plan->unreachable) {
        const auto [ti, pi] = angles_deg(u.wi);
        const auto [to, po] = angles_deg(u.wo);
        std::printf("unreachable,,%.4f,%.4f,%.4f,%.4f,,\"%s\"\n", ti, pi, to, po, u.reason.c_str());
    }
    return 0;
}

/// "HxDxP" (theta_h x theta_d x phi_d bins) of --grid; false when malformed.
bool parse_grid(const std::string& text, acq::TableLayout* out) {
    int h = 0;
    int d = 0;
    int p = 0;
    char x1 = 0;
    char x2 = 0;
    char extra = 0;
    if (std::sscanf(text.c_str(), "%d%c%d%c%d%c", &h, &x1, &d, &x2, &p, &extra) != 5 || x1 != 'x' ||
        x2 != 'x' || h < 1 || d < 1 || p < 1) {
        return false;
    }
    *out = {h, d, p};
    return true;
}

/// The live page's hooks: the campaign thread only hands each sample and (at most four a second)
/// a small picture of the frame its exposure settled on over; the server draws on its own thread.
void attach_live_page(gonio::report::LiveServer* l, acq::RunHooks* hooks) {
    l->publish_progress(0, 0, "running");
    hooks->on_measurement = [l](const gonio::brdf::Sample& s, std::size_t done, std::size_t n) {
        l->publish_sample(s);
        l->publish_progress(done, n, "running");
    };
    using Clock = std::chrono::steady_clock;
    hooks->on_frame = [l, last = Clock::time_point()](const gonio::devices::Frame& f) mutable {
        const Clock::time_point now = Clock::now();
        if (now - last < std::chrono::milliseconds(250)) {
            return;
        }
        last = now;
        gonio::report::Image picture =
            gonio::tools::live_frame_picture(f, gonio::tools::kLiveFrameWidth);
        std::string caption = gonio::tools::live_frame_description(
            f, picture, "the detector camera (the measurement averages a centred square of it)");
        l->publish_frame(std::move(picture), std::move(caption));
    };
}

acq::RunHooks operator_hooks() {
    acq::RunHooks hooks;
    hooks.stop = &g_stop;
    hooks.out = stdout;
    hooks.mount = [](bool white) -> gonio::Expected<void> {
        std::printf(
            "%s, then press Enter: ",
            white ? "Mount the white reference in the sample holder" : "Mount the sample again");
        std::fflush(stdout);
        std::string line;
        if (!std::getline(std::cin, line)) {
            return gonio::make_error("no operator input (stdin closed)");
        }
        return {};
    };
    return hooks;
}

/// What to run next on a campaign folder: the fit of its dataset, then its report.
void print_next_commands(const std::string& dir) {
    const fs::path d(dir);
    std::error_code ec;
    const fs::path data = fs::exists(d / "dataset.csv", ec) || !fs::exists(d / "dataset.bsdf", ec)
                              ? d / "dataset.csv"
                              : d / "dataset.bsdf";
    std::printf("next: gonio fit %s --out %s\n      gonio report %s\n",
                data.string().c_str(),
                (d / "fit.json").string().c_str(),
                dir.c_str());
}

int campaign_status(const acq::RunResult& res, const std::string& dir) {
    switch (res.outcome) {
        case acq::Outcome::kCompleted:
            return 0;
        case acq::Outcome::kInterrupted:
            std::fprintf(stderr,
                         "gonio acquire: stopped on request; continue with: gonio acquire --resume "
                         "%s\n",
                         dir.c_str());
            return 1;
        case acq::Outcome::kPaused:
            std::fprintf(stderr,
                         "gonio acquire: paused: %s\ncontinue with: gonio acquire --resume %s\n",
                         res.message.c_str(),
                         dir.c_str());
            return 1;
    }
    return 1;
}

int run(const acq::CampaignRequest& r) {
    if (auto c = acq::find_conflict(r)) {
        return refuse(r, *c);
    }
    if (auto c = acq::find_rig_conflict(r)) {
        return gonio::tools::usage_error("acquire", flag_of(c->option) + " " + c->rule);
    }
    if (!r.until.empty()) {
        if (auto rule = acq::parse_stop_rule(r.until); !rule) {
            return gonio::tools::usage_error("acquire", "--until: " + rule.error().message);
        }
    }
    std::optional<std::pair<std::string, int>> serve_at;
    if (!r.serve.empty()) {
        auto a = gonio::report::parse_listen_address(r.serve);
        if (!a) {
            return gonio::tools::usage_error("acquire", a.error().message);
        }
        serve_at = *a;
    }
    if (r.mode == acq::CampaignMode::kImage) {
        // Before any work: work whose memory estimate is above the budget is refused, and no
        // campaign folder is made.
        if (auto m = acq::check_image_request_memory(r); !m) {
            return gonio::tools::usage_error("acquire", m.error().message);
        }
        if (r.plan_only) {
            return gonio::tools::print_image_plan(r);
        }
        return gonio::tools::run_acquire_image_mode(
            r, serve_at ? serve_at->first : std::string(), serve_at ? serve_at->second : -1);
    }
    if (r.plan_only) {
        return print_point_plan(r);
    }
    // The live page's address is bound before the campaign starts: one that cannot be served
    // stops the command before its folder exists.
    std::unique_ptr<gonio::report::LiveServer> live;
    if (serve_at) {
        auto srv = gonio::tools::start_live_page(serve_at->first, serve_at->second, "campaign");
        if (!srv) {
            return fail(srv.error().message);
        }
        live = std::move(*srv);
    }
    auto campaign = acq::start_point_campaign(r, gonio::tools::embedded_rig_starter(), stdout);
    if (!campaign) {
        return fail(campaign.error().message);
    }
    const std::string dir = (*campaign)->dir;
    acq::RunHooks hooks = operator_hooks();
    hooks.accept_drift = r.accept_drift;
    hooks.fit_check = gonio::tools::default_fit_check();
    hooks.plan_fit = gonio::tools::default_plan_fit();
    if (live) {
        live->set_title("gonio campaign " + fs::path(dir).filename().string());
        attach_live_page(live.get(), &hooks);
    }
    std::signal(SIGINT, on_sigint);
    auto res = acq::run_campaign(dir, (*campaign)->devices, hooks);
    std::signal(SIGINT, SIG_DFL);
    if (!res) {
        gonio::tools::keep_live_page(live.get(), dir, "failed: " + res.error().message);
        return fail(res.error().message);
    }
    std::printf(
        "%s\ndataset: %s\nrig time: %s (motion %.1f s, settle %.1f s, exposure %.1f s, "
        "readout %.1f s; the campaign so far %s); stopped: %s\n",
        res->message.c_str(),
        (fs::path(dir) / "dataset.csv").string().c_str(),
        acq::format_duration(res->rig_time.total_s()).c_str(),
        res->rig_time.motion_s,
        res->rig_time.settle_s,
        res->rig_time.exposure_s,
        res->rig_time.readout_s,
        acq::format_duration(res->campaign_rig_time_s).c_str(),
        res->stopped.c_str());
    if (res->outcome == acq::Outcome::kCompleted) {
        print_next_commands(dir);
    }
    std::fflush(stdout);
    const int status = campaign_status(*res, dir);
    // A campaign stopped with Ctrl-C ends the command; any other end keeps its page up.
    if (res->outcome != acq::Outcome::kInterrupted) {
        const char* state = res->outcome == acq::Outcome::kCompleted ? "completed" : "paused";
        gonio::tools::keep_live_page(live.get(), dir, state);
    }
    return status;
}

/// The campaign's description, folder and sample (and the virtual rig's truth).
void add_campaign_options(CLI::App* cmd, acq::CampaignRequest& r) {
    cmd->add_option("campaign", r.campaign_file, "campaign description (campaign.json)")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--rig",
                    r.rig_path,
                    "rig description (default: the campaign's, else data/rigs/sim4.json)")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--out", r.out_dir, "campaign folder (default: campaigns/<time>_<sample>)");
    cmd->add_option("--campaigns-dir",
                    r.campaigns_dir,
                    "parent of automatically named folders (default: campaigns; image mode: the "
                    "current folder)");
    cmd->add_option("--resume", r.resume_dir, "continue the campaign in this folder")
        ->check(gonio::tools::readable_input(gonio::tools::InputKind::kFolder));
    cmd->add_option("--material", r.material, "virtual rig: named material (data/materials)");
    cmd->add_option("--brdf", r.brdf_path, "virtual rig: ground-truth model JSON or table")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--scene", r.scene, "measure only the region of interest of this scene")
        ->check(gonio::tools::readable_input());
    cmd->add_option("--sample", r.sample, "sample name");
    cmd->add_option("--operator", r.operator_name, "operator name");
}

/// The point-mode plan and its settings.
void add_plan_options(CLI::App* cmd, acq::CampaignRequest& r) {
    cmd->add_option("--plan",
                    r.plan_kind,
                    "uniform, half-diff, vndf (retro-reflection, then the VNDF-warped domain; "
                    "writes dataset.bsdf) or fit (a space-filling batch, then each batch chosen "
                    "from the fit of the values so far: where its prediction is least certain "
                    "or it misfits, per second of rig time; with --anisotropic over every "
                    "azimuth)")
        ->check(CLI::IsMember({"uniform", "half-diff", "vndf", "fit"}));
    cmd->add_option("--n-theta", r.n_theta, "uniform plan: polar angles")
        ->check(gonio::tools::integer_in(2, acq::kMaxPlanAxis));
    cmd->add_option("--n-dphi", r.n_dphi, "uniform plan: azimuth differences")
        ->check(gonio::tools::integer_in(2, acq::kMaxPlanAxis));
    cmd->add_option("--adaptive", r.adaptive, "adaptive refinement passes (0 = none)")
        ->check(gonio::tools::integer_in(0, 100));
    cmd->add_flag("--anisotropic",
                  r.anisotropic,
                  "for samples whose BRDF depends on the azimuth: point mode plans over "
                  "(theta_i, phi_i, theta_o, phi_o) with the spin axis (with --plan vndf: the "
                  "NDF over every azimuth and an anisotropic dataset.bsdf with 8 incident "
                  "azimuths); image mode measures a turned sphere at several spins into a 4-D "
                  "table");
    cmd->add_option("--symmetry",
                    r.symmetry,
                    "anisotropic plan: the sample's symmetry about its normal (none, mirror "
                    "across its x axis, 2-fold as brushed metal)")
        ->check(CLI::IsMember({"none", "mirror", "2-fold"}));
    cmd->add_option("--vndf-theta-i",
                    r.vndf_theta_i,
                    "vndf plan: incident elevations of its RGL file (default 8)")
        ->check(gonio::tools::integer_in(2, 64));
    cmd->add_option("--vndf-resolution",
                    r.vndf_resolution,
                    "vndf plan: nodes per axis of the VNDF-warped square (default 16)")
        ->check(gonio::tools::integer_in(4, 128));
    cmd->add_option("--vndf-phi-i",
                    r.vndf_phi_i,
                    "anisotropic vndf plan: incident azimuths of its RGL file (default 8)")
        ->check(gonio::tools::integer_in(2, 64));
}

/// The virtual rig's time scale and the resume's drift rule.
void add_rig_options(CLI::App* cmd, acq::CampaignRequest& r) {
    cmd->add_option("--time-scale", r.time_scale, "virtual rig: motion time scale")
        ->check(gonio::tools::finite_in(0.001, 1e6));
    cmd->add_flag("--accept-drift",
                  r.accept_drift,
                  "resume: take the lamp's current level as the new baseline");
}

/// The mode and image mode's settings.
void add_image_options(CLI::App* cmd, AcquireOptions& o) {
    acq::CampaignRequest& r = o.request;
    cmd->add_option(
           "--mode", o.mode, "point (one configuration per frame) or image (curved sample)")
        ->check(CLI::IsMember({"point", "image"}));
    cmd->add_option(
           "--coverage-target", r.coverage_target, "image mode: fraction of valid table bins")
        ->check(gonio::tools::finite_in(0.001, 1));
    cmd->add_option(
        "--grid", o.grid, "image mode: table bins N_THETA_HxN_THETA_DxN_PHI_D (90x90x180 = MERL)");
    cmd->add_option("--max-frames", r.max_frames, "image mode: most light positions")
        ->check(gonio::tools::integer_in(1, 1000000));
    cmd->add_option("--camera-px",
                    r.camera_px,
                    "image mode, virtual rig: size of its camera, px (default 256; not with a "
                    "calibrated camera_model)")
        ->check(gonio::tools::integer_in(16, 2048));
    cmd->add_option("--max-theta-deg",
                    r.max_theta_deg,
                    "image mode: grazing limit of the pixels' theta_i and theta_o, deg (default "
                    "80; at most the rig's geometry.max_theta_deg)")
        ->check(gonio::tools::finite_in(1, 89.9));
    cmd->add_flag("--no-zoom",
                  r.no_zoom,
                  "image mode: every frame in the wide view, none through the rig's zoomed "
                  "camera placements");
}

/// What the run does besides measuring: print the plan only, stop by a rule, fly, serve a page.
void add_run_options(CLI::App* cmd, acq::CampaignRequest& r) {
    cmd->add_flag(
        "--plan-only",
        r.plan_only,
        "print the plan (and unreachable targets; image mode: the predicted coverage) and exit");
    cmd->add_option("--until",
                    r.until,
                    "point mode: fit between batches and stop when every fitted parameter's "
                    "relative sigma <= TARGET and the held-out values are predicted within the "
                    "noise (sigma=0.01[,holdout=2][,every=N]; kept by --resume)");
    cmd->add_flag(
        "--fly",
        r.fly,
        "point mode: fly scans: the arms measure while moving, one arm sweeping at "
        "constant speed through each run of configurations it reaches alone, each value "
        "the mean over its exposure's path, triggered by the drives' position compare (kept by "
        "--resume; not with image mode or a colour filter changer whose arms trigger by "
        "polling)");
    cmd->add_option("--fly-smear",
                    r.fly_smear_deg,
                    "fly scans: the largest arc one exposure may span, degrees (default 1); the "
                    "sweep's speed is bounded by it")
        ->check(CLI::Range(1e-3, 10.0));
    cmd->add_option("--serve",
                    r.serve,
                    "serve a live page of the campaign at [ADDR:]PORT (ADDR default 127.0.0.1, "
                    "PORT 0 = any free port; the URL is printed)");
}

}  // namespace

GONIO_COMMAND(acquire) {
    auto* cmd = app.add_subcommand("acquire",
                                   "run a measurement campaign (no arguments: a default material "
                                   "on the embedded virtual rig)");
    auto o = std::make_shared<AcquireOptions>();
    acq::CampaignRequest& r = o->request;
    add_campaign_options(cmd, r);
    add_plan_options(cmd, r);
    add_rig_options(cmd, r);
    add_image_options(cmd, *o);
    add_run_options(cmd, r);
    return [o]() {
        acq::CampaignRequest& req = o->request;
        // A resume of an image campaign is recognised by its folder (its settings file).
        const bool image_folder = acq::is_image_campaign_dir(req.resume_dir);
        req.mode = o->mode == "image" || image_folder ? acq::CampaignMode::kImage
                                                      : acq::CampaignMode::kPoint;
        if (!o->grid.empty() && !parse_grid(o->grid, &req.grid)) {
            return gonio::tools::usage_error("acquire",
                                             "--grid \"" + o->grid +
                                                 "\": expected N_THETA_HxN_THETA_DxN_PHI_D, e.g. "
                                                 "90x90x180");
        }
        return run(req);
    };
}
