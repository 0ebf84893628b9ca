#pragma once

// USB3 Vision stream channel packets (U3V 1.x, ch. 5.6): a block (one frame) travels as a leader,
// the payload in one or more bulk transfers, and a trailer. Pure bytes <-> struct, little-endian.
//
// Image leader (52 bytes): magic "U3VL" (0x4C563355) u32, reserved u16, leader_size u16,
//   block_id u64, reserved u16, payload_type u16 (0x0001 image), timestamp_ns u64,
//   pixel_format u32 (PFNC), size_x u32, size_y u32, offset_x u32, offset_y u32, padding_x u16,
//   reserved u16.
// Image trailer (32 bytes): magic "U3VT" (0x54563355) u32, reserved u16, trailer_size u16,
//   block_id u64, status u16 (GenCP status of the block), reserved u16, valid_payload_size u64,
//   size_y u32 (lines actually delivered).

#include <cstdint>
#include <vector>

#include "gonio/brdf/error.h"

namespace gonio::devices::u3v {

inline constexpr std::uint32_t kLeaderMagic = 0x4C563355;   ///< "U3VL"
inline constexpr std::uint32_t kTrailerMagic = 0x54563355;  ///< "U3VT"
inline constexpr std::uint16_t kPayloadImage = 0x0001;
inline constexpr std::size_t kImageLeaderSize = 52;
inline constexpr std::size_t kImageTrailerSize = 32;

struct Leader {
    std::uint64_t block_id = 0;
    std::uint16_t payload_type = kPayloadImage;
    std::uint64_t timestamp_ns = 0;
    std::uint32_t pixel_format = 0;
    std::uint32_t size_x = 0;
    std::uint32_t size_y = 0;
    std::uint32_t offset_x = 0;
    std::uint32_t offset_y = 0;
    std::uint16_t padding_x = 0;
};

struct Trailer {
    std::uint64_t block_id = 0;
    std::uint16_t status = 0;
    std::uint64_t valid_payload_size = 0;
    std::uint32_t size_y = 0;
};

std::vector<std::uint8_t> encode(const Leader& l);
std::vector<std::uint8_t> encode(const Trailer& t);
/// Errors name the field and the rule ("U3V leader: magic 0x... != U3VL").
Expected<Leader> decode_leader(const std::uint8_t* data, std::size_t size);
Expected<Trailer> decode_trailer(const std::uint8_t* data, std::size_t size);
/// True if the bytes start with the given magic.
bool has_magic(const std::uint8_t* data, std::size_t size, std::uint32_t magic);

}  // namespace gonio::devices::u3v
