#pragma once

// The Modbus wire format as pure bytes <-> struct codecs, no I/O: the PDUs of the functions gonio
// uses (MODBUS Application Protocol Specification V1.1b3, section 6; exceptions, section 7), the
// MBAP header of Modbus TCP (MODBUS Messaging on TCP/IP Implementation Guide V1.0b, section 3.1.3),
// RTU framing with its CRC-16 and its silent intervals (MODBUS over Serial Line Specification and
// Implementation Guide V1.02, sections 2.5.1 and 6.2.2). Shared by the simulator's servers and the
// fuzz target; every length and address is checked before it is used, in arithmetic that cannot
// overflow.
//
// PDUs (big-endian 16-bit fields):
//   function 1/2 read coils/discrete inputs   address u16, quantity u16 (1..2000)
//            -> byte count u8, ceil(quantity / 8) bytes of bits (LSB first)
//   function 3/4 read holding/input registers address u16, quantity u16 (1..125)
//            -> byte count u8, 2 * quantity bytes
//   function 5 write single coil              address u16, value u16 (0xFF00 on, 0x0000 off)
//            -> echo
//   function 6 write single register          address u16, value u16 -> echo
//   function 15 write multiple coils          address u16, quantity u16 (1..1968), byte count u8,
//                                             bits -> address u16, quantity u16
//   function 16 write multiple registers      address u16, quantity u16 (1..123), byte count u8,
//                                             values -> address u16, quantity u16
//   exception response                        function | 0x80, exception code u8

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <tl/expected.hpp>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::devices::modbus {

using Bytes = std::vector<std::uint8_t>;

/// Function codes served and used by gonio.
enum class Function : std::uint8_t {
    kReadCoils = 0x01,               ///< read 1..2000 coils
    kReadDiscreteInputs = 0x02,      ///< read 1..2000 discrete inputs
    kReadHoldingRegisters = 0x03,    ///< read 1..125 holding registers
    kReadInputRegisters = 0x04,      ///< read 1..125 input registers
    kWriteSingleCoil = 0x05,         ///< write one coil (0xFF00 on, 0x0000 off)
    kWriteSingleRegister = 0x06,     ///< write one holding register
    kWriteMultipleCoils = 0x0F,      ///< write 1..1968 coils
    kWriteMultipleRegisters = 0x10,  ///< write 1..123 holding registers
};

/// Exception codes (Application Protocol V1.1b3, section 7).
enum class ExceptionCode : std::uint8_t {
    kIllegalFunction = 0x01,                     ///< function not supported
    kIllegalDataAddress = 0x02,                  ///< address range not in the device
    kIllegalDataValue = 0x03,                    ///< quantity, byte count or value malformed
    kServerDeviceFailure = 0x04,                 ///< unrecoverable error while executing
    kAcknowledge = 0x05,                         ///< accepted, takes long
    kServerDeviceBusy = 0x06,                    ///< busy with a long command
    kMemoryParityError = 0x08,                   ///< file record parity
    kGatewayPathUnavailable = 0x0A,              ///< gateway has no path to the target
    kGatewayTargetDeviceFailedToRespond = 0x0B,  ///< the target behind a gateway is silent
};

/// "illegal data address" for a known code, "exception 0x.." otherwise.
std::string to_string(ExceptionCode code);

inline constexpr std::size_t kMaxPduSize = 253;  ///< 256-byte RTU ADU less address and CRC
inline constexpr std::size_t kMbapSize = 7;      ///< transaction, protocol, length, unit
inline constexpr std::size_t kMinRtuAdu = 4;     ///< address, function, CRC
inline constexpr std::size_t kMaxRtuAdu = 256;
inline constexpr std::uint8_t kExceptionBit = 0x80;
inline constexpr int kMaxReadBits = 2000;
inline constexpr int kMaxReadRegisters = 125;
inline constexpr int kMaxWriteBits = 0x07B0;
inline constexpr int kMaxWriteRegisters = 0x7B;
/// Addresses are 16-bit: a range [address, address + quantity) ends at most here.
inline constexpr std::uint32_t kAddressSpace = 0x10000;

/// CRC-16/MODBUS: polynomial 0xA001 (x^16 + x^15 + x^2 + 1, reflected), initial value 0xFFFF
/// (Serial Line V1.02, section 6.2.2 and appendix B); sent low byte first.
std::uint16_t crc16(const std::uint8_t* data, std::size_t size);

/// A request PDU decoded.
struct Request {
    Function function = Function::kReadHoldingRegisters;
    std::uint16_t address = 0;
    /// Registers or coils read or written (1 for the single writes).
    std::uint16_t quantity = 1;
    /// Values written (functions 6 and 16).
    std::vector<std::uint16_t> registers;
    /// Coils written (functions 5 and 15).
    std::vector<bool> coils;
};

/// Why a request PDU is refused: the exception a server answers and the rule broken.
struct Refusal {
    ExceptionCode code = ExceptionCode::kIllegalDataValue;
    std::string message;
};

/// Decodes a request PDU (function code first). Follows the service flowcharts of section 6: an
/// unknown function is exception 1; a quantity out of range, a byte count that disagrees with it,
/// a coil value other than 0xFF00/0x0000 or a PDU of the wrong length is exception 3; a range that
/// runs past address 0xFFFF is exception 2.
tl::expected<Request, Refusal> parse_request(const std::uint8_t* pdu, std::size_t size);
/// Encodes a request PDU (the inverse of parse_request for every request it accepts).
Bytes encode_request(const Request& r);

/// A response PDU decoded.
struct Response {
    Function function = Function::kReadHoldingRegisters;
    /// Set: an exception response (function | 0x80, code); the fields below are empty.
    std::optional<ExceptionCode> exception;
    std::uint16_t address = 0;   ///< writes: the echoed address
    std::uint16_t quantity = 0;  ///< writes: the echoed quantity (1 for the single writes)
    std::vector<std::uint16_t> registers;  ///< read registers, or the value of function 6
    std::vector<bool> coils;               ///< read coils (quantity of them), or function 5's
};

/// The response that answers `request` with `registers` (functions 3/4) or `coils` (1/2) read;
/// the writes echo.
Response make_response(const Request& request,
                       const std::vector<std::uint16_t>& registers = {},
                       const std::vector<bool>& coils = {});
Bytes encode_response(const Response& r);
/// The exception response PDU for `function` (any byte: an unknown function is answered too).
Bytes exception_pdu(std::uint8_t function, ExceptionCode code);
/// Decodes the response PDU to `request`: checks the function, byte count and echoes against it.
/// The message names the rule broken.
Expected<Response> parse_response(const Request& request,
                                  const std::uint8_t* pdu,
                                  std::size_t size);

/// MBAP header of a Modbus TCP ADU.
struct MbapHeader {
    std::uint16_t transaction_id = 0;
    std::uint16_t protocol_id = 0;  ///< 0 = Modbus
    std::uint16_t length = 0;       ///< bytes that follow: unit id and PDU
    std::uint8_t unit_id = 0;
};

/// MBAP header and PDU.
Bytes encode_tcp_adu(std::uint16_t transaction_id, std::uint8_t unit_id, const Bytes& pdu);

/// The first frame of a TCP byte stream.
struct TcpFrame {
    enum class Status {
        kIncomplete,  ///< more bytes needed
        kFrame,       ///< header and pdu hold a frame of `consumed` bytes
        kBroken,      ///< the length field is outside [2, 254]: frame boundaries are lost
    };
    Status status = Status::kIncomplete;
    std::size_t consumed = 0;
    MbapHeader header;
    Bytes pdu;
    std::string error;  ///< kBroken: the rule broken
};
TcpFrame next_tcp_frame(const std::uint8_t* data, std::size_t size);

/// Unit address and CRC around a PDU.
Bytes encode_rtu_adu(std::uint8_t unit_id, const Bytes& pdu);
struct RtuAdu {
    std::uint8_t unit_id = 0;
    Bytes pdu;
};
/// Decodes one whole RTU frame: 4..256 bytes, CRC over all but the last two bytes.
Expected<RtuAdu> parse_rtu_adu(const std::uint8_t* data, std::size_t size);
/// Length of the request frame at the start of an RTU byte stream, from its function's layout
/// (0 = more bytes needed to tell). For a function without a known layout: the shortest prefix of
/// at least 4 bytes whose last two bytes are its CRC (0 when none yet).
std::size_t rtu_request_length(const std::uint8_t* data, std::size_t size);

/// RTU timing (Serial Line V1.02, section 2.5.1.1): a character is 11 bits; frames are separated
/// by 3.5 character times of silence and a frame's characters by at most 1.5. Above 19200 baud
/// the times are fixed at 1750 us and 750 us.
std::chrono::microseconds rtu_frame_silence(int baud);
std::chrono::microseconds rtu_character_gap(int baud);

}  // namespace gonio::devices::modbus
