// Fuzz target for the Modbus wire codec (devices/modbus_codec.h) and the simulated controllers'
// register logic (sim/motor_registers.h) behind it. The first byte chooses how the rest is read:
// even, a Modbus TCP byte stream (MBAP frames); odd, an RTU byte stream (frames found by their
// function's layout and CRC, as the RTU server does). Every frame goes to a fresh set of units: an
// Oriental Motor AZ drive (unit 1) and a shutter coil (unit 3).
// Properties: no crash, no sanitizer finding; every answer is a PDU of at most 253 bytes that the
// client-side parser accepts as the answer to the request (an exception for a request the codec
// refuses, with the refusal's code); a request that parses encodes to a PDU of the same size that
// parses to the same request; the stream framers consume at least one byte per frame and never
// more than they were given.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_support.h"
#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_codec.h"
#include "gonio/sim/motor_registers.h"

namespace {

namespace mb = gonio::devices::modbus;
using Bytes = std::vector<std::uint8_t>;

void require(bool ok, const char* what, const std::string& detail = "") {
    gonio::fuzz::require(ok, "modbus", what, detail);
}

std::string hex(const Bytes& b) {
    static const char* digits = "0123456789ABCDEF";
    std::string s;
    for (std::size_t i = 0; i < b.size() && i < 64; ++i) {
        s += digits[b[i] >> 4];
        s += digits[b[i] & 0xF];
        s += ' ';
    }
    return s;
}

const gonio::devices::AxisProfile& profile() {
    static const gonio::devices::AxisProfile p = [] {
        auto loaded = gonio::devices::load_axis_profile("oriental-az");
        require(static_cast<bool>(loaded),
                "the oriental-az profile loads:",
                loaded ? "" : loaded.error().message);
        return *loaded;
    }();
    return p;
}

/// The codec's own properties on one request PDU.
void check_request_codec(const Bytes& pdu) {
    auto r = mb::parse_request(pdu.data(), pdu.size());
    if (!r) {
        require(!r.error().message.empty(), "a refusal says why");
        return;
    }
    require(static_cast<std::uint32_t>(r->address) + r->quantity <= mb::kAddressSpace,
            "an accepted range fits the address space");
    const Bytes again = mb::encode_request(*r);
    require(again.size() == pdu.size(), "encode(parse(x)) has x's size:", hex(pdu));
    auto back = mb::parse_request(again.data(), again.size());
    require(back.has_value(), "encode(parse(x)) parses:", hex(again));
    require(mb::encode_request(*back) == again, "the encoding is stable:", hex(again));
}

/// The register logic's answer to one request, checked against the request.
void serve(gonio::sim::MotorRegisters& regs, int unit, const Bytes& pdu, bool serial) {
    check_request_codec(pdu);
    const gonio::sim::Reply a = regs.process(unit, pdu, serial);
    if (a.kind != gonio::sim::Reply::Kind::kSend) {
        return;
    }
    require(!a.pdu.empty() && a.pdu.size() <= mb::kMaxPduSize, "answer size in [1, 253]");
    const std::uint8_t fc = pdu.empty() ? 0 : pdu[0];
    require((a.pdu[0] & 0x7F) == (fc & 0x7F), "the answer carries the request's function");
    auto r = mb::parse_request(pdu.data(), pdu.size());
    if (!r) {
        // Refused by the codec: an exception (2 bytes) with the refusal's code, or an injected
        // exception.
        require(a.pdu.size() == 2 && (a.pdu[0] & mb::kExceptionBit) != 0,
                "a malformed request gets an exception:",
                hex(pdu) + "-> " + hex(a.pdu));
        return;
    }
    auto resp = mb::parse_response(*r, a.pdu.data(), a.pdu.size());
    require(resp.has_value(),
            "the answer parses as the answer to the request:",
            hex(pdu) + "-> " + hex(a.pdu) + (resp ? "" : resp.error().message));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1 || size > 4096) {
        return 0;
    }
    gonio::sim::MotorRegisters regs;
    gonio::sim::MotorSimConfig cfg;
    cfg.start_homed = true;
    cfg.time_scale = 1000;  // moves end within the input's run
    require(static_cast<bool>(regs.add_unit(1, profile(), cfg)), "unit 1 is added");
    require(static_cast<bool>(regs.add_shutter(3, 0)), "shutter unit 3 is added");
    const bool rtu = (data[0] & 1U) != 0;
    const std::uint8_t* p = data + 1;
    std::size_t left = size - 1;
    while (left > 0) {
        if (!rtu) {
            const mb::TcpFrame f = mb::next_tcp_frame(p, left);
            if (f.status != mb::TcpFrame::Status::kFrame) {
                require(f.status == mb::TcpFrame::Status::kIncomplete || !f.error.empty(),
                        "a broken stream says why");
                break;
            }
            require(f.consumed >= mb::kMbapSize + 1 && f.consumed <= left, "frame within input");
            require(f.pdu.size() + 1 == f.header.length, "PDU length from the MBAP length");
            serve(regs, f.header.unit_id, f.pdu, false);
            p += f.consumed;
            left -= f.consumed;
        } else {
            const std::size_t n = mb::rtu_request_length(p, left);
            if (n == 0 || n > left) {
                break;
            }
            auto frame = mb::parse_rtu_adu(p, n);
            if (frame) {
                require(mb::encode_rtu_adu(frame->unit_id, frame->pdu) == Bytes(p, p + n),
                        "an RTU frame encodes back to its bytes");
                serve(regs, frame->unit_id, frame->pdu, true);
            }
            p += n;
            left -= n;
        }
    }
    // The codec alone on the whole input as one PDU.
    check_request_codec(Bytes(data + 1, data + size));
    return 0;
}
