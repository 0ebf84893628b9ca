#pragma once

// Connection addresses of a Modbus bus, as written in rig descriptions and on the command line:
//   tcp://127.0.0.1:502                       Modbus TCP (port defaults to 502)
//   rtu:/dev/ttyUSB0?baud=115200&parity=N     Modbus RTU on a serial line (RS-485)
// RTU query keys: baud (default 115200), parity (N, E or O; default N), data_bits (7 or 8; default
// 8), stop_bits (1 or 2; default 1).
// Query keys of both kinds (the bus scheduler and reconnect, docs/operator-guide.md):
//   poll_rate=R   status polls of all units on the bus together, at most R per second
//   line_share=F  RTU: polls use at most the fraction F of the line's capacity (from the baud rate,
//                 the character format and the frame sizes); default 0.5
//   outage_ms=T   a link lost for up to T ms is reconnected with back-off (default 10000)

#include <string>

#include "gonio/base/error.h"

namespace gonio::devices {

/// Which Modbus transport a bus uses.
enum class BusKind {
    kTcp,  ///< Modbus TCP (MBAP header, transaction ids).
    kRtu,  ///< Modbus RTU (binary frames with CRC-16 on a serial line).
};

struct BusAddress {
    BusKind kind = BusKind::kTcp;
    std::string host;       ///< TCP only.
    int port = 502;         ///< TCP only.
    std::string device;     ///< RTU only: the serial device path.
    int baud = 115200;      ///< RTU only.
    char parity = 'N';      ///< RTU only: 'N', 'E' or 'O'.
    int data_bits = 8;      ///< RTU only.
    int stop_bits = 1;      ///< RTU only.
    double poll_rate = 0;   ///< Polls per second on the bus; 0 = the default budget.
    double line_share = 0;  ///< RTU: share of the line's capacity for polls; 0 = default (0.5).
    int outage_ms = 10000;  ///< A lost link is retried with back-off for this long.
};

/// Bus time of one request and its reply on an RTU line: characters of 1 start bit, the data
/// bits, a parity bit unless parity is N, and the stop bits, plus the 3.5-character silence
/// after each frame (Modbus over Serial Line V1.02, section 2.5.1.1; fixed at 1.75 ms above
/// 19200 baud). Seconds.
double rtu_transaction_s(const BusAddress& a, int request_bytes, int reply_bytes);

/// Status polls per second allowed on a bus: poll_rate when given; on RTU otherwise line_share
/// (default 0.5) of the line's capacity for 2-register reads; on TCP otherwise 200.
double poll_budget_per_s(const BusAddress& a);

/// Parses an address string; the error names the string and the rule it breaks.
Expected<BusAddress> parse_bus_address(const std::string& text);

/// The canonical string of an address (parse_bus_address(to_string(a)) == a).
std::string to_string(const BusAddress& a);

}  // namespace gonio::devices
