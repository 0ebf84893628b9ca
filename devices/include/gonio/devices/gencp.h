#pragma once

// GenCP (Generic Control Protocol, GenICam GenCP 1.x) as used by the USB3 Vision control channel
// (U3V 1.x, ch. 5): pure bytes <-> struct codecs, no I/O.
//
// Every message starts with a 12-byte prefix, all fields little-endian:
//   command: magic "U3VC" (0x43563355) u32, flags u16, command_id u16, scd_length u16, request_id
//   u16 ack:     magic "U3VC" (0x43563355) u32, status u16, command_id u16, scd_length u16,
//   request_id u16
// followed by the command-specific data (SCD) of scd_length bytes:
//   READMEM_CMD  : address u64, reserved u16, read_length u16      -> READMEM_ACK : data
//   WRITEMEM_CMD : address u64, data                               -> WRITEMEM_ACK: reserved u16,
//                                                                                   length_written
//                                                                                   u16
//   PENDING_ACK  : reserved u16, temporary_timeout_ms u16 (the device needs more time; the host
//                  extends its deadline and keeps waiting for the real ack of the same request_id)

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/brdf/error.h"

namespace gonio::devices::gencp {

inline constexpr std::uint32_t kMagic = 0x43563355;  ///< "U3VC" little-endian
inline constexpr std::size_t kPrefixSize = 12;
inline constexpr std::uint16_t kFlagRequestAck = 1u << 14;

/// Command identifiers (even = command, odd = its acknowledge).
enum class CommandId : std::uint16_t {
    kReadMemCmd = 0x0800,   ///< read device memory
    kReadMemAck = 0x0801,   ///< its acknowledge
    kWriteMemCmd = 0x0802,  ///< write device memory
    kWriteMemAck = 0x0803,  ///< its acknowledge
    kPendingAck = 0x0805,   ///< the device needs more time for the pending command
};

/// GenCP status codes (0x0000 success; 0x8xxx errors).
enum class Status : std::uint16_t {
    kSuccess = 0x0000,           ///< command executed
    kNotImplemented = 0x8001,    ///< command not supported
    kInvalidParameter = 0x8002,  ///< a parameter is not valid
    kInvalidAddress = 0x8003,    ///< address does not exist
    kWriteProtect = 0x8004,      ///< address is read-only
    kBadAlignment = 0x8005,      ///< address or length misaligned
    kAccessDenied = 0x8006,      ///< not accessible now
    kBusy = 0x8007,              ///< device busy
    kMsgTimeout = 0x800B,        ///< message timed out
    kInvalidHeader = 0x800E,     ///< malformed prefix
    kWrongConfig = 0x800F,       ///< configuration prevents the command
    kGenericError = 0x8FFF,      ///< unspecified error
};

/// Human-readable name of a status ("GENCP_INVALID_ADDRESS"), "status 0x....." for unknown codes.
std::string to_string(Status s);

struct Command {
    std::uint16_t flags = kFlagRequestAck;
    CommandId id = CommandId::kReadMemCmd;
    std::uint16_t request_id = 0;
    std::vector<std::uint8_t> scd;
};

struct Ack {
    Status status = Status::kSuccess;
    CommandId id = CommandId::kReadMemAck;
    std::uint16_t request_id = 0;
    std::vector<std::uint8_t> scd;
};

std::vector<std::uint8_t> encode(const Command& c);
std::vector<std::uint8_t> encode(const Ack& a);
/// Errors name the offending field and value ("GenCP command: magic 0x... != U3VC").
Expected<Command> decode_command(const std::uint8_t* data, std::size_t size);
Expected<Ack> decode_ack(const std::uint8_t* data, std::size_t size);

// Builders and parsers of the SCDs.
Command make_read_mem(std::uint16_t request_id, std::uint64_t address, std::uint16_t length);
Command make_write_mem(std::uint16_t request_id,
                       std::uint64_t address,
                       const std::vector<std::uint8_t>& data);

struct ReadMemRequest {
    std::uint64_t address = 0;
    std::uint16_t length = 0;
};
struct WriteMemRequest {
    std::uint64_t address = 0;
    std::vector<std::uint8_t> data;
};
Expected<ReadMemRequest> parse_read_mem(const Command& c);
Expected<WriteMemRequest> parse_write_mem(const Command& c);

Ack make_read_mem_ack(std::uint16_t request_id, Status s, std::vector<std::uint8_t> data);
Ack make_write_mem_ack(std::uint16_t request_id, Status s, std::uint16_t length_written);
Ack make_pending_ack(std::uint16_t request_id, std::uint16_t timeout_ms);
/// Bytes written from a WRITEMEM_ACK's SCD.
Expected<std::uint16_t> parse_write_mem_ack(const Ack& a);
/// Temporary timeout (ms) from a PENDING_ACK's SCD.
Expected<std::uint16_t> parse_pending_ack(const Ack& a);

}  // namespace gonio::devices::gencp
