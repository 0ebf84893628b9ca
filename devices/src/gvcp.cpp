// GVCP codecs (GigE Vision 2.x, ch. 15) and the first-URL parser (ch. 28.3).

#include "gonio/devices/gvcp.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>

namespace gonio::devices::gvcp {

namespace {

std::string hex4(unsigned v) {
    char b[16];
    std::snprintf(b, sizeof b, "0x%04X", v);
    return b;
}

Bytes header_and(std::size_t data_size) {
    return Bytes(kHeaderSize + data_size, 0);
}

}  // namespace

void put_u16(std::uint8_t* p, std::uint16_t v) {
    p[0] = static_cast<std::uint8_t>(v >> 8);
    p[1] = static_cast<std::uint8_t>(v);
}

void put_u32(std::uint8_t* p, std::uint32_t v) {
    p[0] = static_cast<std::uint8_t>(v >> 24);
    p[1] = static_cast<std::uint8_t>(v >> 16);
    p[2] = static_cast<std::uint8_t>(v >> 8);
    p[3] = static_cast<std::uint8_t>(v);
}

std::uint16_t get_u16(const std::uint8_t* p) {
    return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

std::uint32_t get_u32(const std::uint8_t* p) {
    return (static_cast<std::uint32_t>(p[0]) << 24) | (static_cast<std::uint32_t>(p[1]) << 16) |
           (static_cast<std::uint32_t>(p[2]) << 8) | p[3];
}

std::string to_string(Status s) {
    switch (s) {
        case Status::kSuccess:
            return "GEV_STATUS_SUCCESS";
        case Status::kNotImplemented:
            return "GEV_STATUS_NOT_IMPLEMENTED";
        case Status::kInvalidParameter:
            return "GEV_STATUS_INVALID_PARAMETER";
        case Status::kInvalidAddress:
            return "GEV_STATUS_INVALID_ADDRESS";
        case Status::kWriteProtect:
            return "GEV_STATUS_WRITE_PROTECT";
        case Status::kBadAlignment:
            return "GEV_STATUS_BAD_ALIGNMENT";
        case Status::kAccessDenied:
            return "GEV_STATUS_ACCESS_DENIED";
        case Status::kBusy:
            return "GEV_STATUS_BUSY";
        case Status::kPacketUnavailable:
            return "GEV_STATUS_PACKET_UNAVAILABLE";
        case Status::kInvalidHeader:
            return "GEV_STATUS_INVALID_HEADER";
        case Status::kError:
            return "GEV_STATUS_ERROR";
    }
    return "status " + hex4(static_cast<unsigned>(s));
}

std::string to_string(Command c) {
    switch (c) {
        case Command::kDiscoveryCmd:
            return "DISCOVERY_CMD";
        case Command::kDiscoveryAck:
            return "DISCOVERY_ACK";
        case Command::kPacketResendCmd:
            return "PACKETRESEND_CMD";
        case Command::kReadRegCmd:
            return "READREG_CMD";
        case Command::kReadRegAck:
            return "READREG_ACK";
        case Command::kWriteRegCmd:
            return "WRITEREG_CMD";
        case Command::kWriteRegAck:
            return "WRITEREG_ACK";
        case Command::kReadMemCmd:
            return "READMEM_CMD";
        case Command::kReadMemAck:
            return "READMEM_ACK";
        case Command::kWriteMemCmd:
            return "WRITEMEM_CMD";
        case Command::kWriteMemAck:
            return "WRITEMEM_ACK";
        case Command::kPendingAck:
            return "PENDING_ACK";
    }
    return "command " + hex4(static_cast<unsigned>(c));
}

Bytes encode(const CommandPacket& c) {
    Bytes b = header_and(c.data.size());
    b[0] = kKey;
    b[1] = c.flags;
    put_u16(&b[2], static_cast<std::uint16_t>(c.command));
    put_u16(&b[4], static_cast<std::uint16_t>(c.data.size()));
    put_u16(&b[6], c.req_id);
    std::copy(c.data.begin(), c.data.end(), b.begin() + kHeaderSize);
    return b;
}

Bytes encode(const AckPacket& a) {
    Bytes b = header_and(a.data.size());
    put_u16(&b[0], static_cast<std::uint16_t>(a.status));
    put_u16(&b[2], static_cast<std::uint16_t>(a.answer));
    put_u16(&b[4], static_cast<std::uint16_t>(a.data.size()));
    put_u16(&b[6], a.ack_id);
    std::copy(a.data.begin(), a.data.end(), b.begin() + kHeaderSize);
    return b;
}

Expected<CommandPacket> parse_command(const std::uint8_t* bytes, std::size_t size) {
    if (size < kHeaderSize) {
        return make_error("GVCP command: " + std::to_string(size) + " bytes, the header needs " +
                          std::to_string(kHeaderSize));
    }
    if (bytes[0] != kKey) {
        return make_error("GVCP command: key byte " + hex4(bytes[0]) + ", must be 0x42");
    }
    CommandPacket c;
    c.flags = bytes[1];
    c.command = static_cast<Command>(get_u16(bytes + 2));
    const std::uint16_t length = get_u16(bytes + 4);
    c.req_id = get_u16(bytes + 6);
    if (kHeaderSize + length > size) {
        return make_error("GVCP " + to_string(c.command) + ": length field " +
                          std::to_string(length) + " exceeds the " +
                          std::to_string(size - kHeaderSize) + " data bytes received");
    }
    c.data.assign(bytes + kHeaderSize, bytes + kHeaderSize + length);
    return c;
}

Expected<AckPacket> parse_ack(const std::uint8_t* bytes, std::size_t size) {
    if (size < kHeaderSize) {
        return make_error("GVCP acknowledge: " + std::to_string(size) +
                          " bytes, the header needs " + std::to_string(kHeaderSize));
    }
    AckPacket a;
    a.status = static_cast<Status>(get_u16(bytes));
    a.answer = static_cast<Command>(get_u16(bytes + 2));
    const std::uint16_t length = get_u16(bytes + 4);
    a.ack_id = get_u16(bytes + 6);
    if (kHeaderSize + length > size) {
        return make_error("GVCP " + to_string(a.answer) + ": length field " +
                          std::to_string(length) + " exceeds the " +
                          std::to_string(size - kHeaderSize) + " data bytes received");
    }
    a.data.assign(bytes + kHeaderSize, bytes + kHeaderSize + length);
    return a;
}

CommandPacket make_discovery(std::uint16_t req_id) {
    CommandPacket c;
    c.command = Command::kDiscoveryCmd;
    c.req_id = req_id;
    return c;
}

CommandPacket make_read_reg(std::uint16_t req_id, const std::vector<std::uint32_t>& addresses) {
    CommandPacket c;
    c.command = Command::kReadRegCmd;
    c.req_id = req_id;
    c.data.resize(4 * addresses.size());
    for (std::size_t i = 0; i < addresses.size(); ++i) {
        put_u32(&c.data[4 * i], addresses[i]);
    }
    return c;
}

CommandPacket make_write_reg(
    std::uint16_t req_id,
    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& address_values) {
    CommandPacket c;
    c.command = Command::kWriteRegCmd;
    c.req_id = req_id;
    c.data.resize(8 * address_values.size());
    for (std::size_t i = 0; i < address_values.size(); ++i) {
        put_u32(&c.data[8 * i], address_values[i].first);
        put_u32(&c.data[8 * i + 4], address_values[i].second);
    }
    return c;
}

CommandPacket make_read_mem(std::uint16_t req_id, std::uint32_t address, std::uint16_t count) {
    CommandPacket c;
    c.command = Command::kReadMemCmd;
    c.req_id = req_id;
    c.data.resize(8, 0);
    put_u32(&c.data[0], address);
    put_u16(&c.data[6], count);
    return c;
}

CommandPacket make_write_mem(std::uint16_t req_id, std::uint32_t address, const Bytes& data) {
    CommandPacket c;
    c.command = Command::kWriteMemCmd;
    c.req_id = req_id;
    c.data.resize(4 + data.size());
    put_u32(&c.data[0], address);
    std::copy(data.begin(), data.end(), c.data.begin() + 4);
    return c;
}

CommandPacket make_packet_resend(std::uint16_t req_id, const PacketResend& r, bool extended_ids) {
    CommandPacket c;
    c.command = Command::kPacketResendCmd;
    c.req_id = req_id;
    c.flags = static_cast<std::uint8_t>(extended_ids ? kFlagExtendedIds : 0);
    c.data.resize(extended_ids ? 20 : 12, 0);
    put_u16(&c.data[0], r.stream_channel);
    if (!extended_ids) {
        put_u16(&c.data[2], static_cast<std::uint16_t>(r.block_id));
    }
    put_u32(&c.data[4], r.first_packet_id & (extended_ids ? 0xFFFFFFFFu : 0x00FFFFFFu));
    put_u32(&c.data[8], r.last_packet_id & (extended_ids ? 0xFFFFFFFFu : 0x00FFFFFFu));
    if (extended_ids) {
        put_u32(&c.data[12], static_cast<std::uint32_t>(r.block_id >> 32));
        put_u32(&c.data[16], static_cast<std::uint32_t>(r.block_id));
    }
    return c;
}

Expected<std::vector<std::uint32_t>> parse_read_reg(const CommandPacket& c) {
    const std::size_t n = c.data.size() / 4;
    if (c.data.empty() || c.data.size() % 4 != 0 || n > kMaxReadRegs) {
        return make_error("READREG_CMD: " + std::to_string(c.data.size()) +
                          " data bytes; must be 4 to " + std::to_string(4 * kMaxReadRegs) +
                          " in steps of 4");
    }
    std::vector<std::uint32_t> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        out[i] = get_u32(&c.data[4 * i]);
    }
    return out;
}

Expected<std::vector<std::pair<std::uint32_t, std::uint32_t>>> parse_write_reg(
    const CommandPacket& c) {
    if (c.data.empty() || c.data.size() % 8 != 0) {
        return make_error("WRITEREG_CMD: " + std::to_string(c.data.size()) +
                          " data bytes; must be a non-zero multiple of 8 (address, value)");
    }
    std::vector<std::pair<std::uint32_t, std::uint32_t>> out(c.data.size() / 8);
    for (std::size_t i = 0; i < out.size(); ++i) {
        out[i] = {get_u32(&c.data[8 * i]), get_u32(&c.data[8 * i + 4])};
    }
    return out;
}

Expected<MemRead> parse_read_mem(const CommandPacket& c) {
    if (c.data.size() != 8) {
        return make_error("READMEM_CMD: " + std::to_string(c.data.size()) +
                          " data bytes; must be 8 (address, reserved, count)");
    }
    return MemRead{get_u32(&c.data[0]), get_u16(&c.data[6])};
}

Expected<MemWrite> parse_write_mem(const CommandPacket& c) {
    if (c.data.size() < 8) {
        return make_error("WRITEMEM_CMD: " + std::to_string(c.data.size()) +
                          " data bytes; needs an address and at least 4 bytes");
    }
    MemWrite w;
    w.address = get_u32(&c.data[0]);
    w.data.assign(c.data.begin() + 4, c.data.end());
    return w;
}

Expected<PacketResend> parse_packet_resend(const CommandPacket& c) {
    const bool ext = (c.flags & kFlagExtendedIds) != 0;
    const std::size_t need = ext ? 20 : 12;
    if (c.data.size() != need) {
        return make_error("PACKETRESEND_CMD: " + std::to_string(c.data.size()) +
                          " data bytes; must be " + std::to_string(need) +
                          (ext ? " with extended ids" : " without extended ids"));
    }
    PacketResend r;
    r.stream_channel = get_u16(&c.data[0]);
    const std::uint32_t mask = ext ? 0xFFFFFFFFu : 0x00FFFFFFu;
    r.first_packet_id = get_u32(&c.data[4]) & mask;
    r.last_packet_id = get_u32(&c.data[8]) & mask;
    r.block_id =
        ext ? (static_cast<std::uint64_t>(get_u32(&c.data[12])) << 32) | get_u32(&c.data[16])
            : get_u16(&c.data[2]);
    return r;
}

AckPacket make_read_reg_ack(std::uint16_t ack_id,
                            Status status,
                            const std::vector<std::uint32_t>& values) {
    AckPacket a;
    a.status = status;
    a.answer = Command::kReadRegAck;
    a.ack_id = ack_id;
    a.data.resize(4 * values.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
        put_u32(&a.data[4 * i], values[i]);
    }
    return a;
}

AckPacket make_write_reg_ack(std::uint16_t ack_id, Status status, std::uint16_t index) {
    AckPacket a;
    a.status = status;
    a.answer = Command::kWriteRegAck;
    a.ack_id = ack_id;
    a.data.resize(4, 0);
    put_u16(&a.data[2], index);
    return a;
}

AckPacket make_read_mem_ack(std::uint16_t ack_id,
                            Status status,
                            std::uint32_t address,
                            const Bytes& data) {
    AckPacket a;
    a.status = status;
    a.answer = Command::kReadMemAck;
    a.ack_id = ack_id;
    a.data.resize(4 + data.size());
    put_u32(&a.data[0], address);
    std::copy(data.begin(), data.end(), a.data.begin() + 4);
    return a;
}

AckPacket make_write_mem_ack(std::uint16_t ack_id, Status status, std::uint16_t index) {
    AckPacket a = make_write_reg_ack(ack_id, status, index);
    a.answer = Command::kWriteMemAck;
    return a;
}

AckPacket make_discovery_ack(std::uint16_t ack_id, const Bytes& bootstrap_head) {
    AckPacket a;
    a.answer = Command::kDiscoveryAck;
    a.ack_id = ack_id;
    a.data.assign(kDiscoveryDataSize, 0);
    std::copy_n(bootstrap_head.begin(),
                std::min(bootstrap_head.size(), kDiscoveryDataSize),
                a.data.begin());
    return a;
}

Expected<std::vector<std::uint32_t>> parse_read_reg_ack(const AckPacket& a) {
    if (a.answer != Command::kReadRegAck) {
        return make_error("expected READREG_ACK, got " + to_string(a.answer));
    }
    if (a.status != Status::kSuccess) {
        return make_error("READREG_ACK: " + to_string(a.status));
    }
    if (a.data.size() % 4 != 0) {
        return make_error("READREG_ACK: " + std::to_string(a.data.size()) +
                          " data bytes, not a multiple of 4");
    }
    std::vector<std::uint32_t> v(a.data.size() / 4);
    for (std::size_t i = 0; i < v.size(); ++i) {
        v[i] = get_u32(&a.data[4 * i]);
    }
    return v;
}

Expected<Bytes> parse_read_mem_ack(const AckPacket& a, std::uint32_t expected_address) {
    if (a.answer != Command::kReadMemAck) {
        return make_error("expected READMEM_ACK, got " + to_string(a.answer));
    }
    if (a.status != Status::kSuccess) {
        return make_error("READMEM_ACK: " + to_string(a.status));
    }
    if (a.data.size() < 4 || get_u32(a.data.data()) != expected_address) {
        return make_error("READMEM_ACK: address field does not echo the requested address");
    }
    return Bytes(a.data.begin() + 4, a.data.end());
}

}  // namespace gonio::devices::gvcp

namespace gonio::devices::gvbs {

Expected<LocalUrl> parse_local_url(const std::string& url_in) {
    // The register is NUL-padded.
    const std::string url = url_in.substr(0, url_in.find('\0'));
    const std::string scheme = "local:";
    if (url.size() < scheme.size() ||
        !std::equal(scheme.begin(), scheme.end(), url.begin(), [](char a, char b) {
            return a == std::tolower(static_cast<unsigned char>(b));
        })) {
        return make_error("XML URL '" + url + "': scheme must be Local:");
    }
    const std::string rest = url.substr(scheme.size());
    const auto s1 = rest.find(';');
    const auto s2 = s1 == std::string::npos ? std::string::npos : rest.find(';', s1 + 1);
    if (s2 == std::string::npos) {
        return make_error("XML URL '" + url + "': expected Local:NAME;ADDRESS;LENGTH");
    }
    LocalUrl u;
    u.file_name = rest.substr(0, s1);
    const std::string a = rest.substr(s1 + 1, s2 - s1 - 1);
    const std::string l = rest.substr(s2 + 1);
    char* end = nullptr;
    u.address = std::strtoull(a.c_str(), &end, 16);
    if (a.empty() || *end != '\0') {
        return make_error("XML URL '" + url + "': address '" + a + "' is not hexadecimal");
    }
    u.length = std::strtoull(l.c_str(), &end, 16);
    if (l.empty() || *end != '\0' || u.length == 0) {
        return make_error("XML URL '" + url + "': length '" + l +
                          "' is not a positive hexadecimal number");
    }
    return u;
}

}  // namespace gonio::devices::gvbs
