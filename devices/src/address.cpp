#include "gonio/devices/address.h"

#include <cstdlib>
#include <map>

namespace gonio::devices {
namespace {

/// Parses a whole decimal integer in [lo, hi].
bool parse_int(const std::string& s, int lo, int hi, int* out) {
    if (s.empty() || s.size() > 9) {
        return false;
    }
    for (char c : s) {
        if (c < '0' || c > '9') {
            return false;
        }
    }
    const long v = std::strtol(s.c_str(), nullptr, 10);
    if (v < lo || v > hi) {
        return false;
    }
    *out = static_cast<int>(v);
    return true;
}

}  // namespace

Expected<BusAddress> parse_bus_address(const std::string& text) {
    const std::string where = "address \"" + text + "\"";
    BusAddress a;
    if (text.rfind("tcp://", 0) == 0) {
        a.kind = BusKind::kTcp;
        const std::string rest = text.substr(6);
        const auto colon = rest.rfind(':');
        a.host = colon == std::string::npos ? rest : rest.substr(0, colon);
        if (a.host.empty()) {
            return make_error(where + ": missing host (expected tcp://HOST:PORT)");
        }
        if (colon != std::string::npos && !parse_int(rest.substr(colon + 1), 1, 65535, &a.port)) {
            return make_error(where + ": port \"" + rest.substr(colon + 1) +
                              "\" is not an integer in [1, 65535]");
        }
        return a;
    }
    if (text.rfind("rtu:", 0) == 0) {
        a.kind = BusKind::kRtu;
        std::string rest = text.substr(4);
        const auto q = rest.find('?');
        a.device = rest.substr(0, q);
        if (a.device.empty()) {
            return make_error(where +
                              ": missing serial device (expected rtu:/dev/ttyUSB0?baud=115200)");
        }
        if (q == std::string::npos) {
            return a;
        }
        std::string query = rest.substr(q + 1);
        size_t start = 0;
        while (start <= query.size()) {
            const auto amp = query.find('&', start);
            const std::string kv =
                query.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
            start = amp == std::string::npos ? query.size() + 1 : amp + 1;
            if (kv.empty()) {
                continue;
            }
            const auto eq = kv.find('=');
            if (eq == std::string::npos) {
                return make_error(where + ": \"" + kv + "\" is not key=value");
            }
            const std::string key = kv.substr(0, eq);
            const std::string value = kv.substr(eq + 1);
            if (key == "baud") {
                if (!parse_int(value, 50, 4000000, &a.baud)) {
                    return make_error(where + ": baud \"" + value + "\" not in [50, 4000000]");
                }
            } else if (key == "parity") {
                if (value != "N" && value != "E" && value != "O") {
                    return make_error(where + ": parity \"" + value + "\" not one of N, E, O");
                }
                a.parity = value[0];
            } else if (key == "data_bits") {
                if (!parse_int(value, 7, 8, &a.data_bits)) {
                    return make_error(where + ": data_bits \"" + value + "\" not 7 or 8");
                }
            } else if (key == "stop_bits") {
                if (!parse_int(value, 1, 2, &a.stop_bits)) {
                    return make_error(where + ": stop_bits \"" + value + "\" not 1 or 2");
                }
            } else {
                return make_error(where + ": unknown key \"" + key +
                                  "\" (known: baud, parity, data_bits, stop_bits)");
            }
        }
        return a;
    }
    return make_error(where + ": expected tcp://HOST:PORT or rtu:DEVICE?baud=N&parity=N");
}

std::string to_string(const BusAddress& a) {
    if (a.kind == BusKind::kTcp) {
        return "tcp://" + a.host + ":" + std::to_string(a.port);
    }
    return "rtu:" + a.device + "?baud=" + std::to_string(a.baud) +
           "&parity=" + std::string(1, a.parity) + "&data_bits=" + std::to_string(a.data_bits) +
           "&stop_bits=" + std::to_string(a.stop_bits);
}

}  // namespace gonio::devices
