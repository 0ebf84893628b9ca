// Simulated camera throughput: a 5-megapixel (2448 x 2048) Mono16 stream through the in-process
// and the TCP transports, and the render time per frame (radiance + sensor noise).
// Each benchmark reports, next to its time, the relative error of the frame's patch mean against
// the radiometric chain's closed form (docs/camera.md).

#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "gonio/devices/camera_factory.h"
#include "gonio/devices/u3v_camera.h"
#include "gonio/sim/camera_render.h"
#include "gonio/sim/sensor_model.h"
#include "gonio/sim/u3v_device.h"
#include "gonio/sim/u3v_tcp_server.h"

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

std::shared_ptr<gonio::sim::U3vDevice> device() {
    gonio::sim::U3vDeviceConfig c;
    c.sensor.width = kW;
    c.sensor.height = kH;
    c.sensor.seed = 11;
    const auto s = scene();
    return std::make_shared<gonio::sim::U3vDevice>(
        c, std::make_shared<WhiteBrdf>(), [s] { return s; });
}

double patch_relative_error(const gonio::devices::Frame& f, const gonio::sim::SensorModel& m) {
    double sum = 0;
    long n = 0;
    for (int y = 0; y < f.image.rows; y += 4) {
        for (int x = 0; x < f.image.cols; x += 4) {
            if (gonio::sim::in_point_patch(x + 0.5, y + 0.5, kW, kH)) {
                sum += f.image.at<std::uint16_t>(y, x);
                ++n;
            }
        }
    }
    const double L = 0.8 / M_PI * std::cos(0.5);
    const double expected =
        m.mean_counts(L, {kExposureUs, 1, gonio::devices::PixelFormat::kMono16});
    return std::abs(sum / n - expected) / (expected - f.black_level);
}

void stream(benchmark::State& state, gonio::devices::Camera& cam) {
    if (!cam.set_exposure_us(kExposureUs) || !cam.start_stream()) {
        state.SkipWithError("stream setup failed");
        return;
    }
    gonio::sim::SensorModel model(gonio::sim::SensorParams{kW, kH});
    double err = 0;
    for (auto _ : state) {
        auto f = cam.next_frame(10000ms);
        if (!f) {
            state.SkipWithError(f.error().message.c_str());
            break;
        }
        err = patch_relative_error(*f, model);
        benchmark::DoNotOptimize(f->image.data);
    }
    (void)cam.stop_stream();
    const double bytes = static_cast<double>(kW) * kH * 2;
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
    state.counters["fps"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["patch_rel_err"] = err;
}

void BM_Stream5MpMono16InProcess(benchmark::State& state) {
    auto cam = gonio::devices::U3vCamera::open(gonio::sim::make_memory_transport(device()));
    if (!cam) {
        state.SkipWithError(cam.error().message.c_str());
        return;
    }
    stream(state, **cam);
}
BENCHMARK(BM_Stream5MpMono16InProcess)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Stream5MpMono16Tcp(benchmark::State& state) {
    gonio::sim::U3vTcpServer server(device());
    if (!server.start(0)) {
        state.SkipWithError("server start failed");
        return;
    }
    auto cam = gonio::devices::open_camera(server.address());
    if (!cam) {
        state.SkipWithError(cam.error().message.c_str());
        return;
    }
    stream(state, **cam);
}
BENCHMARK(BM_Stream5MpMono16Tcp)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RenderPointFrame5Mp(benchmark::State& state) {
    WhiteBrdf f;
    gonio::sim::SensorModel model(gonio::sim::SensorParams{kW, kH});
    const gonio::sim::ExposureSettings e{kExposureUs, 1, gonio::devices::PixelFormat::kMono16};
    double err = 0;
    for (auto _ : state) {
        const cv::Mat L = gonio::sim::render_scene(f, scene(), kW, kH, {0, 0, kW, kH});
        const cv::Mat c = model.expose(L, e);
        benchmark::DoNotOptimize(c.data);
        const double centre = cv::mean(c(cv::Rect(kW / 2 - 50, kH / 2 - 50, 100, 100)))[0];
        const double expected = model.mean_counts(0.8 / M_PI * std::cos(0.5), e);
        err = std::abs(centre - expected) / (expected - model.black_level(e.format));
    }
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
