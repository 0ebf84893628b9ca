// Fuzz target for the GigE Vision control channel as the simulated camera receives it: any UDP
// datagram on port 3956 is fed to sim::GigeCamera::handle_gvcp, as if from a host that first took
// control. Properties: no crash, no sanitizer finding; an acknowledge is sent only for a datagram
// with a GVCP command header, is well formed (parse_ack accepts it) and carries the command's
// request id; the client-side acknowledge parser survives the same bytes.

#include <cstddef>
#include <cstdint>
#include <memory>

#include "fuzz_support.h"
#include "gonio/devices/gvcp.h"
#include "gonio/sim/gige_camera.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    namespace gvcp = gonio::devices::gvcp;
    namespace sim = gonio::sim;
    static auto camera = [] {
        sim::GigeCameraConfig cfg;
        cfg.sensor.width = 64;
        cfg.sensor.height = 48;
        return std::make_shared<sim::GigeCamera>(cfg, nullptr, sim::SceneFn());
    }();
    const sim::HostId host{0x7F000001u, 50000};
    const auto now = sim::GigeCamera::Clock::now();
    // Take control (CCP = 0x0A00, exclusive access) so that writes reach the registers.
    const gvcp::Bytes take = gvcp::encode(gvcp::make_write_reg(1, {{0x0A00, 1}}));
    (void)camera->handle_gvcp(take.data(), take.size(), host, now);
    std::optional<gvcp::PacketResend> resend;
    const auto ack = camera->handle_gvcp(data, size, host, now, &resend);
    if (ack) {
        auto parsed = gvcp::parse_ack(ack->data(), ack->size());
        gonio::fuzz::require(parsed.has_value(), "gvcp", "the camera's acknowledge parses");
        gonio::fuzz::require(size >= gvcp::kHeaderSize && data[0] == gvcp::kKey,
                             "gvcp",
                             "only a datagram with a GVCP command header is answered");
        gonio::fuzz::require(parsed->ack_id == gvcp::get_u16(data + 6),
                             "gvcp",
                             "the acknowledge carries the request id");
    }
    (void)gvcp::parse_ack(data, size);
    // Release control again so that every input starts from the same state.
    const gvcp::Bytes release = gvcp::encode(gvcp::make_write_reg(2, {{0x0A00, 0}}));
    (void)camera->handle_gvcp(release.data(), release.size(), host, now);
    return 0;
}
