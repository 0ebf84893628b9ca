#pragma once

// Bootstrap registers of a USB3 Vision device (U3V 1.x ch. 5.5; GenCP 1.x technology-agnostic
// bootstrap register map). Offsets in bytes; all registers little-endian.

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/brdf/error.h"

namespace gonio::devices::u3v {

/// ABRM: technology-agnostic bootstrap register map, at device address 0.
namespace abrm {
inline constexpr std::uint64_t kGencpVersion = 0x0000;           ///< u32
inline constexpr std::uint64_t kManufacturerName = 0x0004;       ///< 64-byte string
inline constexpr std::uint64_t kModelName = 0x0044;              ///< 64-byte string
inline constexpr std::uint64_t kFamilyName = 0x0084;             ///< 64-byte string
inline constexpr std::uint64_t kDeviceVersion = 0x00C4;          ///< 64-byte string
inline constexpr std::uint64_t kManufacturerInfo = 0x0104;       ///< 64-byte string
inline constexpr std::uint64_t kSerialNumber = 0x0144;           ///< 64-byte string
inline constexpr std::uint64_t kUserDefinedName = 0x0184;        ///< 64-byte string
inline constexpr std::uint64_t kDeviceCapability = 0x01C4;       ///< u64
inline constexpr std::uint64_t kMaxDeviceResponseTime = 0x01CC;  ///< u32, ms
inline constexpr std::uint64_t kManifestTableAddress = 0x01D0;   ///< u64
inline constexpr std::uint64_t kSbrmAddress = 0x01D8;            ///< u64
inline constexpr std::uint64_t kDeviceConfiguration = 0x01E0;    ///< u64
inline constexpr std::uint64_t kTimestamp = 0x01F0;              ///< u64, ns
inline constexpr std::uint64_t kSize = 0x0210;
inline constexpr std::size_t kStringLength = 64;
}  // namespace abrm

/// SBRM: U3V technology-specific bootstrap register map, at the address read from ABRM.
namespace sbrm {
inline constexpr std::uint64_t kU3vVersion = 0x00;             ///< u32
inline constexpr std::uint64_t kU3vcpCapability = 0x04;        ///< u64
inline constexpr std::uint64_t kU3vcpConfiguration = 0x0C;     ///< u64
inline constexpr std::uint64_t kMaxCommandTransferLen = 0x14;  ///< u32, bytes
inline constexpr std::uint64_t kMaxAckTransferLen = 0x18;      ///< u32, bytes
inline constexpr std::uint64_t kNumStreamChannels = 0x1C;      ///< u32
inline constexpr std::uint64_t kSirmAddress = 0x20;            ///< u64
inline constexpr std::uint64_t kSirmLength = 0x28;             ///< u32
inline constexpr std::uint64_t kEirmAddress = 0x2C;            ///< u64
inline constexpr std::uint64_t kEirmLength = 0x34;             ///< u32
inline constexpr std::uint64_t kIidc2Address = 0x38;           ///< u64
inline constexpr std::uint64_t kCurrentSpeed = 0x40;           ///< u32
inline constexpr std::uint64_t kSize = 0x44;
}  // namespace sbrm

/// SIRM: streaming interface register map, at the address read from SBRM.
namespace sirm {
inline constexpr std::uint64_t kInfo = 0x00;                  ///< u32
inline constexpr std::uint64_t kControl = 0x04;               ///< u32, bit 0 = stream enable
inline constexpr std::uint64_t kRequiredPayloadSize = 0x08;   ///< u64
inline constexpr std::uint64_t kRequiredLeaderSize = 0x10;    ///< u32
inline constexpr std::uint64_t kRequiredTrailerSize = 0x14;   ///< u32
inline constexpr std::uint64_t kMaxLeaderSize = 0x18;         ///< u32 (host writes)
inline constexpr std::uint64_t kPayloadTransferSize = 0x1C;   ///< u32 (host writes)
inline constexpr std::uint64_t kPayloadTransferCount = 0x20;  ///< u32 (host writes)
inline constexpr std::uint64_t kPayloadFinal1Size = 0x24;     ///< u32 (host writes)
inline constexpr std::uint64_t kPayloadFinal2Size = 0x28;     ///< u32 (host writes)
inline constexpr std::uint64_t kMaxTrailerSize = 0x2C;        ///< u32 (host writes)
inline constexpr std::uint64_t kSize = 0x30;
}  // namespace sirm

/// One entry of the manifest table (GenCP 1.x, 64 bytes): the table is a u64 entry count followed
/// by the entries. file_version: major bits 31..24, minor 23..16, subminor 15..0. schema: bits
/// 15..10 file type (0 = uncompressed XML, 1 = zip holding one XML file), schema major 31..24 and
/// minor 23..16. sha1 is 20 bytes (all zero when the device gives none), then 20 reserved bytes.
struct ManifestEntry {
    std::uint32_t file_version = 0;
    std::uint32_t schema = 0;
    std::uint64_t address = 0;
    std::uint64_t size = 0;
    std::uint8_t sha1[20] = {};
    bool zipped() const { return ((schema >> 10) & 0x3F) == 1; }
};
inline constexpr std::size_t kManifestEntrySize = 64;
inline constexpr std::uint32_t kSchemaZip = 1u << 10;

std::vector<std::uint8_t> encode_manifest(const std::vector<ManifestEntry>& entries);
/// Parses the u64 count plus entries; the error names the entry and the rule.
Expected<std::vector<ManifestEntry>> decode_manifest(const std::uint8_t* data, std::size_t size);

// Little-endian helpers shared by the codecs.
void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v);
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v);
void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v);
std::uint16_t get_u16(const std::uint8_t* p);
std::uint32_t get_u32(const std::uint8_t* p);
std::uint64_t get_u64(const std::uint8_t* p);
/// Reads a NUL-terminated (or full-length) fixed string field.
std::string get_fixed_string(const std::uint8_t* p, std::size_t length);

}  // namespace gonio::devices::u3v
