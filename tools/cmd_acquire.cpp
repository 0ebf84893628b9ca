// gonio acquire: run or resume a measurement campaign. With no description it measures a default
// material on the embedded virtual rig; with campaign.json it uses the rig that description names
// (a real rig, or a `gonio sim` process).

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>

#include "acquire_image_mode.h"
#include "command.h"
#include "gonio/acquisition/campaign.h"
#include "gonio/acquisition/rig_config.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/data_path.h"
#include "gonio/base/limits.h"
#include "gonio/report/live_server.h"
#include "gonio/sim/sim_rig.h"
#include "option_checks.h"

namespace {

namespace acq = gonio::acquisition;
namespace fs = std::filesystem;

struct AcquireOptions {
    std::string campaign;
    std::string rig;
    std::string out;
    std::string resume;
    std::string campaigns_dir = "campaigns";
    std::string material;
    std::string brdf;
    std::string scene;
    std::string sample;
    std::string operator_name;
    std::string plan;
    int n_theta = 0;
    int n_dphi = 0;
    int adaptive = -1;
    double time_scale = 0;
    bool accept_drift = false;
    bool plan_only = false;
    std::string mode = "point";
    double coverage_target = 0;
    int max_frames = 0;
    std::string grid;
    std::string serve;  ///< "[ADDR:]PORT" of the live page; empty = none
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

/// The rig description marks campaigns that ran on the embedded virtual rig, so a resume restarts
/// it.
bool is_embedded(const std::string& rig_json) {
    const nlohmann::json j = nlohmann::json::parse(rig_json, nullptr, false);
    return !j.is_discarded() && j.value("embedded_virtual_rig", false);
}

/// "ground_truth.json" for a model file, "ground_truth.gtab" for a table; empty for a library
/// material ("material:NAME"), which is no file.
std::string ground_truth_name(const std::string& brdf) {
    if (brdf.rfind("material:", 0) == 0) {
        return {};
    }
    return "ground_truth" + fs::path(brdf).extension().string();
}

/// "HxDxP" (theta_h x theta_d x phi_d bins) of --grid; false when malformed.
bool parse_grid(const std::string& text, gonio::acquisition::TableLayout* out) {
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

/// Image mode: a curved sample, thousands of samples per frame (docs/image-acquisition.md).
int run_image(const AcquireOptions& o) {
    gonio::tools::AcquireImageOptions io;
    io.resume_dir = o.resume;
    if (!o.resume.empty()) {
        // A resume continues with the settings stored in the folder.
        const std::pair<bool, const char*> given[] = {{!o.grid.empty(), "--grid"},
                                                      {o.coverage_target > 0, "--coverage-target"},
                                                      {o.max_frames > 0, "--max-frames"},
                                                      {!o.material.empty(), "--material"},
                                                      {!o.brdf.empty(), "--brdf"},
                                                      {!o.rig.empty(), "--rig"},
                                                      {!o.out.empty(), "--out"},
                                                      {o.time_scale > 0, "--time-scale"}};
        for (const auto& [set, name] : given) {
            if (set) {
                std::fprintf(stderr,
                             "gonio acquire: %s with --resume: an image campaign continues with "
                             "the settings in %s/image_campaign.json\n",
                             name,
                             o.resume.c_str());
                return 2;
            }
        }
    }
    if (!o.grid.empty() && !parse_grid(o.grid, &io.grid)) {
        std::fprintf(stderr,
                     "gonio acquire: --grid \"%s\": expected N_THETA_HxN_THETA_DxN_PHI_D, e.g. "
                     "90x90x180\n",
                     o.grid.c_str());
        return 2;
    }
    io.out_dir = o.out;
    if (!o.material.empty()) {
        io.material = o.material;
    }
    io.brdf_path = o.brdf;
    io.rig_path = o.rig;
    if (o.coverage_target > 0) {
        io.coverage_target = o.coverage_target;
    }
    if (o.max_frames > 0) {
        io.max_frames = o.max_frames;
    }
    io.time_scale = o.time_scale;
    return gonio::tools::run_acquire_image_mode(io);
}

int run(const AcquireOptions& o) {
    std::error_code image_ec;
    const bool image =
        o.mode == "image" ||
        (!o.resume.empty() && fs::exists(fs::path(o.resume) / "image_campaign.json", image_ec));
    std::optional<std::pair<std::string, int>> serve_at;
    if (!o.serve.empty()) {
        if (image) {
            std::fprintf(stderr,
                         "gonio acquire: --serve: the live page follows point-mode campaigns; "
                         "image mode is not served\n");
            return 2;
        }
        if (o.plan_only) {
            std::fprintf(stderr, "gonio acquire: --serve with --plan-only: nothing to watch\n");
            return 2;
        }
        auto a = gonio::report::parse_listen_address(o.serve);
        if (!a) {
            std::fprintf(stderr, "gonio acquire: %s\n", a.error().message.c_str());
            return 2;
        }
        serve_at = *a;
    }
    if (image) {
        return run_image(o);
    }
    if (!o.grid.empty()) {
        std::fprintf(stderr,
                     "gonio acquire: --grid: image mode only (point mode: --plan, --n-theta, "
                     "--n-dphi)\n");
        return 2;
    }
    std::string dir;
    acq::RigConfig rig;
    std::unique_ptr<gonio::sim::SimRig> sim;
    bool embedded = false;
    // The virtual rig takes its ground truth and time scale from the stored rig description.
    gonio::sim::SimRigOptions so;
    // A new campaign's folder is created only once everything is checked: description, plan,
    // scene, rig, ground truth and devices reachable. Until then nothing is written.
    acq::CampaignSpec new_spec;
    std::string ground_truth_copy;
    if (!o.resume.empty()) {
        dir = o.resume;
        auto r = acq::read_rig_config((fs::path(dir) / "rig.json").string());
        if (!r) {
            return fail(r.error().message);
        }
        rig = *r;
        embedded = is_embedded(rig.json);
        if (embedded) {
            // The virtual rig's ground truth, when a file, is read from the campaign folder only.
            const nlohmann::json j = nlohmann::json::parse(rig.json, nullptr, false);
            const std::string b = j.is_object() && j.contains("sim") && j["sim"].is_object()
                                      ? j["sim"].value("brdf", std::string())
                                      : std::string();
            if (!b.empty() && b.rfind("material:", 0) != 0) {
                const fs::path bp(b);
                bool outside = bp.is_absolute();
                for (const auto& part : bp) {
                    outside = outside || part == "..";
                }
                if (outside) {
                    return fail(dir + "/rig.json: sim.brdf = \"" + b +
                                "\" lies outside the campaign folder; a resume reads only the "
                                "folder (copy the file into it and name it relative to it)");
                }
                so.brdf_path = (fs::path(dir) / bp).string();
            }
        }
    } else {
        acq::CampaignSpec spec;
        if (!o.campaign.empty()) {
            auto s = acq::read_campaign_spec(o.campaign);
            if (!s) {
                return fail(s.error().message);
            }
            spec = *s;
            const fs::path base = fs::path(o.campaign).parent_path();
            if (!spec.rig.empty() && fs::path(spec.rig).is_relative()) {
                spec.rig = (base / spec.rig).string();
            }
            if (!spec.scene.empty() && fs::path(spec.scene).is_relative()) {
                spec.scene = (base / spec.scene).string();
            }
        } else {
            embedded = true;
            spec = acq::default_campaign_spec(!o.brdf.empty() ? fs::path(o.brdf).stem().string()
                                              : !o.material.empty() ? o.material
                                                                    : "red-plastic");
        }
        if (!o.rig.empty()) {
            spec.rig = o.rig;
        }
        if (spec.rig.empty()) {
            auto p = gonio::find_data_file("rigs/sim4.json");
            if (!p) {
                return fail(p.error().message);
            }
            spec.rig = *p;
        }
        if (!o.scene.empty()) {
            spec.scene = o.scene;
        }
        if (!o.sample.empty()) {
            spec.sample = o.sample;
        }
        if (!o.operator_name.empty()) {
            spec.operator_name = o.operator_name;
        }
        if (!o.plan.empty()) {
            spec.plan_kind = o.plan;
        }
        if (o.n_theta > 0) {
            spec.uniform.n_theta = o.n_theta;
        }
        if (o.n_dphi > 0) {
            spec.uniform.n_dphi = o.n_dphi;
        }
        if (o.adaptive >= 0) {
            spec.adaptive = o.adaptive > 0;
            spec.adaptive_passes = o.adaptive;
        }
        auto r = acq::read_rig_config(spec.rig);
        if (!r) {
            return fail(r.error().message);
        }
        rig = *r;
        auto plan = acq::build_plan(spec, rig);
        if (!plan) {
            return fail(plan.error().message);
        }
        if (o.plan_only) {
            std::printf(
                "%zu configurations, %zu unreachable, %llu outside the ROI, naive 4D grid %llu\n",
                plan->configs.size(),
                plan->unreachable.size(),
                static_cast<unsigned long long>(plan->outside_roi),
                static_cast<unsigned long long>(plan->naive_count));
            for (const auto& u : plan->unreachable) {
                std::printf("unreachable: %s\n", u.reason.c_str());
            }
            return 0;
        }
        dir = o.out.empty() ? acq::auto_campaign_dir(o.campaigns_dir, spec.sample) : o.out;
        if (embedded) {
            // Record that the virtual rig served this campaign, and its ground truth, so that a
            // resume restarts the same world.
            nlohmann::json j = nlohmann::json::parse(rig.json);
            j["embedded_virtual_rig"] = true;
            if (!o.brdf.empty()) {
                // The ground truth is copied into the folder (ground_truth.<ext>) so that a resume
                // reads nothing outside it; the simulator starts from the given file.
                ground_truth_copy = ground_truth_name(o.brdf);
                j["sim"]["brdf"] = ground_truth_copy.empty() ? o.brdf : ground_truth_copy;
                so.brdf_path = o.brdf;
                j["sim"].erase("material");
            } else if (!o.material.empty()) {
                j["sim"]["material"] = o.material;
                j["sim"].erase("brdf");
            }
            if (o.time_scale > 0) {
                j["sim"]["time_scale"] = o.time_scale;
            }
            auto rr = acq::parse_rig_config(j.dump(2), spec.rig);
            if (!rr) {
                return fail(rr.error().message);
            }
            rig = *rr;
        }
        std::error_code ec;
        if (fs::exists(fs::path(dir) / "journal.log", ec) ||
            fs::exists(fs::path(dir) / "campaign.json", ec)) {
            return fail(dir + ": already holds a campaign (use --resume " + dir + ")");
        }
        if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
            return fail(dir + ": exists and is not a folder");
        }
        new_spec = spec;
    }
    if (embedded) {
        auto s = gonio::sim::SimRig::start(rig.json, so);
        if (!s) {
            return fail(s.error().message);
        }
        sim = std::move(*s);
        std::printf("virtual rig: %s; motors %s, camera %s\n",
                    sim->describe().c_str(),
                    sim->motor_address().c_str(),
                    sim->camera_address().c_str());
        rig = acq::with_addresses(rig, sim->motor_address(), sim->camera_address());
    }
    std::printf("campaign folder: %s\n", dir.c_str());
    std::fflush(stdout);

    auto dev = acq::open_rig(rig);
    if (!dev) {
        return fail(dev.error().message);
    }
    if (o.resume.empty()) {
        if (auto c = acq::create_campaign_dir(dir, new_spec, rig); !c) {
            return fail(c.error().message);
        }
        if (!ground_truth_copy.empty()) {
            auto bytes = gonio::read_input_file(o.brdf, gonio::max_memory_bytes());
            if (!bytes) {
                return fail(bytes.error().message);
            }
            const std::string to = (fs::path(dir) / ground_truth_copy).string();
            if (auto w = gonio::write_file_atomic(to, *bytes); !w) {
                return fail(w.error().message);
            }
        }
    }
    acq::RunHooks hooks;
    hooks.stop = &g_stop;
    hooks.out = stdout;
    hooks.accept_drift = o.accept_drift;
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
    std::unique_ptr<gonio::report::LiveServer> live;
    if (serve_at) {
        gonio::report::LiveOptions lo;
        lo.title = "gonio campaign " + fs::path(dir).filename().string();
        auto srv = gonio::report::LiveServer::start(serve_at->first, serve_at->second, lo);
        if (!srv) {
            return fail(srv.error().message);
        }
        live = std::move(*srv);
        std::printf("live page: %s\n", live->url().c_str());
        std::fflush(stdout);
        gonio::report::LiveServer* l = live.get();
        l->publish_progress(0, 0, "running");
        // The campaign thread only hands each sample over; the server draws on its own thread.
        hooks.on_measurement = [l](const gonio::brdf::Sample& s, std::size_t done, std::size_t n) {
            l->publish_sample(s);
            l->publish_progress(done, n, "running");
        };
    }
    std::signal(SIGINT, on_sigint);
    auto res = acq::run_campaign(dir, *dev, hooks);
    if (live && res) {
        const char* state = res->outcome == acq::Outcome::kCompleted     ? "completed"
                            : res->outcome == acq::Outcome::kInterrupted ? "stopped"
                                                                         : "paused";
        live->publish_progress(res->measured_total, res->planned_total, state);
    }
    std::signal(SIGINT, SIG_DFL);
    if (!res) {
        return fail(res.error().message);
    }
    std::printf("%s\ndataset: %s\n",
                res->message.c_str(),
                (fs::path(dir) / "dataset.csv").string().c_str());
    switch (res->outcome) {
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
                         res->message.c_str(),
                         dir.c_str());
            return 1;
    }
    return 1;
}

}  // namespace

GONIO_COMMAND(acquire) {
    auto* cmd = app.add_subcommand("acquire",
                                   "run a measurement campaign (no arguments: a default material "
                                   "on the embedded virtual rig)");
    auto o = std::make_shared<AcquireOptions>();
    cmd->add_option("campaign", o->campaign, "campaign description (campaign.json)");
    cmd->add_option(
        "--rig", o->rig, "rig description (default: the campaign's, else data/rigs/sim4.json)");
    cmd->add_option("--out", o->out, "campaign folder (default: campaigns/<time>_<sample>)");
    cmd->add_option("--campaigns-dir", o->campaigns_dir, "parent of automatically named folders");
    cmd->add_option("--resume", o->resume, "continue the campaign in this folder");
    cmd->add_option("--material", o->material, "virtual rig: named material (data/materials)");
    cmd->add_option("--brdf", o->brdf, "virtual rig: ground-truth model JSON or table");
    cmd->add_option("--scene", o->scene, "measure only the region of interest of this scene");
    cmd->add_option("--sample", o->sample, "sample name");
    cmd->add_option("--operator", o->operator_name, "operator name");
    cmd->add_option("--plan", o->plan, "uniform or half-diff")
        ->check(CLI::IsMember({"uniform", "half-diff"}));
    cmd->add_option("--n-theta", o->n_theta, "uniform plan: polar angles")
        ->check(gonio::tools::integer_in(2, acq::kMaxPlanAxis));
    cmd->add_option("--n-dphi", o->n_dphi, "uniform plan: azimuth differences")
        ->check(gonio::tools::integer_in(2, acq::kMaxPlanAxis));
    cmd->add_option("--adaptive", o->adaptive, "adaptive refinement passes (0 = none)")
        ->check(gonio::tools::integer_in(0, 100));
    cmd->add_option("--time-scale", o->time_scale, "virtual rig: motion time scale")
        ->check(gonio::tools::finite_in(0.001, 1e6));
    cmd->add_flag("--accept-drift",
                  o->accept_drift,
                  "resume: take the lamp's current level as the new baseline");
    cmd->add_option(
           "--mode", o->mode, "point (one configuration per frame) or image (curved sample)")
        ->check(CLI::IsMember({"point", "image"}));
    cmd->add_option(
           "--coverage-target", o->coverage_target, "image mode: fraction of valid table bins")
        ->check(gonio::tools::finite_in(0.001, 1));
    cmd->add_option(
        "--grid", o->grid, "image mode: table bins N_THETA_HxN_THETA_DxN_PHI_D (90x90x180 = MERL)");
    cmd->add_option("--max-frames", o->max_frames, "image mode: most light positions")
        ->check(gonio::tools::integer_in(1, 1000000));
    cmd->add_flag("--plan-only", o->plan_only, "print the plan (and unreachable targets) and exit");
    cmd->add_option("--serve",
                    o->serve,
                    "serve a live page of the campaign at [ADDR:]PORT (ADDR default 127.0.0.1, "
                    "PORT 0 = any free port; the URL is printed); point mode");
    return [o]() { return run(*o); };
}
