#include "gonio/devices/address.h"

#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <locale>
#include <map>
#include <sstream>

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

/// Parses a finite decimal number in [lo, hi].
bool parse_real(const std::string& s, double lo, double hi, double* out) {
    if (s.empty()) {
        return false;
    }
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end == nullptr || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
        return false;
    }
    *out = v;
    return true;
}

/// The keys valid on every bus kind; false when `key` is not one of them.
bool common_key(const std::string& where,
                const std::string& key,
                const std::string& value,
                BusAddress* a,
                std::string* err) {
    if (key == "poll_rate") {
        if (!parse_real(value, 0.01, 100000, &a->poll_rate)) {
            *err =
                where + ": poll_rate \"" + value + "\" not a number of polls/s in [0.01, 100000]";
        }
        return true;
    }
    if (key == "line_share") {
        if (a->kind != BusKind::kRtu) {
            *err = where + ": line_share applies to RTU lines only (use poll_rate on TCP)";
        } else if (!parse_real(value, 0.01, 1, &a->line_share)) {
            *err = where + ": line_share \"" + value + "\" not a fraction in [0.01, 1]";
        }
        return true;
    }
    if (key == "outage_ms") {
        if (!parse_int(value, 0, 86400000, &a->outage_ms)) {
            *err = where + ": outage_ms \"" + value + "\" not an integer in [0, 86400000]";
        }
        return true;
    }
    return false;
}

}  // namespace

double rtu_transaction_s(const BusAddress& a, int request_bytes, int reply_bytes) {
    const double bits_per_char = 1 + a.data_bits + (a.parity == 'N' ? 0 : 1) + a.stop_bits;
    const double char_s = bits_per_char / a.baud;
    const double silence_s = a.baud > 19200 ? 1.75e-3 : 3.5 * char_s;
    return (request_bytes + reply_bytes) * char_s + 2 * silence_s;
}

double poll_budget_per_s(const BusAddress& a) {
    if (a.poll_rate > 0) {
        return a.poll_rate;
    }
    if (a.kind == BusKind::kRtu) {
        // A 2-register read: 8 request bytes, 9 reply bytes.
        const double share = a.line_share > 0 ? a.line_share : 0.5;
        return share / rtu_transaction_s(a, 8, 9);
    }
    return 200;
}

namespace {

/// Calls `apply(key, value)` for each non-empty "key=value" of an '&'-separated query, stopping
/// at the first error.
template <class Apply>
Expected<void> for_each_query_pair(const std::string& where,
                                   const std::string& query,
                                   Apply apply) {
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
        if (auto r = apply(kv.substr(0, eq), kv.substr(eq + 1)); !r) {
            return r;
        }
    }
    return {};
}

/// tcp://HOST[:PORT][?poll_rate=..&outage_ms=..]
Expected<BusAddress> parse_tcp_address(const std::string& text, const std::string& where) {
    BusAddress a;
    a.kind = BusKind::kTcp;
    std::string rest = text.substr(6);
    const auto qm = rest.find('?');
    if (qm != std::string::npos) {
        const std::string query = rest.substr(qm + 1);
        rest = rest.substr(0, qm);
        auto r = for_each_query_pair(
            where, query, [&](const std::string& key, const std::string& value) -> Expected<void> {
                std::string err;
                if (!common_key(where, key, value, &a, &err)) {
                    return make_error(where + ": unknown key \"" + key +
                                      "\" (known: poll_rate, outage_ms)");
                }
                if (!err.empty()) {
                    return make_error(err);
                }
                return {};
            });
        if (!r) {
            return tl::unexpected(r.error());
        }
    }
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

/// One key of an RTU address's query: the serial line's settings or a common key.
Expected<void> apply_rtu_key(const std::string& where,
                             const std::string& key,
                             const std::string& value,
                             BusAddress* a) {
    if (key == "baud") {
        if (!parse_int(value, 50, 4000000, &a->baud)) {
            return make_error(where + ": baud \"" + value + "\" not in [50, 4000000]");
        }
    } else if (key == "parity") {
        if (value != "N" && value != "E" && value != "O") {
            return make_error(where + ": parity \"" + value + "\" not one of N, E, O");
        }
        a->parity = value[0];
    } else if (key == "data_bits") {
        if (!parse_int(value, 7, 8, &a->data_bits)) {
            return make_error(where + ": data_bits \"" + value + "\" not 7 or 8");
        }
    } else if (key == "stop_bits") {
        if (!parse_int(value, 1, 2, &a->stop_bits)) {
            return make_error(where + ": stop_bits \"" + value + "\" not 1 or 2");
        }
    } else {
        std::string err;
        if (!common_key(where, key, value, a, &err)) {
            return make_error(where + ": unknown key \"" + key +
                              "\" (known: baud, parity, data_bits, stop_bits, poll_rate, "
                              "line_share, outage_ms)");
        }
        if (!err.empty()) {
            return make_error(err);
        }
    }
    return {};
}

/// rtu:DEVICE[?baud=..&parity=..&...]
Expected<BusAddress> parse_rtu_address(const std::string& text, const std::string& where) {
    BusAddress a;
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
    auto r = for_each_query_pair(
        where, rest.substr(q + 1), [&](const std::string& key, const std::string& value) {
            return apply_rtu_key(where, key, value, &a);
        });
    if (!r) {
        return tl::unexpected(r.error());
    }
    return a;
}

}  // namespace

Expected<BusAddress> parse_bus_address(const std::string& text) {
    const std::string where = "address \"" + text + "\"";
    if (text.rfind("tcp://", 0) == 0) {
        return parse_tcp_address(text, where);
    }
    if (text.rfind("rtu:", 0) == 0) {
        return parse_rtu_address(text, where);
    }
    return make_error(where + ": expected tcp://HOST:PORT or rtu:DEVICE?baud=N&parity=N");
}

namespace {

std::string number(double v) {
    std::ostringstream s;
    s.imbue(std::locale::classic());
    s << std::setprecision(15) << v;
    return s.str();
}

/// The scheduler and reconnect keys that differ from their defaults, each starting with `sep`.
std::string common_keys(const BusAddress& a, char sep) {
    std::string s;
    if (a.poll_rate > 0) {
        s += sep + std::string("poll_rate=") + number(a.poll_rate);
        sep = '&';
    }
    if (a.line_share > 0) {
        s += sep + std::string("line_share=") + number(a.line_share);
        sep = '&';
    }
    if (a.outage_ms != 10000) {
        s += sep + std::string("outage_ms=") + std::to_string(a.outage_ms);
    }
    return s;
}

}  // namespace

std::string to_string(const BusAddress& a) {
    if (a.kind == BusKind::kTcp) {
        return "tcp://" + a.host + ":" + std::to_string(a.port) + common_keys(a, '?');
    }
    return "rtu:" + a.device + "?baud=" + std::to_string(a.baud) +
           "&parity=" + std::string(1, a.parity) + "&data_bits=" + std::to_string(a.data_bits) +
           "&stop_bits=" + std::to_string(a.stop_bits) + common_keys(a, '&');
}

}  // namespace gonio::devices
