// Host-side decoding of camera frames: PFNC/GigE Vision pixel formats into 16-bit counts, for a
// 5 MP frame (2448 x 2048), the size the simulated camera streams at 10 frames/s. Reports the
// frames/s and MB/s one core decodes, and the number of decoded pixels that differ from the values
// packed (the error column: 0 when the unpacking is exact).

#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "gonio/devices/packed_pixels.h"

namespace {

using gonio::devices::find_pixel_format;
using gonio::devices::PixelLayout;

constexpr int kWidth = 2448;
constexpr int kHeight = 2048;

// Packs values into a format's layout, written from the specifications independently of the
// decoder (bit by bit, LSB first, or the GigE 3-byte groups).
std::vector<std::uint8_t> pack(const std::vector<std::uint16_t>& v, PixelLayout layout) {
    std::vector<std::uint8_t> out;
    switch (layout) {
        case PixelLayout::kU8:
            for (auto p : v) {
                out.push_back(static_cast<std::uint8_t>(p));
            }
            break;
        case PixelLayout::kU16Le:
            for (auto p : v) {
                out.push_back(static_cast<std::uint8_t>(p & 0xFF));
                out.push_back(static_cast<std::uint8_t>(p >> 8));
            }
            break;
        case PixelLayout::kGigePacked10:
        case PixelLayout::kGigePacked12: {
            const int low = layout == PixelLayout::kGigePacked12 ? 4 : 2;
            for (std::size_t i = 0; i + 1 < v.size(); i += 2) {
                out.push_back(static_cast<std::uint8_t>(v[i] >> low));
                out.push_back(static_cast<std::uint8_t>((v[i] & ((1 << low) - 1)) |
                                                        ((v[i + 1] & ((1 << low) - 1)) << 4)));
                out.push_back(static_cast<std::uint8_t>(v[i + 1] >> low));
            }
            break;
        }
        case PixelLayout::kLsbPacked10:
        case PixelLayout::kLsbPacked12: {
            const int b = layout == PixelLayout::kLsbPacked12 ? 12 : 10;
            out.assign((v.size() * b + 7) / 8, 0);
            std::size_t bit = 0;
            for (auto p : v) {
                for (int k = 0; k < b; ++k, ++bit) {
                    if ((p >> k) & 1) {
                        out[bit / 8] = static_cast<std::uint8_t>(out[bit / 8] | (1u << (bit % 8)));
                    }
                }
            }
            break;
        }
    }
    return out;
}

void BM_Unpack(benchmark::State& state, const char* name) {
    const auto format = *find_pixel_format(name);
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> dist(0, (1 << format.bits) - 1);
    std::vector<std::uint16_t> values(static_cast<std::size_t>(kWidth) * kHeight);
    for (auto& v : values) {
        v = static_cast<std::uint16_t>(dist(rng));
    }
    const auto bytes = pack(values, format.layout);
    cv::Mat last;
    for (auto _ : state) {
        auto m = gonio::devices::unpack_pixels(bytes.data(), bytes.size(), format, kWidth, kHeight);
        benchmark::DoNotOptimize(m->data);
        last = std::move(*m);
    }
    std::int64_t wrong = 0;
    for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
            wrong +=
                last.at<std::uint16_t>(y, x) != values[static_cast<std::size_t>(y) * kWidth + x];
        }
    }
    state.counters["frames_per_s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["MB_per_s"] = benchmark::Counter(
        static_cast<double>(state.iterations()) * static_cast<double>(bytes.size()) / 1e6,
        benchmark::Counter::kIsRate);
    state.counters["wrong_pixels"] = static_cast<double>(wrong);
}

BENCHMARK_CAPTURE(BM_Unpack, Mono8, "Mono8")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Unpack, Mono16, "Mono16")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Unpack, Mono12Packed, "Mono12Packed")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Unpack, Mono12p, "Mono12p")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Unpack, Mono10p, "Mono10p")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
