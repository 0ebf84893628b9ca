#include "gonio/devices/modbus_codec.h"

#include <algorithm>
#include <cstdio>

namespace gonio::devices::modbus {
namespace {

std::uint16_t get_u16(const std::uint8_t* p) {
    return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

void put_u16(Bytes& b, std::uint16_t v) {
    b.push_back(static_cast<std::uint8_t>(v >> 8));
    b.push_back(static_cast<std::uint8_t>(v & 0xFF));
}

std::string hex(unsigned v, int digits) {
    char b[16];
    std::snprintf(b, sizeof b, "0x%0*X", digits, v);
    return b;
}

const char* function_name(std::uint8_t fc) {
    switch (fc) {
        case 0x01:
            return "read coils";
        case 0x02:
            return "read discrete inputs";
        case 0x03:
            return "read holding registers";
        case 0x04:
            return "read input registers";
        case 0x05:
            return "write single coil";
        case 0x06:
            return "write single register";
        case 0x0F:
            return "write multiple coils";
        case 0x10:
            return "write multiple registers";
        default:
            return nullptr;
    }
}

std::string function_label(std::uint8_t fc) {
    const char* n = function_name(fc);
    return "function " + std::to_string(fc) + (n != nullptr ? std::string(" (") + n + ")" : "");
}

tl::unexpected<Refusal> refuse(ExceptionCode code, std::string message) {
    return tl::unexpected<Refusal>(Refusal{code, std::move(message)});
}

bool is_read_bits(Function f) {
    return f == Function::kReadCoils || f == Function::kReadDiscreteInputs;
}
bool is_read_registers(Function f) {
    return f == Function::kReadHoldingRegisters || f == Function::kReadInputRegisters;
}

/// The range [address, address + quantity) fits the 16-bit address space (32-bit sum: no wrap).
bool range_fits(std::uint16_t address, std::uint16_t quantity) {
    return static_cast<std::uint32_t>(address) + quantity <= kAddressSpace;
}

}  // namespace

std::string to_string(ExceptionCode code) {
    switch (code) {
        case ExceptionCode::kIllegalFunction:
            return "illegal function";
        case ExceptionCode::kIllegalDataAddress:
            return "illegal data address";
        case ExceptionCode::kIllegalDataValue:
            return "illegal data value";
        case ExceptionCode::kServerDeviceFailure:
            return "server device failure";
        case ExceptionCode::kAcknowledge:
            return "acknowledge";
        case ExceptionCode::kServerDeviceBusy:
            return "server device busy";
        case ExceptionCode::kMemoryParityError:
            return "memory parity error";
        case ExceptionCode::kGatewayPathUnavailable:
            return "gateway path unavailable";
        case ExceptionCode::kGatewayTargetDeviceFailedToRespond:
            return "gateway target device failed to respond";
    }
    return "exception " + hex(static_cast<unsigned>(code), 2);
}

std::uint16_t crc16(const std::uint8_t* data, std::size_t size) {
    std::uint16_t crc = 0xFFFF;
    for (std::size_t i = 0; i < size; ++i) {
        crc ^= data[i];
        for (int bit = 0; bit < 8; ++bit) {
            const bool carry = (crc & 1U) != 0;
            crc = static_cast<std::uint16_t>(crc >> 1);
            if (carry) {
                crc ^= 0xA001U;
            }
        }
    }
    return crc;
}

tl::expected<Request, Refusal> parse_request(const std::uint8_t* pdu, std::size_t size) {
    if (size < 1) {
        return refuse(ExceptionCode::kIllegalFunction, "empty PDU: no function code");
    }
    const std::uint8_t fc = pdu[0];
    if (function_name(fc) == nullptr) {
        return refuse(ExceptionCode::kIllegalFunction,
                      "function " + std::to_string(fc) + " is not served");
    }
    Request r;
    r.function = static_cast<Function>(fc);
    const std::string label = function_label(fc);
    const auto wrong_size = [&](const std::string& expected) {
        return refuse(ExceptionCode::kIllegalDataValue,
                      label + ": " + std::to_string(size) + "-byte PDU, expected " + expected);
    };
    switch (r.function) {
        case Function::kReadCoils:
        case Function::kReadDiscreteInputs:
        case Function::kReadHoldingRegisters:
        case Function::kReadInputRegisters: {
            if (size != 5) {
                return wrong_size("5");
            }
            r.address = get_u16(pdu + 1);
            r.quantity = get_u16(pdu + 3);
            const int max = is_read_bits(r.function) ? kMaxReadBits : kMaxReadRegisters;
            if (r.quantity < 1 || r.quantity > max) {
                return refuse(ExceptionCode::kIllegalDataValue,
                              label + ": quantity " + std::to_string(r.quantity) + " not in [1, " +
                                  std::to_string(max) + "]");
            }
            break;
        }
        case Function::kWriteSingleCoil: {
            if (size != 5) {
                return wrong_size("5");
            }
            r.address = get_u16(pdu + 1);
            const std::uint16_t v = get_u16(pdu + 3);
            if (v != 0xFF00 && v != 0x0000) {
                return refuse(ExceptionCode::kIllegalDataValue,
                              label + ": value " + hex(v, 4) + " is neither 0xFF00 nor 0x0000");
            }
            r.coils = {v == 0xFF00};
            break;
        }
        case Function::kWriteSingleRegister:
            if (size != 5) {
                return wrong_size("5");
            }
            r.address = get_u16(pdu + 1);
            r.registers = {get_u16(pdu + 3)};
            break;
        case Function::kWriteMultipleCoils:
        case Function::kWriteMultipleRegisters: {
            if (size < 6) {
                return wrong_size("at least 6");
            }
            r.address = get_u16(pdu + 1);
            r.quantity = get_u16(pdu + 3);
            const std::size_t byte_count = pdu[5];
            const bool coils = r.function == Function::kWriteMultipleCoils;
            const int max = coils ? kMaxWriteBits : kMaxWriteRegisters;
            if (r.quantity < 1 || r.quantity > max) {
                return refuse(ExceptionCode::kIllegalDataValue,
                              label + ": quantity " + std::to_string(r.quantity) + " not in [1, " +
                                  std::to_string(max) + "]");
            }
            const std::size_t need = coils ? (r.quantity + 7u) / 8u : 2u * r.quantity;
            if (byte_count != need) {
                return refuse(ExceptionCode::kIllegalDataValue,
                              label + ": byte count " + std::to_string(byte_count) + " for " +
                                  std::to_string(r.quantity) + (coils ? " coils" : " registers") +
                                  ", expected " + std::to_string(need));
            }
            if (size != 6 + byte_count) {
                return wrong_size(std::to_string(6 + byte_count) + " (byte count " +
                                  std::to_string(byte_count) + ")");
            }
            for (std::size_t k = 0; k < r.quantity; ++k) {
                if (coils) {
                    r.coils.push_back(((pdu[6 + k / 8] >> (k % 8)) & 1U) != 0);
                } else {
                    r.registers.push_back(get_u16(pdu + 6 + 2 * k));
                }
            }
            break;
        }
    }
    if (!range_fits(r.address, r.quantity)) {
        return refuse(ExceptionCode::kIllegalDataAddress,
                      label + ": addresses " + hex(r.address, 4) + " + " +
                          std::to_string(r.quantity) + " run past 0xFFFF");
    }
    return r;
}

Bytes encode_request(const Request& r) {
    Bytes b{static_cast<std::uint8_t>(r.function)};
    put_u16(b, r.address);
    switch (r.function) {
        case Function::kReadCoils:
        case Function::kReadDiscreteInputs:
        case Function::kReadHoldingRegisters:
        case Function::kReadInputRegisters:
            put_u16(b, r.quantity);
            break;
        case Function::kWriteSingleCoil:
            put_u16(b, !r.coils.empty() && r.coils[0] ? 0xFF00 : 0x0000);
            break;
        case Function::kWriteSingleRegister:
            put_u16(b, r.registers.empty() ? 0 : r.registers[0]);
            break;
        case Function::kWriteMultipleCoils: {
            const std::size_t n = r.coils.size();
            put_u16(b, static_cast<std::uint16_t>(n));
            b.push_back(static_cast<std::uint8_t>((n + 7) / 8));
            const std::size_t start = b.size();
            b.resize(start + (n + 7) / 8, 0);
            for (std::size_t k = 0; k < n; ++k) {
                if (r.coils[k]) {
                    b[start + k / 8] |= static_cast<std::uint8_t>(1U << (k % 8));
                }
            }
            break;
        }
        case Function::kWriteMultipleRegisters:
            put_u16(b, static_cast<std::uint16_t>(r.registers.size()));
            b.push_back(static_cast<std::uint8_t>(2 * r.registers.size()));
            for (const std::uint16_t v : r.registers) {
                put_u16(b, v);
            }
            break;
    }
    return b;
}

Response make_response(const Request& request,
                       const std::vector<std::uint16_t>& registers,
                       const std::vector<bool>& coils) {
    Response r;
    r.function = request.function;
    r.address = request.address;
    r.quantity = request.quantity;
    if (is_read_registers(request.function)) {
        r.registers = registers;
    } else if (is_read_bits(request.function)) {
        r.coils = coils;
    } else {
        r.registers = request.registers;
        r.coils = request.coils;
    }
    return r;
}

Bytes exception_pdu(std::uint8_t function, ExceptionCode code) {
    return {static_cast<std::uint8_t>(function | kExceptionBit), static_cast<std::uint8_t>(code)};
}

Bytes encode_response(const Response& r) {
    const auto fc = static_cast<std::uint8_t>(r.function);
    if (r.exception) {
        return exception_pdu(fc, *r.exception);
    }
    Bytes b{fc};
    switch (r.function) {
        case Function::kReadCoils:
        case Function::kReadDiscreteInputs: {
            const std::size_t n = (r.coils.size() + 7) / 8;
            b.push_back(static_cast<std::uint8_t>(n));
            b.resize(2 + n, 0);
            for (std::size_t k = 0; k < r.coils.size(); ++k) {
                if (r.coils[k]) {
                    b[2 + k / 8] |= static_cast<std::uint8_t>(1U << (k % 8));
                }
            }
            break;
        }
        case Function::kReadHoldingRegisters:
        case Function::kReadInputRegisters:
            b.push_back(static_cast<std::uint8_t>(2 * r.registers.size()));
            for (const std::uint16_t v : r.registers) {
                put_u16(b, v);
            }
            break;
        case Function::kWriteSingleCoil:
            put_u16(b, r.address);
            put_u16(b, !r.coils.empty() && r.coils[0] ? 0xFF00 : 0x0000);
            break;
        case Function::kWriteSingleRegister:
            put_u16(b, r.address);
            put_u16(b, r.registers.empty() ? 0 : r.registers[0]);
            break;
        case Function::kWriteMultipleCoils:
        case Function::kWriteMultipleRegisters:
            put_u16(b, r.address);
            put_u16(b, r.quantity);
            break;
    }
    return b;
}

Expected<Response> parse_response(const Request& request,
                                  const std::uint8_t* pdu,
                                  std::size_t size) {
    const auto fc = static_cast<std::uint8_t>(request.function);
    const std::string label = function_label(fc) + " response";
    if (size < 2) {
        return make_error(label + ": " + std::to_string(size) + "-byte PDU, too short");
    }
    Response r;
    r.function = request.function;
    if (pdu[0] == (fc | kExceptionBit)) {
        if (size != 2) {
            return make_error(label + ": exception response of " + std::to_string(size) +
                              " bytes, expected 2");
        }
        r.exception = static_cast<ExceptionCode>(pdu[1]);
        return r;
    }
    if (pdu[0] != fc) {
        return make_error(label + ": function code " + std::to_string(pdu[0]) + " answers " +
                          std::to_string(fc));
    }
    switch (request.function) {
        case Function::kReadCoils:
        case Function::kReadDiscreteInputs:
        case Function::kReadHoldingRegisters:
        case Function::kReadInputRegisters: {
            const bool bits = is_read_bits(request.function);
            const std::size_t need = bits ? (request.quantity + 7u) / 8u : 2u * request.quantity;
            if (pdu[1] != need || size != 2 + need) {
                return make_error(label + ": byte count " + std::to_string(pdu[1]) + " in a " +
                                  std::to_string(size) + "-byte PDU, expected " +
                                  std::to_string(need) + " for quantity " +
                                  std::to_string(request.quantity));
            }
            r.address = request.address;
            r.quantity = request.quantity;
            for (std::size_t k = 0; k < request.quantity; ++k) {
                if (bits) {
                    r.coils.push_back(((pdu[2 + k / 8] >> (k % 8)) & 1U) != 0);
                } else {
                    r.registers.push_back(get_u16(pdu + 2 + 2 * k));
                }
            }
            return r;
        }
        case Function::kWriteSingleCoil:
        case Function::kWriteSingleRegister:
        case Function::kWriteMultipleCoils:
        case Function::kWriteMultipleRegisters: {
            if (size != 5) {
                return make_error(label + ": " + std::to_string(size) + "-byte PDU, expected 5");
            }
            const Bytes expected = encode_response(make_response(request));
            if (!std::equal(expected.begin(), expected.end(), pdu)) {
                return make_error(label + ": does not echo the request's address and " +
                                  (request.function == Function::kWriteSingleCoil ||
                                           request.function == Function::kWriteSingleRegister
                                       ? "value"
                                       : "quantity"));
            }
            return make_response(request);
        }
    }
    return make_error(label + ": unknown function");
}

Bytes encode_tcp_adu(std::uint16_t transaction_id, std::uint8_t unit_id, const Bytes& pdu) {
    Bytes b;
    b.reserve(kMbapSize + pdu.size());
    put_u16(b, transaction_id);
    put_u16(b, 0);
    put_u16(b, static_cast<std::uint16_t>(pdu.size() + 1));
    b.push_back(unit_id);
    b.insert(b.end(), pdu.begin(), pdu.end());
    return b;
}

TcpFrame next_tcp_frame(const std::uint8_t* data, std::size_t size) {
    TcpFrame f;
    if (size < kMbapSize) {
        return f;
    }
    f.header.transaction_id = get_u16(data);
    f.header.protocol_id = get_u16(data + 2);
    f.header.length = get_u16(data + 4);
    f.header.unit_id = data[6];
    // The length counts the unit id and the PDU: a PDU has 1 to 253 bytes.
    if (f.header.length < 2 || f.header.length > kMaxPduSize + 1) {
        f.status = TcpFrame::Status::kBroken;
        f.error = "MBAP length " + std::to_string(f.header.length) + " not in [2, " +
                  std::to_string(kMaxPduSize + 1) + "]";
        return f;
    }
    const std::size_t total = 6 + static_cast<std::size_t>(f.header.length);
    if (size < total) {
        return f;
    }
    f.status = TcpFrame::Status::kFrame;
    f.consumed = total;
    f.pdu.assign(data + kMbapSize, data + total);
    return f;
}

Bytes encode_rtu_adu(std::uint8_t unit_id, const Bytes& pdu) {
    Bytes b;
    b.reserve(pdu.size() + 3);
    b.push_back(unit_id);
    b.insert(b.end(), pdu.begin(), pdu.end());
    const std::uint16_t crc = crc16(b.data(), b.size());
    b.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    b.push_back(static_cast<std::uint8_t>(crc >> 8));
    return b;
}

Expected<RtuAdu> parse_rtu_adu(const std::uint8_t* data, std::size_t size) {
    if (size < kMinRtuAdu || size > kMaxRtuAdu) {
        return make_error("RTU frame of " + std::to_string(size) + " bytes, not in [" +
                          std::to_string(kMinRtuAdu) + ", " + std::to_string(kMaxRtuAdu) + "]");
    }
    const std::uint16_t crc = crc16(data, size - 2);
    const auto got = static_cast<std::uint16_t>(data[size - 2] | (data[size - 1] << 8));
    if (crc != got) {
        return make_error("RTU frame: CRC " + hex(got, 4) + " received, " + hex(crc, 4) +
                          " computed");
    }
    RtuAdu a;
    a.unit_id = data[0];
    a.pdu.assign(data + 1, data + size - 2);
    return a;
}

std::size_t rtu_request_length(const std::uint8_t* data, std::size_t size) {
    if (size < 2) {
        return 0;
    }
    switch (data[1]) {
        case 0x01:
        case 0x02:
        case 0x03:
        case 0x04:
        case 0x05:
        case 0x06:
            return 8;  // address, function, 4 bytes, CRC
        case 0x0F:
        case 0x10:
            // address, function, address, quantity, byte count, data, CRC
            return size < 7 ? 0 : 9 + static_cast<std::size_t>(data[6]);
        default:
            for (std::size_t n = kMinRtuAdu; n <= size && n <= kMaxRtuAdu; ++n) {
                const std::uint16_t crc = crc16(data, n - 2);
                if (data[n - 2] == (crc & 0xFF) && data[n - 1] == (crc >> 8)) {
                    return n;
                }
            }
            return 0;
    }
}

std::chrono::microseconds rtu_frame_silence(int baud) {
    if (baud <= 0 || baud > 19200) {
        return std::chrono::microseconds(1750);
    }
    // 3.5 characters of 11 bits: 38.5 bit times, rounded up to a whole microsecond.
    return std::chrono::microseconds((38500000LL + baud - 1) / baud);
}

std::chrono::microseconds rtu_character_gap(int baud) {
    if (baud <= 0 || baud > 19200) {
        return std::chrono::microseconds(750);
    }
    // 1.5 characters of 11 bits: 16.5 bit times.
    return std::chrono::microseconds((16500000LL + baud - 1) / baud);
}

}  // namespace gonio::devices::modbus
