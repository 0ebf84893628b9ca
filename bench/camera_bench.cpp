// Simulated camera throughput: a 5-megapixel (2448 x 2048) Mono16 stream from the simulated GigE
// Vision camera through Aravis on a loopback address of its own, and the render time per frame
// (radiance, sensor noise).
// Each benchmark reports, next to its time, the relative error of the frame's patch mean against
// the radiometric chain's closed form (docs/camera.md).

#include <arv.h>
#include <benchmark/benchmark.h>
#include <dirent.h>
#include <time.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "gonio/sim/camera_render.h"
#include "gonio/sim/gige_camera.h"
#include "gonio/sim/gige_server.h"
#include "gonio/sim/sensor_model.h"

namespace {

using namespace std::chrono_literals;

constexpr int kW = 2448;
constexpr int kH = 2048;
constexpr double kExposureUs = 5000;

class WhiteBrdf : public gonio::brdf::Brdf {
  public:
    gonio::brdf::Rgbd eval(const gonio::brdf::Vec3d& wi,
                           const gonio::brdf::Vec3d& wo) const override {
        if (wi.z() <= 0 || wo.z() <= 0) {
            return gonio::brdf::Rgbd::Zero();
        }
        return gonio::brdf::Rgbd::Constant(0.8 / M_PI);
    }
    bool isotropic() const override { return true; }
    std::string describe() const override { return "white 0.8"; }
};

gonio::sim::SceneState scene() {
    return gonio::sim::scene_from_angles(0.5, 0, 0.3, M_PI, 1.0);
}

double process_cpu_s() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// CPU time (user + system, s, at the kernel's tick resolution) of this process's threads that
/// receive frames as a lab host would: the main thread (pops buffers) and Aravis's threads (named
/// "arv..."). Everything else in the process is the simulated camera.
double client_threads_cpu_s() {
    const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
    const std::string self = std::to_string(getpid());
    double total = 0;
    DIR* d = opendir("/proc/self/task");
    if (d == nullptr) {
        return 0;
    }
    while (const dirent* e = readdir(d)) {
        const std::string tid = e->d_name;
        if (tid == "." || tid == "..") {
            continue;
        }
        std::ifstream in("/proc/self/task/" + tid + "/stat");
        std::string line;
        std::getline(in, line);
        // pid (comm) state ... : the name is between the first '(' and the last ')'.
        const auto open = line.find('('), close = line.rfind(')');
        if (open == std::string::npos || close == std::string::npos) {
            continue;
        }
        const std::string comm = line.substr(open + 1, close - open - 1);
        if (tid != self && comm.rfind("arv", 0) != 0) {
            continue;
        }
        std::istringstream rest(line.substr(close + 2));
        std::string field;
        double utime = 0, stime = 0;
        // Fields 3.. of proc(5): utime is field 14, stime field 15.
        for (int i = 3; i <= 15 && rest >> field; ++i) {
            if (i == 14) {
                utime = std::stod(field);
            } else if (i == 15) {
                stime = std::stod(field);
            }
        }
        total += (utime + stime) / tick;
    }
    closedir(d);
    return total;
}

// The whole chain of a lab camera: the simulated GigE Vision camera renders and streams GVSP on a
// loopback address of its own (127.x.y.z: no lock on 127.0.0.1:3956), Aravis (in the same
// process) receives, reassembles and resends. The argument is AcquisitionFrameRate (Hz): 200 so
// the camera is never the pacer (the chain's ceiling), 10 for the campaign's aim. Frames/s is wall
// time; cpu_ms_per_frame is the process CPU per frame, split into the camera's (render, payload,
// GVSP send) and the host's (Aravis receive and reassembly, the main thread); frames_lost counts
// frames Aravis reported incomplete or never delivered, frame_id_gaps frames missing between
// delivered frame ids.
void BM_Stream5MpMono16Gige(benchmark::State& state) {
    gonio::sim::GigeCameraConfig c;
    c.sensor.width = kW;
    c.sensor.height = kH;
    c.sensor.seed = 11;
    const auto sc = scene();
    auto camera = std::make_shared<gonio::sim::GigeCamera>(
        c, std::make_shared<WhiteBrdf>(), [sc] { return sc; });
    gonio::sim::GigeServer server(camera);
    if (!server.start_on_free_loopback()) {
        state.SkipWithError("GigE server: no free loopback address");
        return;
    }
    const std::string ip = server.address().substr(std::string("gige://").size());
    GError* err = nullptr;
    ArvCamera* cam = arv_camera_new(ip.c_str(), &err);
    if (cam == nullptr) {
        state.SkipWithError(("Aravis could not open " + ip).c_str());
        g_clear_error(&err);
        return;
    }
    arv_camera_set_pixel_format(cam, ARV_PIXEL_FORMAT_MONO_16, &err);
    arv_camera_set_exposure_time(cam, kExposureUs, &err);
    arv_device_set_float_feature_value(arv_camera_get_device(cam),
                                       "AcquisitionFrameRate",
                                       static_cast<double>(state.range(0)),
                                       &err);
    ArvStream* stream = arv_camera_create_stream(cam, nullptr, nullptr, &err);
    const guint payload = arv_camera_get_payload(cam, &err);
    if (err != nullptr || stream == nullptr) {
        state.SkipWithError("Aravis stream setup failed");
        g_clear_error(&err);
        g_object_unref(cam);
        return;
    }
    for (int i = 0; i < 8; ++i) {
        arv_stream_push_buffer(stream, arv_buffer_new(payload, nullptr));
    }
    arv_camera_start_acquisition(cam, &err);
    gonio::sim::SensorModel model(gonio::sim::SensorParams{kW, kH});
    const double expected = model.mean_counts(
        0.8 / M_PI * std::cos(0.5), {kExposureUs, 1, gonio::devices::PixelFormat::kMono16});
    const double black = model.black_level(gonio::devices::PixelFormat::kMono16);
    double err_rel = 0;
    std::int64_t lost = 0, gaps = 0;
    guint64 last_id = 0;
    bool have_id = false;
    const double cpu0 = process_cpu_s();
    const double client0 = client_threads_cpu_s();
    for (auto _ : state) {
        ArvBuffer* b = arv_stream_timeout_pop_buffer(stream, 10000000);
        if (b == nullptr) {
            ++lost;
            continue;
        }
        if (arv_buffer_get_status(b) != ARV_BUFFER_STATUS_SUCCESS) {
            ++lost;
        } else {
            // GVSP block ids count 1..65535 and wrap to 1.
            const guint64 id = arv_buffer_get_frame_id(b);
            if (have_id && id > last_id + 1) {
                gaps += static_cast<std::int64_t>(id - last_id - 1);
            }
            last_id = id;
            have_id = true;
            std::size_t size = 0;
            const auto* px = static_cast<const std::uint16_t*>(arv_buffer_get_data(b, &size));
            double sum = 0;
            long n = 0;
            for (int y = kH / 2 - 50; y < kH / 2 + 50; ++y) {
                for (int x = kW / 2 - 50; x < kW / 2 + 50; ++x) {
                    sum += px[static_cast<std::size_t>(y) * kW + x];
                    ++n;
                }
            }
            err_rel = std::abs(sum / n - expected) / (expected - black);
        }
        arv_stream_push_buffer(stream, b);
    }
    const double cpu = process_cpu_s() - cpu0;
    const double client = client_threads_cpu_s() - client0;
    arv_camera_stop_acquisition(cam, nullptr);
    guint64 completed = 0, failures = 0, underruns = 0;
    arv_stream_get_statistics(stream, &completed, &failures, &underruns);
    g_object_unref(stream);
    g_object_unref(cam);
    server.stop();
    const double bytes = static_cast<double>(kW) * kH * 2;
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
    state.counters["fps"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    const double frames = static_cast<double>(state.iterations());
    state.counters["cpu_ms_per_frame"] = 1e3 * cpu / frames;
    state.counters["camera_cpu_ms"] = 1e3 * (cpu - client) / frames;
    state.counters["host_cpu_ms"] = 1e3 * client / frames;
    state.counters["frames_lost"] = static_cast<double>(lost);
    state.counters["frame_id_gaps"] = static_cast<double>(gaps);
    state.counters["arv_underruns"] = static_cast<double>(underruns);
    const auto st = server.stats();
    state.counters["resent_packets"] = static_cast<double>(st.packets_resent);
    state.counters["packets_per_frame"] =
        st.frames_sent > 0 ? static_cast<double>(st.packets_sent) / st.frames_sent : 0.0;
    state.counters["patch_rel_err"] = err_rel;
}
BENCHMARK(BM_Stream5MpMono16Gige)
    ->ArgName("fps_set")
    ->Arg(200)
    ->Arg(10)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_RenderPointFrame5Mp(benchmark::State& state) {
    WhiteBrdf f;
    gonio::sim::SensorModel model(gonio::sim::SensorParams{kW, kH});
    const gonio::sim::ExposureSettings e{kExposureUs, 1, gonio::devices::PixelFormat::kMono16};
    double err = 0, radiance_cpu = 0;
    const double cpu0 = process_cpu_s();
    for (auto _ : state) {
        const double r0 = process_cpu_s();
        const cv::Mat L = gonio::sim::render_scene(f, scene(), kW, kH, {0, 0, kW, kH});
        radiance_cpu += process_cpu_s() - r0;
        const cv::Mat c = model.expose(L, e);
        benchmark::DoNotOptimize(c.data);
        const double centre = cv::mean(c(cv::Rect(kW / 2 - 50, kH / 2 - 50, 100, 100)))[0];
        const double expected = model.mean_counts(0.8 / M_PI * std::cos(0.5), e);
        err = std::abs(centre - expected) / (expected - model.black_level(e.format));
    }
    const double frames = static_cast<double>(state.iterations());
    const double cpu = process_cpu_s() - cpu0;
    state.counters["cpu_ms_per_frame"] = 1e3 * cpu / frames;
    state.counters["radiance_cpu_ms"] = 1e3 * radiance_cpu / frames;
    state.counters["noise_cpu_ms"] = 1e3 * (cpu - radiance_cpu) / frames;
    state.counters["patch_rel_err"] = err;
}
BENCHMARK(BM_RenderPointFrame5Mp)->Unit(benchmark::kMillisecond);

void BM_RenderSphereFrame1Mp(benchmark::State& state) {
    WhiteBrdf f;
    auto s = scene();
    s.shape = gonio::sim::SampleShape::kSphere;
    s.wi = {0, 0, 1};
    s.wo = {0, 0, 1};
    double err = 0;
    for (auto _ : state) {
        const cv::Mat L = gonio::sim::render_scene(f, s, 1024, 1024, {0, 0, 1024, 1024});
        benchmark::DoNotOptimize(L.data);
        // Sphere centre faces light and camera: L = f E exactly.
        err = std::abs(L.at<float>(512, 512) - 0.8 / M_PI) / (0.8 / M_PI);
    }
    state.counters["centre_rel_err"] = err;
}
BENCHMARK(BM_RenderSphereFrame1Mp)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
