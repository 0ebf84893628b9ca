// The Modbus wire codec against the specifications' own examples: the PDU examples of the MODBUS
// Application Protocol Specification V1.1b3 (section 6, one per function; section 7, the exception
// example), the CRC example of MODBUS over Serial Line V1.02 (section 6.2.2 and appendix B: the
// frame 02 07 has CRC 0x1241, sent 41 12), the RTU silent intervals of its section 2.5.1.1, and
// the MBAP layout of the Messaging on TCP/IP Implementation Guide V1.0b. Then the bounds: every
// malformed request is refused with the exception the service flowcharts name.

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "gonio/devices/modbus_codec.h"

namespace {

namespace mb = gonio::devices::modbus;
using Bytes = mb::Bytes;

mb::Request parse_ok(const Bytes& pdu) {
    auto r = mb::parse_request(pdu.data(), pdu.size());
    EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().message);
    return r ? *r : mb::Request{};
}

mb::ExceptionCode refusal(const Bytes& pdu) {
    auto r = mb::parse_request(pdu.data(), pdu.size());
    EXPECT_FALSE(r.has_value());
    return r ? mb::ExceptionCode::kAcknowledge : r.error().code;
}

TEST(ModbusWire, CrcOfTheSerialLineExampleFrame) {
    const Bytes frame{0x02, 0x07};
    EXPECT_EQ(mb::crc16(frame.data(), frame.size()), 0x1241);
    // Sent low byte first.
    EXPECT_EQ(mb::encode_rtu_adu(0x02, {0x07}), (Bytes{0x02, 0x07, 0x41, 0x12}));
    // CRC of nothing is the initial value.
    EXPECT_EQ(mb::crc16(nullptr, 0), 0xFFFF);
}

TEST(ModbusWire, ReadHoldingRegistersExampleRequestAndResponse) {
    // Spec 6.3: read registers 108..110 (addresses 0x006B..0x006D); values 0x022B, 0x0000, 0x0064.
    const Bytes request_pdu{0x03, 0x00, 0x6B, 0x00, 0x03};
    const mb::Request r = parse_ok(request_pdu);
    EXPECT_EQ(r.function, mb::Function::kReadHoldingRegisters);
    EXPECT_EQ(r.address, 0x006B);
    EXPECT_EQ(r.quantity, 3);
    EXPECT_EQ(mb::encode_request(r), request_pdu);
    const Bytes response_pdu{0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64};
    EXPECT_EQ(mb::encode_response(mb::make_response(r, {0x022B, 0x0000, 0x0064})), response_pdu);
    auto back = mb::parse_response(r, response_pdu.data(), response_pdu.size());
    ASSERT_TRUE(back.has_value()) << back.error().message;
    EXPECT_EQ(back->registers, (std::vector<std::uint16_t>{0x022B, 0x0000, 0x0064}));
    // The same exchange as RTU frames of unit 1: CRC 0x1774 and 0x7A05 (sent low byte first).
    EXPECT_EQ(mb::encode_rtu_adu(1, request_pdu),
              (Bytes{0x01, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x74, 0x17}));
    EXPECT_EQ(mb::encode_rtu_adu(1, response_pdu),
              (Bytes{0x01, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0x05, 0x7A}));
}

TEST(ModbusWire, ReadCoilsExamplePacksBitsLowFirst) {
    // Spec 6.1: coils 20..38 (address 0x0013, 19 coils) read CD 6B 05.
    const mb::Request r = parse_ok({0x01, 0x00, 0x13, 0x00, 0x13});
    EXPECT_EQ(r.quantity, 19);
    const Bytes response_pdu{0x01, 0x03, 0xCD, 0x6B, 0x05};
    auto back = mb::parse_response(r, response_pdu.data(), response_pdu.size());
    ASSERT_TRUE(back.has_value()) << back.error().message;
    ASSERT_EQ(back->coils.size(), 19u);
    // 0xCD = 1100 1101: coils 27..20 -> coil 20 on, 21 off, 22 on, 23 on, 24 off, 25 off, 26..27
    // on.
    const bool first8[8] = {true, false, true, true, false, false, true, true};
    for (int k = 0; k < 8; ++k) {
        EXPECT_EQ(back->coils[static_cast<std::size_t>(k)], first8[k]) << k;
    }
    // 0x05: coils 36 and 38 on, 37 off (the three remaining bits of the last byte).
    EXPECT_TRUE(back->coils[16]);
    EXPECT_FALSE(back->coils[17]);
    EXPECT_TRUE(back->coils[18]);
    EXPECT_EQ(mb::encode_response(*back), response_pdu);
}

TEST(ModbusWire, WriteExamplesEchoAsTheSpecificationShows) {
    // 6.5 write single coil 173 (0x00AC) on.
    const Bytes coil{0x05, 0x00, 0xAC, 0xFF, 0x00};
    const mb::Request c = parse_ok(coil);
    ASSERT_EQ(c.coils.size(), 1u);
    EXPECT_TRUE(c.coils[0]);
    EXPECT_EQ(mb::encode_response(mb::make_response(c)), coil);
    // 6.6 write single register 2 (0x0001) = 0x0003.
    const Bytes reg{0x06, 0x00, 0x01, 0x00, 0x03};
    const mb::Request w = parse_ok(reg);
    EXPECT_EQ(w.registers, (std::vector<std::uint16_t>{3}));
    EXPECT_EQ(mb::encode_response(mb::make_response(w)), reg);
    // 6.11 write coils 20..29: CD 01.
    const Bytes coils{0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01};
    const mb::Request mc = parse_ok(coils);
    EXPECT_EQ(mc.quantity, 10);
    EXPECT_EQ(mc.coils,
              (std::vector<bool>{true, false, true, true, false, false, true, true, true, false}));
    EXPECT_EQ(mb::encode_request(mc), coils);
    EXPECT_EQ(mb::encode_response(mb::make_response(mc)), (Bytes{0x0F, 0x00, 0x13, 0x00, 0x0A}));
    // 6.12 write registers 2..3 = 0x000A, 0x0102.
    const Bytes regs{0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02};
    const mb::Request mr = parse_ok(regs);
    EXPECT_EQ(mr.registers, (std::vector<std::uint16_t>{0x000A, 0x0102}));
    EXPECT_EQ(mb::encode_request(mr), regs);
    const Bytes echo{0x10, 0x00, 0x01, 0x00, 0x02};
    EXPECT_EQ(mb::encode_response(mb::make_response(mr)), echo);
    EXPECT_TRUE(mb::parse_response(mr, echo.data(), echo.size()).has_value());
    // An echo with another quantity is not the answer to this request.
    const Bytes wrong{0x10, 0x00, 0x01, 0x00, 0x03};
    EXPECT_FALSE(mb::parse_response(mr, wrong.data(), wrong.size()).has_value());
}

TEST(ModbusWire, ExceptionResponseExample) {
    // Section 7: a read coils request answered "illegal data address": 81 02.
    EXPECT_EQ(mb::exception_pdu(0x01, mb::ExceptionCode::kIllegalDataAddress), (Bytes{0x81, 0x02}));
    const mb::Request r = parse_ok({0x01, 0x04, 0xA1, 0x00, 0x01});
    const Bytes e{0x81, 0x02};
    auto back = mb::parse_response(r, e.data(), e.size());
    ASSERT_TRUE(back.has_value());
    ASSERT_TRUE(back->exception.has_value());
    EXPECT_EQ(*back->exception, mb::ExceptionCode::kIllegalDataAddress);
    EXPECT_EQ(mb::to_string(*back->exception), "illegal data address");
}

TEST(ModbusWire, MalformedRequestsGetTheFlowchartsExceptions) {
    using E = mb::ExceptionCode;
    EXPECT_EQ(refusal({}), E::kIllegalFunction);
    EXPECT_EQ(refusal({0x2B, 0x0E, 0x01, 0x00}), E::kIllegalFunction);         // not served
    EXPECT_EQ(refusal({0x03, 0x00, 0x00, 0x00, 0x00}), E::kIllegalDataValue);  // quantity 0
    EXPECT_EQ(refusal({0x03, 0x00, 0x00, 0x00, 0x7E}), E::kIllegalDataValue);  // 126 > 125
    EXPECT_EQ(refusal({0x01, 0x00, 0x00, 0x07, 0xD1}), E::kIllegalDataValue);  // 2001 > 2000
    EXPECT_EQ(refusal({0x03, 0x00, 0x00, 0x00}), E::kIllegalDataValue);        // short PDU
    EXPECT_EQ(refusal({0x05, 0x00, 0x00, 0x12, 0x34}), E::kIllegalDataValue);  // coil value
    // Byte count that disagrees with the quantity, and a PDU longer than its byte count says.
    EXPECT_EQ(refusal({0x10, 0x00, 0x01, 0x00, 0x02, 0x03, 0x00, 0x0A, 0x01}),
              E::kIllegalDataValue);
    EXPECT_EQ(refusal({0x10, 0x00, 0x01, 0x00, 0x01, 0x02, 0x00, 0x0A, 0x01}),
              E::kIllegalDataValue);
    EXPECT_EQ(refusal({0x0F, 0x00, 0x13, 0x00, 0x0A, 0x01, 0xCD}), E::kIllegalDataValue);
}

TEST(ModbusWire, RangesAtTheTopOfTheAddressSpaceNeverWrap) {
    using E = mb::ExceptionCode;
    // The last register alone is fine; one more runs past 0xFFFF (a 16-bit sum would wrap to 0).
    EXPECT_EQ(parse_ok({0x03, 0xFF, 0xFF, 0x00, 0x01}).address, 0xFFFF);
    EXPECT_EQ(refusal({0x03, 0xFF, 0xFF, 0x00, 0x02}), E::kIllegalDataAddress);
    EXPECT_EQ(refusal({0x03, 0xFF, 0x84, 0x00, 0x7D}), E::kIllegalDataAddress);
    EXPECT_EQ(parse_ok({0x03, 0xFF, 0x83, 0x00, 0x7D}).quantity, 125);  // ends at 0xFFFF exactly
    EXPECT_EQ(refusal({0x01, 0xFF, 0xFF, 0x07, 0xD0}), E::kIllegalDataAddress);
    EXPECT_EQ(refusal({0x10, 0xFF, 0xFF, 0x00, 0x02, 0x04, 0, 1, 0, 2}), E::kIllegalDataAddress);
}

TEST(ModbusWire, MbapHeaderFramesAStream) {
    const Bytes pdu{0x03, 0x00, 0x6B, 0x00, 0x03};
    const Bytes adu = mb::encode_tcp_adu(0x1234, 0x11, pdu);
    // transaction 0x1234, protocol 0, length 6 (unit id + 5-byte PDU), unit 0x11.
    EXPECT_EQ(adu, (Bytes{0x12, 0x34, 0x00, 0x00, 0x00, 0x06, 0x11, 0x03, 0x00, 0x6B, 0x00, 0x03}));
    // Two frames back to back, split at every byte: incomplete until the whole first frame.
    Bytes stream = adu;
    stream.insert(stream.end(), adu.begin(), adu.end());
    for (std::size_t n = 0; n < adu.size(); ++n) {
        EXPECT_EQ(mb::next_tcp_frame(stream.data(), n).status, mb::TcpFrame::Status::kIncomplete);
    }
    const mb::TcpFrame f = mb::next_tcp_frame(stream.data(), stream.size());
    ASSERT_EQ(f.status, mb::TcpFrame::Status::kFrame);
    EXPECT_EQ(f.consumed, adu.size());
    EXPECT_EQ(f.header.transaction_id, 0x1234);
    EXPECT_EQ(f.header.unit_id, 0x11);
    EXPECT_EQ(f.pdu, pdu);
    // Lengths outside [2, 254] lose the frame boundaries.
    for (const std::uint16_t len : {0, 1, 255, 0xFFFF}) {
        const Bytes bad{0,
                        1,
                        0,
                        0,
                        static_cast<std::uint8_t>(len >> 8),
                        static_cast<std::uint8_t>(len & 0xFF),
                        1};
        EXPECT_EQ(mb::next_tcp_frame(bad.data(), bad.size()).status, mb::TcpFrame::Status::kBroken)
            << len;
    }
}

TEST(ModbusWire, RtuFramesAreCheckedAndDelimited) {
    const Bytes frame{0x01, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x74, 0x17};
    auto a = mb::parse_rtu_adu(frame.data(), frame.size());
    ASSERT_TRUE(a.has_value()) << a.error().message;
    EXPECT_EQ(a->unit_id, 1);
    EXPECT_EQ(a->pdu, (Bytes{0x03, 0x00, 0x6B, 0x00, 0x03}));
    Bytes garbled = frame;
    garbled[3] ^= 0x01;
    EXPECT_FALSE(mb::parse_rtu_adu(garbled.data(), garbled.size()).has_value());
    EXPECT_FALSE(mb::parse_rtu_adu(frame.data(), 3).has_value());
    const Bytes too_long(257, 0);
    EXPECT_FALSE(mb::parse_rtu_adu(too_long.data(), too_long.size()).has_value());
    // Lengths from the function's layout.
    EXPECT_EQ(mb::rtu_request_length(frame.data(), 1), 0u);
    EXPECT_EQ(mb::rtu_request_length(frame.data(), 2), 8u);
    const Bytes regs =
        mb::encode_rtu_adu(1, {0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02});
    EXPECT_EQ(mb::rtu_request_length(regs.data(), 6), 0u);
    EXPECT_EQ(mb::rtu_request_length(regs.data(), regs.size()), regs.size());
    // A function without a known layout ends where a CRC matches.
    const Bytes odd = mb::encode_rtu_adu(2, {0x07});
    EXPECT_EQ(mb::rtu_request_length(odd.data(), odd.size()), 4u);
    EXPECT_EQ(mb::rtu_request_length(odd.data(), 3), 0u);
}

TEST(ModbusWire, RtuSilentIntervalsFollowTheBaudRate) {
    // 3.5 characters of 11 bits at 9600 baud: 38.5 / 9600 s = 4010.4 us -> 4011 us.
    EXPECT_EQ(mb::rtu_frame_silence(9600).count(), 4011);
    EXPECT_EQ(mb::rtu_character_gap(9600).count(), 1719);   // 16.5 / 9600 s = 1718.75 us
    EXPECT_EQ(mb::rtu_frame_silence(19200).count(), 2006);  // 2005.2 us
    // Above 19200 baud: fixed 1.75 ms and 750 us.
    EXPECT_EQ(mb::rtu_frame_silence(115200).count(), 1750);
    EXPECT_EQ(mb::rtu_character_gap(115200).count(), 750);
}

TEST(ModbusWire, SeededRandomRequestsRoundTrip) {
    std::mt19937 rng(20261201);
    const mb::Function functions[] = {mb::Function::kReadCoils,
                                      mb::Function::kReadHoldingRegisters,
                                      mb::Function::kWriteSingleCoil,
                                      mb::Function::kWriteSingleRegister,
                                      mb::Function::kWriteMultipleCoils,
                                      mb::Function::kWriteMultipleRegisters};
    for (int i = 0; i < 2000; ++i) {
        mb::Request r;
        r.function = functions[rng() % 6];
        switch (r.function) {
            case mb::Function::kReadCoils:
                r.quantity = static_cast<std::uint16_t>(1 + rng() % 2000);
                break;
            case mb::Function::kReadHoldingRegisters:
                r.quantity = static_cast<std::uint16_t>(1 + rng() % 125);
                break;
            case mb::Function::kWriteSingleCoil:
                r.coils = {rng() % 2 == 1};
                break;
            case mb::Function::kWriteSingleRegister:
                r.registers = {static_cast<std::uint16_t>(rng())};
                break;
            case mb::Function::kWriteMultipleCoils:
                r.quantity = static_cast<std::uint16_t>(1 + rng() % mb::kMaxWriteBits);
                for (int k = 0; k < r.quantity; ++k) {
                    r.coils.push_back(rng() % 2 == 1);
                }
                break;
            default:
                r.quantity = static_cast<std::uint16_t>(1 + rng() % mb::kMaxWriteRegisters);
                for (int k = 0; k < r.quantity; ++k) {
                    r.registers.push_back(static_cast<std::uint16_t>(rng()));
                }
                break;
        }
        r.address = static_cast<std::uint16_t>(rng() % (mb::kAddressSpace - r.quantity + 1));
        const Bytes pdu = mb::encode_request(r);
        auto back = mb::parse_request(pdu.data(), pdu.size());
        ASSERT_TRUE(back.has_value())
            << "seed 20261201, request " << i << ": " << back.error().message;
        EXPECT_EQ(mb::encode_request(*back), pdu) << "seed 20261201, request " << i;
        EXPECT_LE(pdu.size(), mb::kMaxPduSize);
    }
}

}  // namespace
