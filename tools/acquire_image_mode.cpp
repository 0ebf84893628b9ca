#include "acquire_image_mode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/base/data_path.h"
#include "gonio/base/limits.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/report/live_server.h"

namespace gonio::tools {

report::Image live_frame_picture(const devices::Frame& frame, int max_width) {
    report::Image out;
    const cv::Mat& src = frame.image;
    if (src.empty() || max_width < 1) {
        return out;
    }
    cv::Mat grey;
    if (src.channels() == 3) {
        cv::cvtColor(src, grey, cv::COLOR_BGR2GRAY);
    } else if (src.channels() == 1) {
        grey = src;
    } else {
        return out;
    }
    // Counts above black relative to the range up to saturation (8-bit frames: their own range).
    double black = frame.black_level;
    double range = frame.saturation_level - frame.black_level;
    if (!(range > 0)) {
        black = 0;
        range = grey.depth() == CV_8U ? 255.0 : grey.depth() == CV_16U ? 65535.0 : 1.0;
    }
    cv::Mat linear;
    grey.convertTo(linear, CV_32F, 1.0 / range, -black / range);
    if (linear.cols > max_width) {
        const int h =
            std::max(1,
                     static_cast<int>(std::lround(static_cast<double>(linear.rows) * max_width /
                                                  static_cast<double>(linear.cols))));
        cv::Mat small;
        cv::resize(linear, small, cv::Size(max_width, h), 0, 0, cv::INTER_AREA);
        linear = small;
    }
    cv::max(linear, 0.0, linear);
    cv::min(linear, 1.0, linear);
    cv::sqrt(linear, linear);
    cv::Mat bytes;
    linear.convertTo(bytes, CV_8U, 255.0);
    out.width = bytes.cols;
    out.height = bytes.rows;
    out.rgb.resize(static_cast<std::size_t>(out.width) * out.height * 3);
    for (int y = 0; y < bytes.rows; ++y) {
        const std::uint8_t* row = bytes.ptr<std::uint8_t>(y);
        for (int x = 0; x < bytes.cols; ++x) {
            const std::size_t i = (static_cast<std::size_t>(y) * out.width + x) * 3;
            out.rgb[i] = out.rgb[i + 1] = out.rgb[i + 2] = row[x];
        }
    }
    return out;
}

std::string live_frame_description(const devices::Frame& frame,
                                   const report::Image& picture,
                                   const std::string& what) {
    char buf[400];
    std::snprintf(buf,
                  sizeof buf,
                  "Latest camera frame: %s; frame %llu, exposure %.3g ms, %d x %d px, shown at "
                  "%d x %d px as the square root of the counts above black relative to "
                  "saturation (white: saturated).",
                  what.c_str(),
                  static_cast<unsigned long long>(frame.frame_id),
                  frame.exposure_us / 1000,
                  frame.image.cols,
                  frame.image.rows,
                  picture.width,
                  picture.height);
    return buf;
}

Expected<std::unique_ptr<ImageRig>> start_image_rig(const AcquireImageOptions& o) {
    std::string rig_path = o.rig_path;
    if (rig_path.empty()) {
        auto p = find_data_file("rigs/sim-image.json");
        if (!p) {
            return tl::unexpected(p.error());
        }
        rig_path = *p;
    }
    auto rig = acquisition::read_rig_config(rig_path);
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    auto out = std::make_unique<ImageRig>();
    const nlohmann::json j = nlohmann::json::parse(rig->json, nullptr, false);
    const bool embedded = j.is_object() && j.contains("sim");
    if (j.is_object() && j.contains("camera_model")) {
        auto c = acquisition::read_camera_model(rig_path);
        if (!c) {
            return tl::unexpected(c.error());
        }
        out->camera = *c;
    } else if (embedded) {
        out->camera =
            acquisition::default_image_camera(o.image_size, o.perspective, rig->sphere_radius_m);
    } else {
        return make_error(rig_path +
                          ": camera_model: missing (image mode on a rig needs the calibrated "
                          "camera; see docs/image-acquisition.md)");
    }
    if (!embedded) {
        // The devices at the description's addresses: a real rig, or a virtual rig served
        // elsewhere.
        out->rig = *rig;
    } else {
        if (o.supersample < 1) {
            return make_error("supersample " + std::to_string(o.supersample) + ": must be >= 1");
        }
        sim::SimRigOptions so;
        so.material = o.material;
        so.brdf_path = o.brdf_path;
        so.time_scale = o.time_scale;
        so.seed = o.seed;
        sim::SphereImaging sphere;
        sphere.camera = to_sphere_camera(out->camera);
        sphere.radius_m = rig->sphere_radius_m;
        sphere.supersample = o.supersample;
        so.sphere = sphere;
        auto s = sim::SimRig::start(rig->json, so);
        if (!s) {
            return tl::unexpected(s.error());
        }
        out->sim = std::move(*s);
        out->rig = acquisition::with_addresses(
            *rig, out->sim->motor_address(), out->sim->camera_address());
    }
    auto dev = acquisition::open_rig(out->rig);
    if (!dev) {
        return tl::unexpected(dev.error());
    }
    out->dev = std::move(*dev);
    devices::Camera& cam = *out->dev.camera;
    if (auto r = cam.set_pixel_format(devices::PixelFormat::kMono16); !r) {
        return tl::unexpected(r.error());
    }
    if (auto r = cam.set_roi(devices::Roi{}); !r) {
        return tl::unexpected(r.error());
    }
    if (auto r = cam.set_gain(out->rig.capture.gain); !r) {
        return tl::unexpected(r.error());
    }
    return out;
}

acquisition::CaptureFn image_rig_capture(ImageRig& rig, double detector_arm_rad) {
    acquisition::RigDevices& d = rig.dev;
    std::function<Expected<void>(int)> select_filter;
    if (d.filter_wheel) {
        devices::FilterWheel* fw = d.filter_wheel.get();
        select_filter = [fw](int c) { return fw->set_filter(c); };
    }
    std::function<Expected<void>(bool)> swap_target;
    if (d.reference_changer) {
        devices::Light* changer = d.reference_changer.get();
        swap_target = [changer](bool white) { return changer->set_shutter_open(white); };
    }
    acquisition::DeviceCaptureOptions opt;
    opt.move_timeout = std::chrono::milliseconds(rig.rig.move_timeout_ms);
    const auto& light_axis = rig.rig.axes[static_cast<int>(acquisition::AxisRole::kLight)];
    const auto& detector_axis = rig.rig.axes[static_cast<int>(acquisition::AxisRole::kDetector)];
    opt.settle = std::chrono::milliseconds(static_cast<std::int64_t>(
        std::ceil(std::max(light_axis.motion.settle_ms, detector_axis.motion.settle_ms))));
    opt.detector_arm = d.axes[static_cast<int>(acquisition::AxisRole::kDetector)].get();
    opt.detector_arm_rad = detector_arm_rad;
    opt.log = &rig.pose_log;
    opt.capture_timeout = std::chrono::milliseconds(rig.rig.capture.timeout_ms);
    opt.capture_retries = rig.rig.retries;
    return acquisition::make_device_capture(
        *d.camera,
        *d.shutter,
        *d.axes[static_cast<int>(acquisition::AxisRole::kLight)],
        std::move(select_filter),
        std::move(swap_target),
        opt);
}

namespace {

std::string new_output_dir(const std::string& parent, const std::string& material) {
    const std::filesystem::path base =
        parent.empty() ? std::filesystem::path(".") : std::filesystem::path(parent);
    for (int n = 1;; ++n) {
        const std::filesystem::path d = base / ("image-" + material + "-" + std::to_string(n));
        if (!std::filesystem::exists(d)) {
            return parent.empty() ? d.filename().string() : d.string();
        }
    }
}

constexpr const char* kSettingsFile = "image_campaign.json";
constexpr const char* kJournalFile = "frames.journal";

/// The settings a resume needs, as stored in the campaign folder.
std::string settings_json(const AcquireImageOptions& o, const std::string& brdf_in_dir) {
    nlohmann::json j;
    j["material"] = o.material;
    j["brdf"] = brdf_in_dir;
    j["rig"] = o.rig_path;
    j["table_factor"] = o.table_factor;
    j["grid"] = {o.grid.n_theta_h, o.grid.n_theta_d, o.grid.n_phi_d};
    j["coverage_target"] = o.coverage_target;
    j["max_frames"] = o.max_frames;
    j["image_size"] = o.image_size;
    j["perspective"] = o.perspective;
    j["supersample"] = o.supersample;
    j["time_scale"] = o.time_scale;
    j["seed"] = o.seed;
    j["sample"] = o.sample;
    j["operator"] = o.operator_name;
    return j.dump(2) + "\n";
}

/// Options of the campaign in `dir` (settings_json), the folder's ground truth resolved in it.
Expected<AcquireImageOptions> read_settings(const std::string& dir,
                                            const AcquireImageOptions& base) {
    const std::string path = (std::filesystem::path(dir) / kSettingsFile).string();
    auto text = read_input_file(path, 1 << 20);
    if (!text) {
        return make_error(dir + ": not an image-mode campaign folder (" + text.error().message +
                          ")");
    }
    AcquireImageOptions o = base;
    try {
        const nlohmann::json j = nlohmann::json::parse(*text);
        o.material = j.at("material").get<std::string>();
        const std::string b = j.at("brdf").get<std::string>();
        o.brdf_path = b.empty() ? std::string() : (std::filesystem::path(dir) / b).string();
        o.rig_path = j.at("rig").get<std::string>();
        o.table_factor = j.at("table_factor").get<int>();
        const auto& g = j.at("grid");
        o.grid = {g.at(0).get<int>(), g.at(1).get<int>(), g.at(2).get<int>()};
        o.coverage_target = j.at("coverage_target").get<double>();
        o.max_frames = j.at("max_frames").get<int>();
        o.image_size = j.at("image_size").get<int>();
        o.perspective = j.at("perspective").get<bool>();
        o.supersample = j.at("supersample").get<int>();
        o.time_scale = j.at("time_scale").get<double>();
        o.seed = j.at("seed").get<std::uint64_t>();
        o.sample = j.value("sample", std::string());
        o.operator_name = j.value("operator", std::string());
    } catch (const nlohmann::json::exception& e) {
        return make_error(path + ": " + e.what());
    }
    o.out_dir = dir;
    o.resume_dir = dir;
    return o;
}

}  // namespace

int run_acquire_image_mode(const AcquireImageOptions& given) {
    AcquireImageOptions o = given;
    if (!given.resume_dir.empty()) {
        auto r = read_settings(given.resume_dir, given);
        if (!r) {
            std::fprintf(stderr, "gonio acquire: %s\n", r.error().message.c_str());
            return 1;
        }
        o = *r;
    }
    const bool custom_grid = o.grid.n_theta_h > 0 || o.grid.n_theta_d > 0 || o.grid.n_phi_d > 0;
    if (custom_grid && (o.grid.n_theta_h < 1 || o.grid.n_theta_d < 1 || o.grid.n_phi_d < 1 ||
                        o.grid.n_theta_h > 360 || o.grid.n_theta_d > 360 || o.grid.n_phi_d > 720)) {
        std::fprintf(stderr,
                     "gonio acquire: --grid %dx%dx%d: each count must be >= 1 (at most 360 x 360 "
                     "x 720)\n",
                     o.grid.n_theta_h,
                     o.grid.n_theta_d,
                     o.grid.n_phi_d);
        return 1;
    }
    if (!custom_grid && (o.table_factor < 1 || 90 % o.table_factor != 0)) {
        std::fprintf(stderr,
                     "gonio acquire: --table-factor %d must divide 90 (1 = MERL resolution)\n",
                     o.table_factor);
        return 1;
    }
    auto rig = start_image_rig(o);
    if (!rig) {
        std::fprintf(stderr, "gonio acquire: %s\n", rig.error().message.c_str());
        return 1;
    }
    const bool embedded = (*rig)->sim != nullptr;
    std::string truth_name = "sample";
    if (embedded) {
        truth_name =
            o.brdf_path.empty() ? o.material : std::filesystem::path(o.brdf_path).stem().string();
        const auto sample = (*rig)->sim->sample();
        if (!sample->isotropic()) {
            std::fprintf(stderr,
                         "gonio acquire: image mode bins into an isotropic half/difference "
                         "table; %s is anisotropic\n",
                         sample->describe().c_str());
            return 1;
        }
    }
    const std::string motors =
        (*rig)->rig.axes[static_cast<int>(acquisition::AxisRole::kLight)].address;
    const std::string camera_address = (*rig)->rig.camera_address;
    const acquisition::ImageCampaignConfig cfg =
        custom_grid
            ? acquisition::image_campaign_config(
                  (*rig)->rig, (*rig)->camera, o.grid, o.coverage_target, o.max_frames)
            : acquisition::image_campaign_config(
                  (*rig)->rig, (*rig)->camera, o.table_factor, o.coverage_target, o.max_frames);
    const std::string dir =
        o.out_dir.empty()
            ? new_output_dir(o.campaigns_dir, o.sample.empty() ? truth_name : o.sample)
            : o.out_dir;
    const std::string journal = (std::filesystem::path(dir) / kJournalFile).string();
    std::unique_ptr<report::LiveServer> live;
    if (o.serve_port >= 0) {
        // Before anything is written: an address that cannot be served leaves no folder behind.
        report::LiveOptions lo;
        lo.title = "gonio image campaign " + std::filesystem::path(dir).filename().string();
        lo.frame_note = "no camera frame yet (the first comes with the white reference)";
        auto srv = report::LiveServer::start(o.serve_host, o.serve_port, lo);
        if (!srv) {
            std::fprintf(stderr, "gonio acquire: %s\n", srv.error().message.c_str());
            return 1;
        }
        live = std::move(*srv);
    }
    if (o.resume_dir.empty()) {
        std::error_code ec;
        if (std::filesystem::exists(journal, ec)) {
            std::fprintf(stderr,
                         "gonio acquire: %s: already holds an image campaign (continue it with "
                         "--resume %s)\n",
                         dir.c_str(),
                         dir.c_str());
            return 1;
        }
        std::filesystem::create_directories(dir, ec);
        if (ec) {
            std::fprintf(stderr,
                         "gonio acquire: %s: cannot create: %s\n",
                         dir.c_str(),
                         ec.message().c_str());
            return 1;
        }
        // The ground truth's file is copied into the folder so that a resume reads only the
        // folder.
        std::string brdf_in_dir;
        if (!o.brdf_path.empty()) {
            brdf_in_dir = "ground_truth" + std::filesystem::path(o.brdf_path).extension().string();
            auto bytes = read_input_file(o.brdf_path, max_memory_bytes());
            if (!bytes) {
                std::fprintf(stderr, "gonio acquire: %s\n", bytes.error().message.c_str());
                return 1;
            }
            if (auto w =
                    write_file_atomic((std::filesystem::path(dir) / brdf_in_dir).string(), *bytes);
                !w) {
                std::fprintf(stderr, "gonio acquire: %s\n", w.error().message.c_str());
                return 1;
            }
        }
        if (auto w = write_file_atomic((std::filesystem::path(dir) / kSettingsFile).string(),
                                       settings_json(o, brdf_in_dir));
            !w) {
            std::fprintf(stderr, "gonio acquire: %s\n", w.error().message.c_str());
            return 1;
        }
    }
    if (!o.quiet) {
        std::printf(
            "image mode: %s sphere on %s (motors %s, camera %s), %dx%dx%d table, "
            "target %.0f%%\n",
            truth_name.c_str(),
            embedded ? "the virtual rig" : (*rig)->rig.name.c_str(),
            motors.c_str(),
            camera_address.c_str(),
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
    acquisition::CaptureFn capture = image_rig_capture(**rig, cfg.detector_arm_rad);
    acquisition::ImageStateFn state;
    if (live) {
        std::printf("live page: %s\n", live->url().c_str());
        std::fflush(stdout);
        report::LiveServer* l = live.get();
        const std::size_t max_frames = static_cast<std::size_t>(std::max(cfg.max_frames, 0));
        l->publish_image_progress(0, max_frames, 0, cfg.coverage_target, "running");
        // The campaign thread hands over a small picture of a frame (at most four a second) and the
        // coverage per (theta_h, theta_d) cell; the server draws them on its own thread.
        using Clock = std::chrono::steady_clock;
        capture = [inner = std::move(capture), l, last = Clock::time_point()](
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
        state = [l, max_frames, target = cfg.coverage_target](
                    const acquisition::ImageCampaignResult& so_far) {
            const acquisition::CoverageMap& c = so_far.coverage;
            const acquisition::TableLayout& lay = c.layout();
            report::CoverageCells cells;
            cells.n_theta_h = lay.n_theta_h;
            cells.n_theta_d = lay.n_theta_d;
            cells.n_phi_d = lay.n_phi_d;
            cells.fraction.assign(static_cast<std::size_t>(lay.n_theta_h) * lay.n_theta_d, -1.0);
            for (int ih = 0; ih < lay.n_theta_h; ++ih) {
                for (int id = 0; id < lay.n_theta_d; ++id) {
                    int valid = 0;
                    int covered = 0;
                    for (int ip = 0; ip < lay.n_phi_d; ++ip) {
                        const std::size_t b = lay.index(ih, id, ip);
                        if (acquisition::bin_valid(lay, b)) {
                            ++valid;
                            covered += c.covered(b) ? 1 : 0;
                        }
                    }
                    if (valid > 0) {
                        cells.fraction[static_cast<std::size_t>(ih) * lay.n_theta_d + id] =
                            static_cast<double>(covered) / valid;
                    }
                }
            }
            cells.measured_bins = c.covered_bins();
            cells.total_bins = c.valid_bins();
            cells.total_is_valid_bins = true;
            l->publish_coverage(std::move(cells));
            l->publish_image_progress(
                so_far.frames.size(), max_frames, c.fraction(), target, "running");
        };
    }
    auto result = acquisition::run_image_campaign(capture, cfg, progress, journal, state);
    const acquisition::PoseCheckLog& poses = (*rig)->pose_log;
    if (live) {
        live->publish_image_progress(result ? result->frames.size() : 0,
                                     static_cast<std::size_t>(std::max(cfg.max_frames, 0)),
                                     result ? result->coverage.fraction() : 0,
                                     cfg.coverage_target,
                                     !result              ? "failed"
                                     : result->target_met ? "completed"
                                                          : "ended without reaching the target (" +
                                                                result->stop_reason + ")");
    }
    if (!result) {
        std::fprintf(stderr, "gonio acquire: %s\n", result.error().message.c_str());
        return 1;
    }
    nlohmann::json extra;
    extra["sample"] = o.sample.empty() ? truth_name : o.sample;
    if (!o.operator_name.empty()) {
        extra["operator"] = o.operator_name;
    }
    if (embedded) {
        extra["ground_truth"] = (*rig)->sim->sample()->describe();
    }
    extra["rig"] = o.rig_path.empty() ? "embedded virtual rig (sim-image)" : o.rig_path;
    extra["embedded_virtual_rig"] = embedded;
    extra["camera_address"] = camera_address;
    extra["seed"] = o.seed;
    extra["pose_repeats"] = poses.repeats;
    extra["pose_corrections"] = poses.corrections;
    extra["capture_retries"] = poses.capture_retries;
    extra["pose_notes"] = poses.notes;
    if (auto w = acquisition::write_image_campaign(dir, *result, cfg, extra.dump()); !w) {
        std::fprintf(stderr, "gonio acquire: %s\n", w.error().message.c_str());
        return 1;
    }
    const acquisition::PixelCounts& c = result->counts;
    if (result->resumed_frames > 0) {
        std::printf(
            "resumed: %zu frames read back from %s\n", result->resumed_frames, journal.c_str());
    }
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
    {
        // Empty valid bins by reason, in the order coverage_holes() tells them apart.
        std::vector<std::pair<std::string, std::size_t>> by_reason;
        for (const auto& h : result->holes) {
            auto it = std::find_if(by_reason.begin(), by_reason.end(), [&](const auto& p) {
                return p.first == h.reason;
            });
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
                    static_cast<double>(std::max<std::size_t>(1, result->coverage.valid_bins())));
            line +=
                (line.empty() ? "" : ", ") + reason + " " + std::to_string(bins) + " (" + pct + ")";
        }
        if (!line.empty()) {
            std::printf("empty valid bins by reason: %s\n", line.c_str());
        }
    }
    std::printf(
        "captures: %llu through %s (%zu retried after a camera error); pose checks: %zu "
        "exposures repeated, %zu poses corrected\n",
        static_cast<unsigned long long>(result->captures),
        camera_address.c_str(),
        poses.capture_retries,
        poses.repeats,
        poses.corrections);
    if (!result->target_met) {
        std::fprintf(stderr,
                     "gonio acquire: coverage target %.1f%% not met (%.1f%%)\n",
                     100 * cfg.coverage_target,
                     100 * result->coverage.fraction());
        return 1;
    }
    return 0;
}

AcquireImageOptions image_options(const acquisition::CampaignRequest& r) {
    AcquireImageOptions io;
    io.resume_dir = r.resume_dir;
    io.out_dir = r.out_dir;
    if (!r.material.empty()) {
        io.material = r.material;
    }
    io.brdf_path = r.brdf_path;
    io.rig_path = r.rig_path;
    if (r.coverage_target > 0) {
        io.coverage_target = r.coverage_target;
    }
    if (r.max_frames > 0) {
        io.max_frames = r.max_frames;
    }
    io.table_factor = r.table_factor;
    io.grid = r.grid;
    io.image_size = r.image_size;
    io.supersample = r.supersample;
    io.time_scale = r.time_scale;
    io.seed = r.seed;
    io.sample = r.sample;
    io.operator_name = r.operator_name;
    io.campaigns_dir = r.campaigns_dir;
    return io;
}

int print_image_plan(const acquisition::CampaignRequest& request) {
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

}  // namespace gonio::tools
