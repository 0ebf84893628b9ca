// GenCP prefix and SCD codecs (GenICam GenCP 1.x; USB3 Vision 1.x control channel).

#include "gonio/devices/gencp.h"

#include <cstdio>

#include "gonio/devices/u3v_bootstrap.h"

namespace gonio::devices::gencp {

using u3v::get_u16;
using u3v::get_u32;
using u3v::get_u64;
using u3v::put_u16;
using u3v::put_u32;
using u3v::put_u64;

namespace {

std::string hex(unsigned v, int width) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "0x%0*X", width, v);
    return buf;
}

std::vector<std::uint8_t> encode_prefix(std::uint16_t word,
                                        std::uint16_t id,
                                        std::uint16_t request_id,
                                        const std::vector<std::uint8_t>& scd) {
    std::vector<std::uint8_t> out;
    out.reserve(kPrefixSize + scd.size());
    put_u32(out, kMagic);
    put_u16(out, word);
    put_u16(out, id);
    put_u16(out, static_cast<std::uint16_t>(scd.size()));
    put_u16(out, request_id);
    out.insert(out.end(), scd.begin(), scd.end());
    return out;
}

struct Prefix {
    std::uint16_t word, id, length, request_id;
};

Expected<Prefix> decode_prefix(const std::uint8_t* data, std::size_t size, const char* what) {
    if (data == nullptr || size < kPrefixSize) {
        return make_error(std::string("GenCP ") + what + ": " + std::to_string(size) +
                          " bytes, shorter than the 12-byte prefix");
    }
    const std::uint32_t magic = get_u32(data);
    if (magic != kMagic) {
        return make_error(std::string("GenCP ") + what + ": magic " + hex(magic, 8) +
                          " != 0x43563355 (U3VC)");
    }
    Prefix p{get_u16(data + 4), get_u16(data + 6), get_u16(data + 8), get_u16(data + 10)};
    if (kPrefixSize + p.length > size) {
        return make_error(std::string("GenCP ") + what + ": scd_length " +
                          std::to_string(p.length) + " exceeds the " +
                          std::to_string(size - kPrefixSize) + " bytes received");
    }
    return p;
}

}  // namespace

std::string to_string(Status s) {
    switch (s) {
        case Status::kSuccess:
            return "GENCP_SUCCESS";
        case Status::kNotImplemented:
            return "GENCP_NOT_IMPLEMENTED";
        case Status::kInvalidParameter:
            return "GENCP_INVALID_PARAMETER";
        case Status::kInvalidAddress:
            return "GENCP_INVALID_ADDRESS";
        case Status::kWriteProtect:
            return "GENCP_WRITE_PROTECT";
        case Status::kBadAlignment:
            return "GENCP_BAD_ALIGNMENT";
        case Status::kAccessDenied:
            return "GENCP_ACCESS_DENIED";
        case Status::kBusy:
            return "GENCP_BUSY";
        case Status::kMsgTimeout:
            return "GENCP_MSG_TIMEOUT";
        case Status::kInvalidHeader:
            return "GENCP_INVALID_HEADER";
        case Status::kWrongConfig:
            return "GENCP_WRONG_CONFIG";
        case Status::kGenericError:
            return "GENCP_GENERIC_ERROR";
    }
    return "status " + hex(static_cast<unsigned>(s), 4);
}

std::vector<std::uint8_t> encode(const Command& c) {
    return encode_prefix(c.flags, static_cast<std::uint16_t>(c.id), c.request_id, c.scd);
}

std::vector<std::uint8_t> encode(const Ack& a) {
    return encode_prefix(static_cast<std::uint16_t>(a.status),
                         static_cast<std::uint16_t>(a.id),
                         a.request_id,
                         a.scd);
}

Expected<Command> decode_command(const std::uint8_t* data, std::size_t size) {
    auto p = decode_prefix(data, size, "command");
    if (!p) {
        return tl::unexpected(p.error());
    }
    // Commands have even identifiers; odd ones are acknowledges.
    if (p->id & 1u) {
        return make_error("GenCP command: command_id " + hex(p->id, 4) +
                          " is odd (an acknowledge id)");
    }
    Command c;
    c.flags = p->word;
    c.id = static_cast<CommandId>(p->id);
    c.request_id = p->request_id;
    c.scd.assign(data + kPrefixSize, data + kPrefixSize + p->length);
    return c;
}

Expected<Ack> decode_ack(const std::uint8_t* data, std::size_t size) {
    auto p = decode_prefix(data, size, "acknowledge");
    if (!p) {
        return tl::unexpected(p.error());
    }
    if ((p->id & 1u) == 0) {
        return make_error("GenCP acknowledge: command_id " + hex(p->id, 4) +
                          " is even (a command id)");
    }
    Ack a;
    a.status = static_cast<Status>(p->word);
    a.id = static_cast<CommandId>(p->id);
    a.request_id = p->request_id;
    a.scd.assign(data + kPrefixSize, data + kPrefixSize + p->length);
    return a;
}

Command make_read_mem(std::uint16_t request_id, std::uint64_t address, std::uint16_t length) {
    Command c;
    c.id = CommandId::kReadMemCmd;
    c.request_id = request_id;
    put_u64(c.scd, address);
    put_u16(c.scd, 0);
    put_u16(c.scd, length);
    return c;
}

Command make_write_mem(std::uint16_t request_id,
                       std::uint64_t address,
                       const std::vector<std::uint8_t>& data) {
    Command c;
    c.id = CommandId::kWriteMemCmd;
    c.request_id = request_id;
    put_u64(c.scd, address);
    c.scd.insert(c.scd.end(), data.begin(), data.end());
    return c;
}

Expected<ReadMemRequest> parse_read_mem(const Command& c) {
    if (c.id != CommandId::kReadMemCmd || c.scd.size() != 12) {
        return make_error("GenCP READMEM_CMD: SCD of " + std::to_string(c.scd.size()) +
                          " bytes, expected 12 (address u64, reserved u16, length u16)");
    }
    return ReadMemRequest{get_u64(c.scd.data()), get_u16(c.scd.data() + 10)};
}

Expected<WriteMemRequest> parse_write_mem(const Command& c) {
    if (c.id != CommandId::kWriteMemCmd || c.scd.size() < 8) {
        return make_error("GenCP WRITEMEM_CMD: SCD of " + std::to_string(c.scd.size()) +
                          " bytes, expected at least 8 (address u64, data)");
    }
    WriteMemRequest w;
    w.address = get_u64(c.scd.data());
    w.data.assign(c.scd.begin() + 8, c.scd.end());
    return w;
}

Ack make_read_mem_ack(std::uint16_t request_id, Status s, std::vector<std::uint8_t> data) {
    Ack a;
    a.status = s;
    a.id = CommandId::kReadMemAck;
    a.request_id = request_id;
    a.scd = std::move(data);
    return a;
}

Ack make_write_mem_ack(std::uint16_t request_id, Status s, std::uint16_t length_written) {
    Ack a;
    a.status = s;
    a.id = CommandId::kWriteMemAck;
    a.request_id = request_id;
    put_u16(a.scd, 0);
    put_u16(a.scd, length_written);
    return a;
}

Ack make_pending_ack(std::uint16_t request_id, std::uint16_t timeout_ms) {
    Ack a;
    a.status = Status::kSuccess;
    a.id = CommandId::kPendingAck;
    a.request_id = request_id;
    put_u16(a.scd, 0);
    put_u16(a.scd, timeout_ms);
    return a;
}

Expected<std::uint16_t> parse_write_mem_ack(const Ack& a) {
    // A device may omit the SCD of a successful WRITEMEM_ACK (GenCP allows length 0).
    if (a.scd.empty()) {
        return std::uint16_t{0};
    }
    if (a.scd.size() != 4) {
        return make_error("GenCP WRITEMEM_ACK: SCD of " + std::to_string(a.scd.size()) +
                          " bytes, expected 4 (reserved u16, length_written u16)");
    }
    return get_u16(a.scd.data() + 2);
}

Expected<std::uint16_t> parse_pending_ack(const Ack& a) {
    if (a.scd.size() != 4) {
        return make_error("GenCP PENDING_ACK: SCD of " + std::to_string(a.scd.size()) +
                          " bytes, expected 4 (reserved u16, timeout_ms u16)");
    }
    return get_u16(a.scd.data() + 2);
}

}  // namespace gonio::devices::gencp
