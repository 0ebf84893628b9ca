#pragma once

// GVCP, the GigE Vision Control Protocol (GigE Vision 2.x, ch. 7 and 15): pure bytes <-> struct
// codecs and the bootstrap register map, no I/O. Every field is big-endian (network order).
//
// A command is an 8-byte header followed by its data:
//   key 0x42 u8, flags u8 (bit 0x01: acknowledge required), command u16, length u16 (of the
//   data, bytes), req_id u16 (non-zero, echoed by the acknowledge)
// An acknowledge is an 8-byte header followed by its data:
//   status u16, answer u16, length u16, ack_id u16
// Data of the commands served here (acknowledge data after the arrow):
//   DISCOVERY_CMD    (none)                                 -> the 248 bytes of bootstrap
//                                                              registers 0x0000..0x00F7
//   READREG_CMD      address u32 (1..135 of them)            -> value u32 per address
//   WRITEREG_CMD     (address u32, value u32) pairs          -> reserved u16, index u16 (number of
//                                                              registers written)
//   READMEM_CMD      address u32, reserved u16, count u16    -> address u32, count bytes
//   WRITEMEM_CMD     address u32, data (multiple of 4 bytes) -> reserved u16, index u16 (bytes
//                                                              written)
//   PACKETRESEND_CMD stream channel u16, block_id u16,      (no acknowledge; the device sends the
//                    first packet_id u32, last packet_id u32  packets again on the stream channel)
//                    (with flag 0x10, extended ids: block_id field reserved, then block_id64 u64)

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::devices::gvcp {

using Bytes = std::vector<std::uint8_t>;

inline constexpr std::uint16_t kPort = 3956;  ///< the fixed GVCP UDP port of a device
inline constexpr std::uint8_t kKey = 0x42;    ///< first byte of every command
inline constexpr std::size_t kHeaderSize = 8;
inline constexpr std::uint8_t kFlagAckRequired = 0x01;
inline constexpr std::uint8_t kFlagExtendedIds = 0x10;  ///< PACKETRESEND with 64-bit block ids
/// Largest data of a READMEM (and WRITEMEM) that fits the 576-byte minimum datagram.
inline constexpr std::size_t kMaxMemData = 536;
inline constexpr std::size_t kMaxReadRegs = 135;
inline constexpr std::size_t kDiscoveryDataSize = 0xF8;

/// Command and acknowledge codes (odd = acknowledge of the even command before it).
enum class Command : std::uint16_t {
    kDiscoveryCmd = 0x0002,     ///< who is there (broadcast or unicast)
    kDiscoveryAck = 0x0003,     ///< device identity
    kPacketResendCmd = 0x0040,  ///< send stream packets again
    kReadRegCmd = 0x0080,       ///< read 32-bit registers
    kReadRegAck = 0x0081,       ///< their values
    kWriteRegCmd = 0x0082,      ///< write 32-bit registers
    kWriteRegAck = 0x0083,      ///< how many were written
    kReadMemCmd = 0x0084,       ///< read a block of device memory
    kReadMemAck = 0x0085,       ///< the block
    kWriteMemCmd = 0x0086,      ///< write a block of device memory
    kWriteMemAck = 0x0087,      ///< how many bytes were written
    kPendingAck = 0x0089,       ///< the device needs more time
};

/// GEV_STATUS codes (0x0000 success; 0x8xxx errors).
enum class Status : std::uint16_t {
    kSuccess = 0x0000,            ///< command executed
    kNotImplemented = 0x8001,     ///< command not supported
    kInvalidParameter = 0x8002,   ///< a parameter is not valid
    kInvalidAddress = 0x8003,     ///< address does not exist
    kWriteProtect = 0x8004,       ///< address is read-only
    kBadAlignment = 0x8005,       ///< address or length not a multiple of 4
    kAccessDenied = 0x8006,       ///< another application has control (or exclusive access)
    kBusy = 0x8007,               ///< device busy
    kPacketUnavailable = 0x800C,  ///< requested stream packet no longer held
    kInvalidHeader = 0x800E,      ///< malformed header
    kError = 0x8FFF,              ///< unspecified error
};

/// "GEV_STATUS_ACCESS_DENIED", or "status 0x...." for codes not listed above.
std::string to_string(Status s);
/// "READREG_CMD", or "command 0x...." for codes not listed above.
std::string to_string(Command c);

struct CommandPacket {
    std::uint8_t flags = kFlagAckRequired;
    Command command = Command::kReadRegCmd;
    std::uint16_t req_id = 1;
    Bytes data;
};

struct AckPacket {
    Status status = Status::kSuccess;
    Command answer = Command::kReadRegAck;
    std::uint16_t ack_id = 1;
    Bytes data;
};

Bytes encode(const CommandPacket& c);
Bytes encode(const AckPacket& a);
/// Parses a command; the message names the rule broken (key, length field vs datagram size).
Expected<CommandPacket> parse_command(const std::uint8_t* bytes, std::size_t size);
Expected<AckPacket> parse_ack(const std::uint8_t* bytes, std::size_t size);

// Command data builders and parsers. Parsers check lengths and alignment and name the field.

CommandPacket make_discovery(std::uint16_t req_id);
CommandPacket make_read_reg(std::uint16_t req_id, const std::vector<std::uint32_t>& addresses);
CommandPacket make_write_reg(
    std::uint16_t req_id,
    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& address_values);
CommandPacket make_read_mem(std::uint16_t req_id, std::uint32_t address, std::uint16_t count);
CommandPacket make_write_mem(std::uint16_t req_id, std::uint32_t address, const Bytes& data);

struct PacketResend {
    std::uint16_t stream_channel = 0;
    std::uint64_t block_id = 0;
    std::uint32_t first_packet_id = 0;
    std::uint32_t last_packet_id = 0;
};
CommandPacket make_packet_resend(std::uint16_t req_id, const PacketResend& r, bool extended_ids);

Expected<std::vector<std::uint32_t>> parse_read_reg(const CommandPacket& c);
Expected<std::vector<std::pair<std::uint32_t, std::uint32_t>>> parse_write_reg(
    const CommandPacket& c);
struct MemRead {
    std::uint32_t address = 0;
    std::uint16_t count = 0;
};
Expected<MemRead> parse_read_mem(const CommandPacket& c);
struct MemWrite {
    std::uint32_t address = 0;
    Bytes data;
};
Expected<MemWrite> parse_write_mem(const CommandPacket& c);
Expected<PacketResend> parse_packet_resend(const CommandPacket& c);

/// Acknowledge builders.
AckPacket make_read_reg_ack(std::uint16_t ack_id,
                            Status status,
                            const std::vector<std::uint32_t>& values);
AckPacket make_write_reg_ack(std::uint16_t ack_id, Status status, std::uint16_t index);
AckPacket make_read_mem_ack(std::uint16_t ack_id,
                            Status status,
                            std::uint32_t address,
                            const Bytes& data);
AckPacket make_write_mem_ack(std::uint16_t ack_id, Status status, std::uint16_t index);
AckPacket make_discovery_ack(std::uint16_t ack_id, const Bytes& bootstrap_head);

/// Values of a READREG_ACK.
Expected<std::vector<std::uint32_t>> parse_read_reg_ack(const AckPacket& a);
/// Data of a READMEM_ACK (after its address).
Expected<Bytes> parse_read_mem_ack(const AckPacket& a, std::uint32_t expected_address);

/// Big-endian helpers shared by the codecs and the bootstrap registers.
void put_u16(std::uint8_t* p, std::uint16_t v);
void put_u32(std::uint8_t* p, std::uint32_t v);
std::uint16_t get_u16(const std::uint8_t* p);
std::uint32_t get_u32(const std::uint8_t* p);

}  // namespace gonio::devices::gvcp

/// Bootstrap registers (GigE Vision 2.x, ch. 28), byte addresses in the device's register space.
namespace gonio::devices::gvbs {

inline constexpr std::uint32_t kVersion = 0x0000;  ///< major u16 << 16 | minor u16
/// Bit 31 (MSB): big-endian registers; bits 30..28 device class (0 transmitter); bits 7..0
/// character set of the strings (1 = UTF-8).
inline constexpr std::uint32_t kDeviceMode = 0x0004;
inline constexpr std::uint32_t kMacHigh = 0x0008;  ///< upper 2 bytes of the MAC in bits 15..0
inline constexpr std::uint32_t kMacLow = 0x000C;
inline constexpr std::uint32_t kSupportedIpConfig = 0x0010;
inline constexpr std::uint32_t kCurrentIpConfig = 0x0014;
inline constexpr std::uint32_t kCurrentIp = 0x0024;
inline constexpr std::uint32_t kCurrentSubnetMask = 0x0034;
inline constexpr std::uint32_t kCurrentGateway = 0x0044;
inline constexpr std::uint32_t kManufacturerName = 0x0048;  ///< 32 bytes
inline constexpr std::uint32_t kModelName = 0x0068;         ///< 32 bytes
inline constexpr std::uint32_t kDeviceVersion = 0x0088;     ///< 32 bytes
inline constexpr std::uint32_t kManufacturerInfo = 0x00A8;  ///< 48 bytes
inline constexpr std::uint32_t kSerialNumber = 0x00D8;      ///< 16 bytes
inline constexpr std::uint32_t kUserDefinedName = 0x00E8;   ///< 16 bytes
/// "Local:NAME.xml;ADDRESS;LENGTH" (hex, no 0x) naming the XML in device memory; 512 bytes.
inline constexpr std::uint32_t kFirstUrl = 0x0200;
inline constexpr std::uint32_t kSecondUrl = 0x0400;
inline constexpr std::uint32_t kUrlSize = 512;
inline constexpr std::uint32_t kNumberOfInterfaces = 0x0600;
inline constexpr std::uint32_t kNumberOfMessageChannels = 0x0900;
inline constexpr std::uint32_t kNumberOfStreamChannels = 0x0904;
/// GVCP capability bits (bit 31 = LSB): 0x4 PACKETRESEND, 0x2 WRITEMEM, 0x40000000 serial
/// number, 0x80000000 user-defined name.
inline constexpr std::uint32_t kGvcpCapability = 0x0934;
inline constexpr std::uint32_t kCapabilityWriteMem = 1u << 1;
inline constexpr std::uint32_t kCapabilityPacketResend = 1u << 2;
inline constexpr std::uint32_t kCapabilitySerialNumber = 1u << 30;
inline constexpr std::uint32_t kCapabilityUserName = 1u << 31;
inline constexpr std::uint32_t kHeartbeatTimeout = 0x0938;  ///< ms
inline constexpr std::uint32_t kTimestampTickFrequencyHigh = 0x093C;
inline constexpr std::uint32_t kTimestampTickFrequencyLow = 0x0940;
/// Write 0x2 to latch the timestamp into 0x0948/0x094C, 0x1 to reset it.
inline constexpr std::uint32_t kTimestampControl = 0x0944;
inline constexpr std::uint32_t kTimestampValueHigh = 0x0948;
inline constexpr std::uint32_t kTimestampValueLow = 0x094C;
/// Control Channel Privilege: 0x1 exclusive access, 0x2 control access, 0x4 switchover enable.
inline constexpr std::uint32_t kControlChannelPrivilege = 0x0A00;
inline constexpr std::uint32_t kCcpExclusive = 1u << 0;
inline constexpr std::uint32_t kCcpControl = 1u << 1;
/// Stream channel 0: host port in bits 15..0 of SCP (0 disables the channel).
inline constexpr std::uint32_t kStreamChannelPort = 0x0D00;
/// SCPS: bits 15..0 packet size in bytes including the IP, UDP and GVSP headers; bit 31 (MSB)
/// fires a test packet; bit 30 do-not-fragment.
inline constexpr std::uint32_t kStreamChannelPacketSize = 0x0D04;
inline constexpr std::uint32_t kStreamChannelPacketDelay = 0x0D08;  ///< ticks between packets
inline constexpr std::uint32_t kStreamChannelDestination = 0x0D18;  ///< IPv4 of the host
inline constexpr std::uint32_t kStreamChannelSourcePort = 0x0D1C;   ///< device's UDP port
inline constexpr std::uint32_t kStreamChannelCapability = 0x0D20;
inline constexpr std::uint32_t kStreamChannelConfig = 0x0D24;
/// IP (20) + UDP (8) + GVSP header (8): what a packet size leaves for stream data.
inline constexpr std::uint32_t kStreamPacketOverhead = 36;

/// Parses the first-URL text "Local:NAME;ADDRESS;LENGTH" (address and length in hex).
struct LocalUrl {
    std::string file_name;
    std::uint64_t address = 0;
    std::uint64_t length = 0;
};
Expected<LocalUrl> parse_local_url(const std::string& url);

}  // namespace gonio::devices::gvbs
