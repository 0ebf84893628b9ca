// gonio camera: inspect a camera, capture an OpenEXR frame, or serve the simulated GigE Vision
// camera.
//   gonio camera --connect ADDRESS info
//   gonio camera --connect ADDRESS capture --exposure-us N [--gain G | --camera-gain V]
//       [--format PFNC] [--roi X,Y,W,H] out.exr
//   gonio camera serve [--ip 127.0.0.1] [--material NAME | --brdf PATH] [--exposure-abs]

#include <signal.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "command.h"
#include "gonio/acquisition/shared/frame_exr.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/devices/aravis_camera.h"
#include "gonio/devices/camera_factory.h"
#include "gonio/devices/pixel_format.h"
#include "gonio/devices/uvc_camera.h"
#include "gonio/sim/gige_camera.h"
#include "gonio/sim/gige_server.h"
#include "option_checks.h"

namespace {

struct CameraOptions {
    std::string connect;
    // capture
    double exposure_us = 10000;
    double gain = 1;
    double camera_gain = std::nan("");  ///< in the camera's unit (dB or raw); NaN = use `gain`
    std::string format = "Mono16";
    std::vector<int> roi;  ///< X, Y, W, H (empty = leave the camera's region)
    int timeout_ms = 5000;
    std::string output;
    // serve
    std::string material = "white-lambert";
    std::string brdf_path;
    bool exposure_abs = false;
    std::string ip = "127.0.0.1";
    int width = 1280;
    int height = 1024;
    std::uint64_t seed = 1;
    double theta_i_deg = 30, phi_i_deg = 0, theta_o_deg = 30, phi_o_deg = 180;
    double irradiance = 1.0;
};

constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// The ground truth: a model JSON or table, a named material, or an ideal white diffuser.
gonio::Expected<std::shared_ptr<const gonio::brdf::Brdf>> load_truth(const CameraOptions& o) {
    if (!o.brdf_path.empty()) {
        auto b = gonio::brdf::load_brdf(o.brdf_path);
        if (!b) {
            return tl::unexpected(b.error());
        }
        return std::shared_ptr<const gonio::brdf::Brdf>(std::move(*b));
    }
    if (o.material == "white-lambert") {
        gonio::brdf::ModelD m;
        m.diffuse = gonio::brdf::Rgbd::Constant(1.0);
        return std::shared_ptr<const gonio::brdf::Brdf>(gonio::brdf::make_analytic_brdf(m));
    }
    auto m = gonio::brdf::load_material(o.material);
    if (!m) {
        return tl::unexpected(m.error());
    }
    return std::shared_ptr<const gonio::brdf::Brdf>(gonio::brdf::make_analytic_brdf(*m));
}

/// The simulated GigE Vision camera with the options' sensor and fixed scene (not started).
gonio::Expected<std::shared_ptr<gonio::sim::GigeCamera>> make_sim_camera(const CameraOptions& o) {
    auto truth = load_truth(o);
    if (!truth) {
        return tl::unexpected(truth.error());
    }
    gonio::sim::GigeCameraConfig cfg;
    cfg.sensor.width = o.width;
    cfg.sensor.height = o.height;
    cfg.sensor.seed = o.seed;
    cfg.exposure_naming =
        o.exposure_abs ? gonio::sim::ExposureNaming::kAbs : gonio::sim::ExposureNaming::kSfnc;
    const gonio::sim::SceneState scene = gonio::sim::scene_from_angles(o.theta_i_deg * kDeg,
                                                                       o.phi_i_deg * kDeg,
                                                                       o.theta_o_deg * kDeg,
                                                                       o.phi_o_deg * kDeg,
                                                                       o.irradiance);
    return std::make_shared<gonio::sim::GigeCamera>(cfg, *truth, [scene] { return scene; });
}

int write_exr(const gonio::devices::Frame& f, const std::string& path) {
    if (auto w = gonio::acquisition::write_frame_exr(path, f); !w) {
        std::fprintf(stderr, "gonio camera: %s\n", w.error().message.c_str());
        return 1;
    }
    return 0;
}

gonio::Expected<std::unique_ptr<gonio::devices::Camera>> connect(const CameraOptions& o,
                                                                 std::shared_ptr<void>* keep) {
    if (o.connect.empty()) {
        return gonio::make_error(
            "--connect ADDRESS is required (gige://HOST, u3v://SERIAL, aravis:DEVICE-ID, "
            "uvc:INDEX, or sim for an embedded simulated camera)");
    }
    if (o.connect == "sim" || o.connect.rfind("sim:", 0) == 0) {
        CameraOptions so = o;
        if (o.connect.size() > 4) {
            so.material = o.connect.substr(4);
        }
        auto cam = make_sim_camera(so);
        if (!cam) {
            return tl::unexpected(cam.error());
        }
        // Served in this process on a loopback address of its own, opened through Aravis like
        // any GigE Vision camera.
        auto server = std::make_shared<gonio::sim::GigeServer>(*cam);
        if (auto r = server->start_on_free_loopback(); !r) {
            return tl::unexpected(r.error());
        }
        *keep = server;
        return gonio::devices::open_camera(server->address());
    }
    if (o.connect.rfind("uvc:", 0) == 0) {
        std::fprintf(stderr, "%s\n", gonio::devices::uvc_radiometry_warning());
    }
    return gonio::devices::open_camera(o.connect);
}

/// How gonio drives this GenICam camera: the features it picked and what it could not find.
void print_genicam_features(gonio::devices::AravisCamera& a) {
    if (auto pf = a.feature_string("PixelFormat")) {
        std::printf("pixel_format: %s\n", pf->c_str());
    }
    if (auto list = a.pixel_formats()) {
        std::string all;
        for (const auto& n : *list) {
            all += (all.empty() ? "" : " ") + n;
        }
        std::printf("pixel_formats: %s\n", all.c_str());
    }
    if (auto f = a.exposure_feature()) {
        std::printf("exposure_feature: %s (unit %s, range %g..%g us)\n",
                    f->name.c_str(),
                    f->unit.empty() ? "us by SFNC" : f->unit.c_str(),
                    f->min_us,
                    f->max_us);
    } else {
        std::printf("exposure_feature: none (%s)\n", f.error().message.c_str());
    }
    if (auto g = a.gain_feature(); g && !g->name.empty()) {
        std::printf("gain_feature: %s (unit %s, range %g..%g %s)\n",
                    g->name.c_str(),
                    g->unit.c_str(),
                    g->min,
                    g->max,
                    g->unit.c_str());
    } else if (!g) {
        std::printf("gain_feature: none (%s)\n", g.error().message.c_str());
    } else {
        std::printf("gain_feature: none\n");
    }
    std::printf("trigger: %s\n", a.trigger_method().c_str());
}

int run_info(const CameraOptions& o) {
    std::shared_ptr<void> keep;
    auto cam = connect(o, &keep);
    if (!cam) {
        std::fprintf(stderr, "gonio camera: %s\n", cam.error().message.c_str());
        return 1;
    }
    auto info = (*cam)->info();
    if (!info) {
        std::fprintf(stderr, "gonio camera: %s\n", info.error().message.c_str());
        return 1;
    }
    auto e = (*cam)->exposure_us();
    std::printf(
        "vendor: %s\nmodel: %s\nserial: %s\nversion: %s\nsensor: %d x %d%s\nbit_depth: %d\n",
        info->vendor.c_str(),
        info->model.c_str(),
        info->serial.c_str(),
        info->version.c_str(),
        info->sensor_width,
        info->sensor_height,
        info->sensor_size_from.empty() ? "" : (" (from " + info->sensor_size_from + ")").c_str(),
        info->bit_depth);
    if (e) {
        std::printf("exposure_us: %g\n", *e);
    }
    if (auto* a = dynamic_cast<gonio::devices::AravisCamera*>(cam->get())) {
        print_genicam_features(*a);
    }
    return 0;
}

int run_capture(const CameraOptions& o) {
    std::shared_ptr<void> keep;
    auto cam = connect(o, &keep);
    if (!cam) {
        std::fprintf(stderr, "gonio camera: %s\n", cam.error().message.c_str());
        return 1;
    }
    auto& c = **cam;
    auto* genicam = dynamic_cast<gonio::devices::AravisCamera*>(&c);
    std::vector<std::function<gonio::Expected<void>()>> steps;
    if (genicam != nullptr) {
        // Any PFNC format the camera offers and gonio decodes.
        steps.emplace_back([&] { return genicam->set_pixel_format_name(o.format); });
    } else {
        auto fmt = gonio::devices::pixel_format_from_string(o.format);
        if (!fmt) {
            std::fprintf(stderr,
                         "gonio camera: --format %s is not Mono8, Mono12 or Mono16\n",
                         o.format.c_str());
            return 2;
        }
        steps.emplace_back([&c, f = *fmt] { return c.set_pixel_format(f); });
    }
    if (o.roi.size() == 4) {
        steps.emplace_back([&] { return c.set_roi({o.roi[0], o.roi[1], o.roi[2], o.roi[3]}); });
    }
    steps.emplace_back([&] { return c.set_exposure_us(o.exposure_us); });
    if (!std::isnan(o.camera_gain)) {
        if (genicam == nullptr) {
            std::fprintf(stderr, "gonio camera: --camera-gain needs a GenICam camera\n");
            return 2;
        }
        steps.emplace_back([&] { return genicam->set_gain_native(o.camera_gain); });
    } else {
        steps.emplace_back([&] { return c.set_gain(o.gain); });
    }
    for (const auto& step : steps) {
        if (auto r = step(); !r) {
            std::fprintf(stderr, "gonio camera: %s\n", r.error().message.c_str());
            return 1;
        }
    }
    auto frame = c.capture(std::chrono::milliseconds(o.timeout_ms));
    if (!frame) {
        std::fprintf(stderr, "gonio camera: %s\n", frame.error().message.c_str());
        return 1;
    }
    if (int rc = write_exr(*frame, o.output); rc != 0) {
        return rc;
    }
    double lo = 0, hi = 0;
    cv::minMaxLoc(frame->image, &lo, &hi);
    std::printf("%s: %d x %d, %d bits, exposure %g us, gain %g, black %g, counts %g..%g%s\n",
                o.output.c_str(),
                frame->image.cols,
                frame->image.rows,
                frame->bit_depth,
                frame->exposure_us,
                frame->gain,
                frame->black_level,
                lo,
                hi,
                frame->linear ? "" : " (not radiometric)");
    if (genicam != nullptr) {
        const auto s = genicam->stream_stats();
        std::printf(
            "frame %llu, %s%s%s; stream: %llu complete, %llu incomplete, %llu missing, "
            "%llu packets resent, %llu packets lost\n",
            static_cast<unsigned long long>(frame->frame_id),
            frame->pixel_format.c_str(),
            frame->cfa.empty() ? "" : " raw mosaic ",
            frame->cfa.c_str(),
            static_cast<unsigned long long>(s.frames_completed),
            static_cast<unsigned long long>(s.frames_incomplete),
            static_cast<unsigned long long>(s.frames_missing),
            static_cast<unsigned long long>(s.resent_packets),
            static_cast<unsigned long long>(s.missing_packets));
    }
    return 0;
}

/// The simulated GigE Vision camera on --ip (default 127.0.0.1), port 3956, until SIGINT or
/// SIGTERM.
int run_serve(const CameraOptions& o) {
    auto camera = make_sim_camera(o);
    if (!camera) {
        std::fprintf(stderr, "gonio camera serve: %s\n", camera.error().message.c_str());
        return 1;
    }
    // Block the termination signals before starting the server threads so that only sigwait
    // receives them.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    gonio::sim::GigeServer server(*camera);
    if (auto r = o.ip == "auto" ? server.start_on_free_loopback() : server.start(o.ip); !r) {
        std::fprintf(stderr, "gonio camera serve: %s\n", r.error().message.c_str());
        return 1;
    }
    std::printf("%s\n", server.address().c_str());
    std::fflush(stdout);
    int sig = 0;
    sigwait(&set, &sig);
    server.stop();
    return 0;
}

void add_capture_options(CLI::App* capture, CameraOptions* o) {
    capture->add_option("--exposure-us", o->exposure_us, "exposure time in microseconds")
        ->check(CLI::PositiveNumber);
    capture->add_option("--gain", o->gain, "linear gain factor (1 = unity)")
        ->check(CLI::PositiveNumber);
    capture->add_option("--camera-gain",
                        o->camera_gain,
                        "gain in the camera's own unit: dB for Gain, raw for GainRaw (GenICam "
                        "cameras; replaces --gain)");
    capture->add_option("--format",
                        o->format,
                        "pixel format: Mono8, Mono12 or Mono16; any mono or Bayer PFNC name the "
                        "camera offers for GenICam cameras");
    capture->add_option("--roi", o->roi, "region of interest X,Y,W,H (W or H 0 = to the edge)")
        ->delimiter(',')
        ->expected(4);
    capture->add_option("--timeout-ms", o->timeout_ms, "frame timeout")->check(CLI::PositiveNumber);
    capture->add_option("output", o->output, "output .exr")->required();
}

void add_serve_options(CLI::App* serve, CameraOptions* o) {
    serve->add_flag("--exposure-abs",
                    o->exposure_abs,
                    "name the exposure feature ExposureTimeAbs instead of ExposureTime");
    serve->add_option("--ip",
                      o->ip,
                      "IPv4 address to serve on, port 3956 (default 127.0.0.1; any 127.x.y.z "
                      "address is also this machine; auto: a free one, printed)");
    serve->add_option("--material",
                      o->material,
                      "material name from data/materials (default: white-lambert, rho = 1)");
    serve
        ->add_option("--brdf",
                     o->brdf_path,
                     "ground-truth model JSON or table (overrides "
                     "--material)")
        ->check(gonio::tools::readable_input());
}

/// The simulated camera's sensor and scene, for capture (with sim) and serve.
void add_simulation_options(CLI::App* sub, CameraOptions* o) {
    sub->add_option("--width", o->width, "sensor width (simulated)")->check(CLI::Range(16, 16384));
    sub->add_option("--height", o->height, "sensor height (simulated)")
        ->check(CLI::Range(16, 16384));
    sub->add_option("--seed", o->seed, "noise seed (simulated)");
    sub->add_option("--theta-i-deg", o->theta_i_deg, "light polar angle (simulated)");
    sub->add_option("--phi-i-deg", o->phi_i_deg, "light azimuth (simulated)");
    sub->add_option("--theta-o-deg", o->theta_o_deg, "detector polar angle (simulated)");
    sub->add_option("--phi-o-deg", o->phi_o_deg, "detector azimuth (simulated)");
    sub->add_option("--irradiance", o->irradiance, "beam irradiance W/m^2 (simulated)");
}

/// Options the chosen mode would drop are usage errors naming them: the exit code (2), or 0
/// when every option given is used.
int refuse_unused_options(const CameraOptions& o,
                          const CLI::App& cmd,
                          const CLI::App& capture,
                          const CLI::App& serve) {
    if (serve.parsed() && cmd.count("--connect") > 0) {
        return gonio::tools::usage_error("camera serve",
                                         "--connect is not used: serve makes the camera it serves");
    }
    if (serve.parsed() && serve.count("--brdf") > 0 && serve.count("--material") > 0) {
        return gonio::tools::usage_error(
            "camera serve", "--brdf and --material both name the ground truth: give one");
    }
    if (!capture.parsed()) {
        return 0;
    }
    const bool simulated = o.connect == "sim" || o.connect.rfind("sim:", 0) == 0;
    for (const char* sim_only : {"--width",
                                 "--height",
                                 "--seed",
                                 "--theta-i-deg",
                                 "--phi-i-deg",
                                 "--theta-o-deg",
                                 "--phi-o-deg",
                                 "--irradiance"}) {
        if (!simulated && !o.connect.empty() && capture.count(sim_only) > 0) {
            return gonio::tools::usage_error(
                "camera capture",
                std::string(sim_only) +
                    " sets up the simulated camera; it is not used with --connect " + o.connect);
        }
    }
    if (capture.count("--gain") > 0 && capture.count("--camera-gain") > 0) {
        return gonio::tools::usage_error("camera capture",
                                         "--camera-gain replaces --gain: give one of them");
    }
    return 0;
}

}  // namespace

GONIO_COMMAND(camera) {
    auto* cmd = app.add_subcommand("camera",
                                   "inspect a camera, capture an OpenEXR frame, or "
                                   "serve the simulated GigE Vision camera");
    auto o = std::make_shared<CameraOptions>();
    cmd->add_option("--connect",
                    o->connect,
                    "camera address: gige://HOST, u3v://SERIAL, aravis:DEVICE-ID (GenICam "
                    "through Aravis), uvc:INDEX (OpenCV), sim or sim:MATERIAL (the simulated "
                    "GigE Vision camera, served in this process)");
    cmd->require_subcommand(1);
    auto* info = cmd->add_subcommand("info", "print vendor, model, serial, sensor size");
    auto* capture = cmd->add_subcommand("capture", "capture one frame into an OpenEXR file");
    add_capture_options(capture, o.get());
    auto* serve =
        cmd->add_subcommand("serve",
                            "serve the simulated GigE Vision camera on 127.0.0.1 and print its "
                            "address");
    add_serve_options(serve, o.get());
    for (CLI::App* sub : {capture, serve}) {
        add_simulation_options(sub, o.get());
    }
    return [o, cmd, info, capture, serve]() -> int {
        if (const int refused = refuse_unused_options(*o, *cmd, *capture, *serve); refused != 0) {
            return refused;
        }
        if (info->parsed()) {
            return run_info(*o);
        }
        if (capture->parsed()) {
            return run_capture(*o);
        }
        if (serve->parsed()) {
            return run_serve(*o);
        }
        return 2;
    };
}
