#pragma once

// Connection addresses of a Modbus bus, as written in rig descriptions and on the command line:
//   tcp://127.0.0.1:502                       Modbus TCP (port defaults to 502)
//   rtu:/dev/ttyUSB0?baud=115200&parity=N     Modbus RTU on a serial line (RS-485)
// RTU query keys: baud (default 115200), parity (N, E or O; default N), data_bits (7 or 8; default
// 8), stop_bits (1 or 2; default 1).

#include <string>

#include "gonio/brdf/error.h"

namespace gonio::devices {

/// Which Modbus transport a bus uses.
enum class BusKind {
    kTcp,  ///< Modbus TCP (MBAP header, transaction ids).
    kRtu,  ///< Modbus RTU (binary frames with CRC-16 on a serial line).
};

struct BusAddress {
    BusKind kind = BusKind::kTcp;
    std::string host;    ///< TCP only.
    int port = 502;      ///< TCP only.
    std::string device;  ///< RTU only: the serial device path.
    int baud = 115200;   ///< RTU only.
    char parity = 'N';   ///< RTU only: 'N', 'E' or 'O'.
    int data_bits = 8;   ///< RTU only.
    int stop_bits = 1;   ///< RTU only.
};

/// Parses an address string; the error names the string and the rule it breaks.
Expected<BusAddress> parse_bus_address(const std::string& text);

/// The canonical string of an address (parse_bus_address(to_string(a)) == a).
std::string to_string(const BusAddress& a);

}  // namespace gonio::devices
