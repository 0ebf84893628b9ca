// U3V stream leader and trailer codecs (USB3 Vision 1.x, image payload type).

#include "gonio/devices/u3v_stream.h"

#include <cstdio>

#include "gonio/devices/u3v_bootstrap.h"

namespace gonio::devices::u3v {

namespace {
std::string hex32(std::uint32_t v) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%08X", v);
    return buf;
}
}  // namespace

bool has_magic(const std::uint8_t* data, std::size_t size, std::uint32_t magic) {
    return data != nullptr && size >= 4 && get_u32(data) == magic;
}

std::vector<std::uint8_t> encode(const Leader& l) {
    std::vector<std::uint8_t> out;
    out.reserve(kImageLeaderSize);
    put_u32(out, kLeaderMagic);
    put_u16(out, 0);
    put_u16(out, static_cast<std::uint16_t>(kImageLeaderSize));
    put_u64(out, l.block_id);
    put_u16(out, 0);
    put_u16(out, l.payload_type);
    put_u64(out, l.timestamp_ns);
    put_u32(out, l.pixel_format);
    put_u32(out, l.size_x);
    put_u32(out, l.size_y);
    put_u32(out, l.offset_x);
    put_u32(out, l.offset_y);
    put_u16(out, l.padding_x);
    put_u16(out, 0);
    return out;
}

std::vector<std::uint8_t> encode(const Trailer& t) {
    std::vector<std::uint8_t> out;
    out.reserve(kImageTrailerSize);
    put_u32(out, kTrailerMagic);
    put_u16(out, 0);
    put_u16(out, static_cast<std::uint16_t>(kImageTrailerSize));
    put_u64(out, t.block_id);
    put_u16(out, t.status);
    put_u16(out, 0);
    put_u64(out, t.valid_payload_size);
    put_u32(out, t.size_y);
    return out;
}

Expected<Leader> decode_leader(const std::uint8_t* data, std::size_t size) {
    // Magic, sizes, block id and payload type fill the first 20 bytes of every leader.
    if (data == nullptr || size < 20) {
        return make_error("U3V leader: " + std::to_string(size) + " bytes, shorter than 20");
    }
    if (get_u32(data) != kLeaderMagic) {
        return make_error("U3V leader: magic " + hex32(get_u32(data)) + " != 0x4C563355 (U3VL)");
    }
    const std::uint16_t leader_size = get_u16(data + 6);
    if (leader_size > size || leader_size < 20) {
        return make_error("U3V leader: leader_size " + std::to_string(leader_size) + " with " +
                          std::to_string(size) +
                          " bytes received (at least 20, at most what arrived)");
    }
    Leader l;
    l.block_id = get_u64(data + 8);
    l.payload_type = get_u16(data + 18);
    if (l.payload_type != kPayloadImage) {
        return make_error("U3V leader: payload_type " + std::to_string(l.payload_type) +
                          " is not 1 (image)");
    }
    if (leader_size < kImageLeaderSize) {
        return make_error("U3V leader: leader_size " + std::to_string(leader_size) +
                          " < 52 for an image leader");
    }
    l.timestamp_ns = get_u64(data + 20);
    l.pixel_format = get_u32(data + 28);
    l.size_x = get_u32(data + 32);
    l.size_y = get_u32(data + 36);
    l.offset_x = get_u32(data + 40);
    l.offset_y = get_u32(data + 44);
    l.padding_x = get_u16(data + 48);
    return l;
}

Expected<Trailer> decode_trailer(const std::uint8_t* data, std::size_t size) {
    if (data == nullptr || size < 8) {
        return make_error("U3V trailer: " + std::to_string(size) + " bytes, shorter than 8");
    }
    if (get_u32(data) != kTrailerMagic) {
        return make_error("U3V trailer: magic " + hex32(get_u32(data)) + " != 0x54563355 (U3VT)");
    }
    const std::uint16_t trailer_size = get_u16(data + 6);
    if (trailer_size > size || trailer_size < kImageTrailerSize) {
        return make_error("U3V trailer: trailer_size " + std::to_string(trailer_size) + " with " +
                          std::to_string(size) + " bytes received (an image trailer has 32)");
    }
    Trailer t;
    t.block_id = get_u64(data + 8);
    t.status = get_u16(data + 16);
    t.valid_payload_size = get_u64(data + 20);
    t.size_y = get_u32(data + 28);
    return t;
}

}  // namespace gonio::devices::u3v
