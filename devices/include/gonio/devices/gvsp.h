#pragma once

// GVSP, the GigE Vision Streaming Protocol (GigE Vision 2.x, ch. 24), standard (16-bit block id)
// packets of the image payload type: pure bytes <-> struct codecs, no I/O. Big-endian fields.
//
// Every packet starts with an 8-byte header:
//   status u16, block_id u16, EI bit (0x80) | packet format u8, packet_id u24
// with packet formats 1 = leader, 2 = trailer, 3 = payload (generic). A block (one frame) is the
// leader (packet_id 0), payload packets 1..N carrying consecutive slices of the image, and the
// trailer (packet_id N + 1).
//   image leader : reserved u16, payload type u16 (0x0001 image), timestamp high u32, low u32,
//                  pixel format u32, size_x u32, size_y u32, offset_x u32, offset_y u32,
//                  padding_x u16, padding_y u16                                (36 bytes)
//   image trailer: reserved u16, payload type u16 (0x0001), size_y u32         (8 bytes)
//   payload      : the data bytes

#include <array>
#include <cstdint>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::devices::gvsp {

inline constexpr std::size_t kHeaderSize = 8;
inline constexpr std::size_t kImageLeaderSize = kHeaderSize + 36;
inline constexpr std::size_t kImageTrailerSize = kHeaderSize + 8;
inline constexpr std::uint16_t kPayloadTypeImage = 0x0001;

/// Packet formats (low 7 bits of header byte 4).
enum class Format : std::uint8_t {
    kLeader = 1,   ///< opens a block
    kTrailer = 2,  ///< closes a block
    kPayload = 3,  ///< generic payload data
};

struct Header {
    std::uint16_t status = 0;  ///< GEV_STATUS of the packet (0 = success)
    std::uint16_t block_id = 0;
    Format format = Format::kPayload;
    std::uint32_t packet_id = 0;  ///< 24 bits
};

struct ImageLeader {
    std::uint64_t timestamp = 0;  ///< device ticks
    std::uint32_t pixel_format = 0;
    std::uint32_t size_x = 0;
    std::uint32_t size_y = 0;
    std::uint32_t offset_x = 0;
    std::uint32_t offset_y = 0;
    std::uint16_t padding_x = 0;
    std::uint16_t padding_y = 0;
};

struct ImageTrailer {
    std::uint32_t size_y = 0;
};

/// Writes the 8-byte header to `out`.
void encode_header(const Header& h, std::uint8_t* out);
std::array<std::uint8_t, kHeaderSize> encode_header(const Header& h);
std::vector<std::uint8_t> encode_leader(std::uint16_t block_id, const ImageLeader& l);
std::vector<std::uint8_t> encode_trailer(std::uint16_t block_id,
                                         std::uint32_t packet_id,
                                         const ImageTrailer& t);

struct Packet {
    Header header;
    ImageLeader leader;                  ///< when header.format is kLeader
    ImageTrailer trailer;                ///< when header.format is kTrailer
    const std::uint8_t* data = nullptr;  ///< payload bytes (kPayload), into the parsed buffer
    std::size_t data_size = 0;
};

/// Parses one datagram; the message names the rule broken (size, extended-id bit, format, payload
/// type).
Expected<Packet> parse(const std::uint8_t* bytes, std::size_t size);

/// Image bytes carried by each payload packet of a stream channel programmed with `packet_size`
/// (the SCPS value, which counts the IP, UDP and GVSP headers).
std::size_t payload_bytes_per_packet(std::uint32_t packet_size);

}  // namespace gonio::devices::gvsp
