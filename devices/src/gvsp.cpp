// GVSP codecs (GigE Vision 2.x, ch. 24).

#include "gonio/devices/gvsp.h"

#include <string>

#include "gonio/devices/gvcp.h"

namespace gonio::devices::gvsp {

using gvcp::get_u16;
using gvcp::get_u32;
using gvcp::put_u16;
using gvcp::put_u32;

void encode_header(const Header& h, std::uint8_t* out) {
    put_u16(out, h.status);
    put_u16(out + 2, h.block_id);
    put_u32(out + 4, (static_cast<std::uint32_t>(h.format) << 24) | (h.packet_id & 0x00FFFFFFu));
}

std::array<std::uint8_t, kHeaderSize> encode_header(const Header& h) {
    std::array<std::uint8_t, kHeaderSize> b{};
    encode_header(h, b.data());
    return b;
}

std::vector<std::uint8_t> encode_leader(std::uint16_t block_id, const ImageLeader& l) {
    std::vector<std::uint8_t> b(kImageLeaderSize, 0);
    encode_header(Header{0, block_id, Format::kLeader, 0}, b.data());
    std::uint8_t* p = b.data() + kHeaderSize;
    put_u16(p + 2, kPayloadTypeImage);
    put_u32(p + 4, static_cast<std::uint32_t>(l.timestamp >> 32));
    put_u32(p + 8, static_cast<std::uint32_t>(l.timestamp));
    put_u32(p + 12, l.pixel_format);
    put_u32(p + 16, l.size_x);
    put_u32(p + 20, l.size_y);
    put_u32(p + 24, l.offset_x);
    put_u32(p + 28, l.offset_y);
    put_u16(p + 32, l.padding_x);
    put_u16(p + 34, l.padding_y);
    return b;
}

std::vector<std::uint8_t> encode_trailer(std::uint16_t block_id,
                                         std::uint32_t packet_id,
                                         const ImageTrailer& t) {
    std::vector<std::uint8_t> b(kImageTrailerSize, 0);
    encode_header(Header{0, block_id, Format::kTrailer, packet_id}, b.data());
    put_u16(b.data() + kHeaderSize + 2, kPayloadTypeImage);
    put_u32(b.data() + kHeaderSize + 4, t.size_y);
    return b;
}

Expected<Packet> parse(const std::uint8_t* bytes, std::size_t size) {
    if (size < kHeaderSize) {
        return make_error("GVSP packet: " + std::to_string(size) + " bytes, the header needs 8");
    }
    Packet p;
    p.header.status = get_u16(bytes);
    p.header.block_id = get_u16(bytes + 2);
    const std::uint8_t fmt = bytes[4];
    if ((fmt & 0x80) != 0) {
        return make_error("GVSP packet: extended-id bit set; only standard ids are handled");
    }
    p.header.packet_id = get_u32(bytes + 4) & 0x00FFFFFFu;
    const std::uint8_t format = fmt & 0x0F;
    const std::uint8_t* d = bytes + kHeaderSize;
    switch (format) {
        case 1: {
            p.header.format = Format::kLeader;
            if (size < kImageLeaderSize) {
                return make_error("GVSP leader: " + std::to_string(size) +
                                  " bytes, an image leader needs " +
                                  std::to_string(kImageLeaderSize));
            }
            if (get_u16(d + 2) != kPayloadTypeImage) {
                return make_error("GVSP leader: payload type " + std::to_string(get_u16(d + 2)) +
                                  ", only 1 (image) is handled");
            }
            ImageLeader& l = p.leader;
            l.timestamp = (static_cast<std::uint64_t>(get_u32(d + 4)) << 32) | get_u32(d + 8);
            l.pixel_format = get_u32(d + 12);
            l.size_x = get_u32(d + 16);
            l.size_y = get_u32(d + 20);
            l.offset_x = get_u32(d + 24);
            l.offset_y = get_u32(d + 28);
            l.padding_x = get_u16(d + 32);
            l.padding_y = get_u16(d + 34);
            return p;
        }
        case 2:
            p.header.format = Format::kTrailer;
            if (size < kImageTrailerSize) {
                return make_error("GVSP trailer: " + std::to_string(size) +
                                  " bytes, an image trailer needs " +
                                  std::to_string(kImageTrailerSize));
            }
            p.trailer.size_y = get_u32(d + 4);
            return p;
        case 3:
            p.header.format = Format::kPayload;
            p.data = d;
            p.data_size = size - kHeaderSize;
            return p;
        default:
            return make_error("GVSP packet: format " + std::to_string(format) +
                              " not handled (1 leader, 2 trailer, 3 payload)");
    }
}

std::size_t payload_bytes_per_packet(std::uint32_t packet_size) {
    const std::uint32_t size = packet_size & 0xFFFFu;
    return size > gvbs::kStreamPacketOverhead ? size - gvbs::kStreamPacketOverhead : 0;
}

}  // namespace gonio::devices::gvsp
