// Protocol conformance of the simulated motor controller, as an independent client sees it: a table
// of raw request bytes and the exact replies the Modbus Application Protocol V1.1b3 (function
// service flowcharts, section 6; exception codes, section 7), the Modbus Messaging on TCP/IP
// Implementation Guide V1.0b (MBAP header) and Modbus over Serial Line V1.02 (RTU framing, CRC,
// broadcast) prescribe. The drive is an Oriental Motor AZ profile standing still at 12.34 deg
// (1234 = 0x04D2 steps, homed, in position, ready: output status 0x00004030).

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <vector>

#include "gonio/devices/axis_profile.h"
#include "gonio/sim/motor_controller_server.h"
#include "raw_modbus_client.h"

namespace {

using gonio::test::Bytes;
using gonio::test::hex_bytes;
using gonio::test::hex_string;
using gonio::test::with_crc;
using namespace std::chrono_literals;

struct Case {
    const char* what;
    const char* request;  ///< Unit id + PDU (TCP: the MBAP header is added with the right length).
    const char* reply;    ///< Unit id + PDU; empty = no reply expected.
};

// Unit 1: the drive. Unit 3: a shutter coil at 0. Unit 9: absent.
const std::vector<Case> kTcpCases = {
    {"read position (2 registers)", "01 03 00CC 0002", "01 03 04 0000 04D2"},
    {"read output status", "01 03 007E 0002", "01 03 04 0000 4030"},
    {"quantity 0 is an illegal data value", "01 03 00CC 0000", "01 83 03"},
    {"quantity 126 is an illegal data value", "01 03 00CC 007E", "01 83 03"},
    {"quantity 125 reaching absent registers is an illegal address", "01 03 00CC 007D", "01 83 02"},
    {"absent register", "01 03 1234 0001", "01 83 02"},
    {"read-only output status refuses function 6", "01 06 007E 0001", "01 86 02"},
    {"read-only position refuses function 16", "01 10 00CC 0002 04 0000 0001", "01 90 02"},
    {"function 16 with a byte count that disagrees with the quantity",
     "01 10 0058 0002 02 0000",
     "01 90 03"},
    {"function 16 quantity 0", "01 10 0058 0000 00", "01 90 03"},
    {"function 16 quantity 124", "01 10 0058 007C 02 0000", "01 90 03"},
    {"writable block, function 6 echoes", "01 06 0058 0000", "01 06 0058 0000"},
    {"writable block, function 16 answers address and quantity",
     "01 10 0058 0002 04 0000 0000",
     "01 10 0058 0002"},
    {"unknown function with a payload", "01 41 DEAD BEEF", "01 C1 01"},
    {"encapsulated interface (0x2B) not supported", "01 2B 0E 01 00", "01 AB 01"},
    {"function 3 with a short PDU", "01 03 00CC", "01 83 03"},
    {"coil on", "03 05 0000 FF00", "03 05 0000 FF00"},
    {"coil read", "03 01 0000 0001", "03 01 01 01"},
    {"coil value other than 0000/FF00", "03 05 0000 1234", "03 85 03"},
    {"coil read quantity 0", "03 01 0000 0000", "03 81 03"},
    {"absent unit behind the gateway", "09 03 00CC 0002", "09 83 0B"},
};

Bytes mbap(std::uint16_t tid, std::uint16_t pid, const Bytes& unit_pdu) {
    Bytes a{static_cast<std::uint8_t>(tid >> 8),
            static_cast<std::uint8_t>(tid & 0xFF),
            static_cast<std::uint8_t>(pid >> 8),
            static_cast<std::uint8_t>(pid & 0xFF),
            static_cast<std::uint8_t>(unit_pdu.size() >> 8),
            static_cast<std::uint8_t>(unit_pdu.size() & 0xFF)};
    a.insert(a.end(), unit_pdu.begin(), unit_pdu.end());
    return a;
}

class Conformance : public ::testing::Test {
  protected:
    void start(gonio::sim::Transport t) {
        auto p = gonio::devices::load_axis_profile("oriental-az");
        ASSERT_TRUE(p) << p.error().message;
        gonio::sim::MotorSimConfig cfg;
        cfg.start_homed = true;
        cfg.initial_deg = 12.34;
        ASSERT_TRUE(server_.add_unit(1, *p, cfg));
        ASSERT_TRUE(server_.add_unit(2, *p, cfg));
        ASSERT_TRUE(server_.add_shutter(3, 0));
        gonio::sim::ServerOptions so;
        so.transport = t;
        so.log = nullptr;
        auto st = server_.start(so);
        ASSERT_TRUE(st) << st.error().message;
    }
    gonio::sim::MotorControllerServer server_;
};

TEST_F(Conformance, TcpRequestsGetTheSpecifiedReplies) {
    start(gonio::sim::Transport::kTcp);
    const int fd = gonio::test::tcp_connect(server_.port());
    ASSERT_GE(fd, 0);
    std::uint16_t tid = 0x1200;
    // All on one connection: a refused request must never desynchronise the stream.
    for (const Case& c : kTcpCases) {
        ++tid;
        ASSERT_TRUE(gonio::test::send_all(fd, mbap(tid, 0, hex_bytes(c.request))));
        const Bytes want = mbap(tid, 0, hex_bytes(c.reply));
        const Bytes got = gonio::test::read_bytes(fd, want.size(), 2000ms);
        EXPECT_EQ(hex_string(got), hex_string(want)) << c.what;
    }
    EXPECT_TRUE(gonio::test::silent_for(fd, 50ms)) << "bytes beyond the specified replies";
    ::close(fd);
}

TEST_F(Conformance, TcpProtocolIdOtherThanModbusIsDiscardedUnanswered) {
    start(gonio::sim::Transport::kTcp);
    const int fd = gonio::test::tcp_connect(server_.port());
    ASSERT_GE(fd, 0);
    // Two frames back to back: protocol id 1 (not Modbus), then a valid one. Only the second is
    // answered.
    Bytes both = mbap(7, 1, hex_bytes("01 03 00CC 0002"));
    const Bytes ok = mbap(8, 0, hex_bytes("01 03 00CC 0002"));
    both.insert(both.end(), ok.begin(), ok.end());
    ASSERT_TRUE(gonio::test::send_all(fd, both));
    const Bytes want = mbap(8, 0, hex_bytes("01 03 04 0000 04D2"));
    EXPECT_EQ(hex_string(gonio::test::read_bytes(fd, want.size(), 2000ms)), hex_string(want));
    EXPECT_TRUE(gonio::test::silent_for(fd, 50ms));
    ::close(fd);
}

TEST_F(Conformance, TcpImpossibleMbapLengthClosesTheConnection) {
    start(gonio::sim::Transport::kTcp);
    // Length 0 and 1 cannot hold a unit id and a function code; 255 exceeds the 253-byte PDU.
    for (const char* header : {"0001 0000 0000", "0001 0000 0001 01", "0001 0000 00FF 01 03"}) {
        const int fd = gonio::test::tcp_connect(server_.port());
        ASSERT_GE(fd, 0);
        ASSERT_TRUE(gonio::test::send_all(fd, hex_bytes(header)));
        bool closed = false;
        const Bytes got = gonio::test::read_bytes(fd, 1, 2000ms, &closed);
        EXPECT_TRUE(closed) << header;
        EXPECT_TRUE(got.empty()) << header;
        ::close(fd);
    }
    // The server still serves a new client.
    const int fd = gonio::test::tcp_connect(server_.port());
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(gonio::test::send_all(fd, mbap(1, 0, hex_bytes("01 03 00CC 0002"))));
    const Bytes want = mbap(1, 0, hex_bytes("01 03 04 0000 04D2"));
    EXPECT_EQ(hex_string(gonio::test::read_bytes(fd, want.size(), 2000ms)), hex_string(want));
    ::close(fd);
}

TEST(ConformanceCrc, MatchesTheSerialLineSpecificationExample) {
    // Read 10 holding registers from address 0 of slave 1: CRC 0xCDC5, sent C5 CD.
    EXPECT_EQ(hex_string(with_crc(hex_bytes("01 03 0000 000A"))), "01 03 00 00 00 0A C5 CD");
}

TEST_F(Conformance, RtuRequestsGetTheSpecifiedReplies) {
    start(gonio::sim::Transport::kRtu);
    const int fd = gonio::test::open_pty(server_.device_path());
    ASSERT_GE(fd, 0);
    const std::vector<Case> cases = {
        {"read position", "01 03 00CC 0002", "01 03 04 0000 04D2"},
        {"unknown function", "01 41 DEAD BEEF", "01 C1 01"},
        {"unknown function without payload", "02 65", "02 E5 01"},
        {"quantity 0", "01 03 00CC 0000", "01 83 03"},
        {"read-only status", "01 06 007E 0001", "01 86 02"},
        {"byte count disagrees with quantity", "01 10 0058 0002 02 0000", "01 90 03"},
        {"absent unit stays silent", "09 03 00CC 0002", ""},
        {"broadcast write: executed, unanswered", "00 06 0058 0007", ""},
        {"broadcast write reached unit 1", "01 03 0058 0001", "01 03 02 0007"},
        {"broadcast write reached unit 2", "02 03 0058 0001", "02 03 02 0007"},
        {"broadcast read is ignored", "00 03 00CC 0002", ""},
    };
    for (const Case& c : cases) {
        ASSERT_TRUE(gonio::test::send_all(fd, with_crc(hex_bytes(c.request))));
        if (std::string(c.reply).empty()) {
            EXPECT_TRUE(gonio::test::silent_for(fd, 200ms)) << c.what;
            continue;
        }
        const Bytes want = with_crc(hex_bytes(c.reply));
        EXPECT_EQ(hex_string(gonio::test::read_bytes(fd, want.size(), 2000ms)), hex_string(want))
            << c.what;
    }
    ::close(fd);
}

}  // namespace
