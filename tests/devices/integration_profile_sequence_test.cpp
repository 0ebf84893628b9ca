// The exact requests each shipped profile puts on the wire for home, move, stop, alarm read and
// alarm reset, checked against the sequences the drives' manuals prescribe (written out by hand in
// docs/profiles.md, "Request sequences"). The peer is a minimal Modbus TCP server written here from
// the Modbus Messaging on TCP/IP Implementation Guide V1.0b (MBAP header) and the Modbus
// Application Protocol V1.1b3 (functions 3, 6 and 16): it records every request PDU and answers
// from a plain register table, so nothing of gonio's simulator is involved.

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "gonio/devices/axis_profile.h"
#include "gonio/devices/modbus_axis.h"

namespace {

using Bytes = std::vector<std::uint8_t>;

/// Records request PDUs (function code onwards) and serves holding registers from a table.
class RecordingServer {
  public:
    RecordingServer() {
        listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in sa{};
        sa.sin_family = AF_INET;
        sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        sa.sin_port = 0;
        EXPECT_EQ(::bind(listen_fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 0);
        EXPECT_EQ(::listen(listen_fd_, 4), 0);
        socklen_t sl = sizeof sa;
        ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&sa), &sl);
        port_ = ntohs(sa.sin_port);
        thread_ = std::thread([this] { loop(); });
    }
    ~RecordingServer() {
        stop_ = true;
        thread_.join();
        for (int c : clients_) {
            ::close(c);
        }
        ::close(listen_fd_);
    }
    int port() const { return port_; }
    void set(int wire, std::uint16_t v) {
        std::lock_guard<std::mutex> lock(mu_);
        regs_[wire] = v;
    }
    void set_words(int wire, const std::vector<std::uint16_t>& w) {
        for (size_t k = 0; k < w.size(); ++k) {
            set(wire + static_cast<int>(k), w[k]);
        }
    }
    std::vector<Bytes> take() {
        std::lock_guard<std::mutex> lock(mu_);
        std::vector<Bytes> out;
        out.swap(log_);
        return out;
    }

  private:
    void loop() {
        std::map<int, Bytes> in;
        while (!stop_) {
            std::vector<pollfd> fds{{listen_fd_, POLLIN, 0}};
            for (int c : clients_) {
                fds.push_back({c, POLLIN, 0});
            }
            if (::poll(fds.data(), fds.size(), 20) <= 0) {
                continue;
            }
            if ((fds[0].revents & POLLIN) != 0) {
                const int c = ::accept(listen_fd_, nullptr, nullptr);
                if (c >= 0) {
                    clients_.push_back(c);
                }
            }
            for (size_t i = 1; i < fds.size(); ++i) {
                if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) == 0) {
                    continue;
                }
                const int c = fds[i].fd;
                std::uint8_t buf[512];
                const ssize_t n = ::read(c, buf, sizeof buf);
                if (n <= 0) {
                    ::close(c);
                    clients_.erase(std::find(clients_.begin(), clients_.end(), c));
                    in.erase(c);
                    continue;
                }
                Bytes& b = in[c];
                b.insert(b.end(), buf, buf + n);
                // MBAP: transaction id (2), protocol id (2), length (2, counts unit id + PDU).
                while (b.size() >= 7) {
                    const size_t len = (static_cast<size_t>(b[4]) << 8) | b[5];
                    if (b.size() < 6 + len) {
                        break;
                    }
                    Bytes pdu(b.begin() + 7, b.begin() + 6 + static_cast<long>(len));
                    Bytes reply = answer(pdu);
                    Bytes adu{b[0],
                              b[1],
                              0,
                              0,
                              static_cast<std::uint8_t>((reply.size() + 1) >> 8),
                              static_cast<std::uint8_t>((reply.size() + 1) & 0xFF),
                              b[6]};
                    adu.insert(adu.end(), reply.begin(), reply.end());
                    b.erase(b.begin(), b.begin() + 6 + static_cast<long>(len));
                    (void)!::write(c, adu.data(), adu.size());
                }
            }
        }
    }
    Bytes answer(const Bytes& pdu) {
        std::lock_guard<std::mutex> lock(mu_);
        log_.push_back(pdu);
        const int fc = pdu[0];
        const int addr = (pdu[1] << 8) | pdu[2];
        if (fc == 3) {
            const int qty = (pdu[3] << 8) | pdu[4];
            Bytes r{3, static_cast<std::uint8_t>(2 * qty)};
            for (int k = 0; k < qty; ++k) {
                const std::uint16_t v = regs_[addr + k];
                r.push_back(static_cast<std::uint8_t>(v >> 8));
                r.push_back(static_cast<std::uint8_t>(v & 0xFF));
            }
            return r;
        }
        if (fc == 6) {
            regs_[addr] = static_cast<std::uint16_t>((pdu[3] << 8) | pdu[4]);
            return pdu;
        }
        if (fc == 16) {
            const int qty = (pdu[3] << 8) | pdu[4];
            for (int k = 0; k < qty; ++k) {
                regs_[addr + k] =
                    static_cast<std::uint16_t>((pdu[6 + 2 * k] << 8) | pdu[7 + 2 * k]);
            }
            return Bytes(pdu.begin(), pdu.begin() + 5);
        }
        return Bytes{static_cast<std::uint8_t>(fc | 0x80), 1};
    }

    int listen_fd_ = -1;
    int port_ = 0;
    std::vector<int> clients_;
    std::atomic<bool> stop_{false};
    std::thread thread_;
    std::mutex mu_;
    std::map<int, std::uint16_t> regs_;
    std::vector<Bytes> log_;
};

Bytes hex(const std::string& s) {
    Bytes out;
    std::string digits;
    for (char ch : s) {
        if (ch != ' ') {
            digits.push_back(ch);
        }
    }
    for (size_t i = 0; i + 1 < digits.size(); i += 2) {
        out.push_back(static_cast<std::uint8_t>(std::stoi(digits.substr(i, 2), nullptr, 16)));
    }
    return out;
}

std::string show(const Bytes& b) {
    static const char* d = "0123456789ABCDEF";
    std::string s;
    for (std::uint8_t x : b) {
        if (!s.empty()) {
            s += ' ';
        }
        s += d[x >> 4];
        s += d[x & 15];
    }
    return s;
}

/// Only the requests that change the drive (functions 5, 6, 15, 16).
std::vector<std::string> writes(const std::vector<Bytes>& log) {
    std::vector<std::string> out;
    for (const Bytes& p : log) {
        if (p[0] == 5 || p[0] == 6 || p[0] == 15 || p[0] == 16) {
            out.push_back(show(p));
        }
    }
    return out;
}

std::vector<std::string> shown(std::initializer_list<const char*> pdus) {
    std::vector<std::string> out;
    for (const char* p : pdus) {
        out.push_back(show(hex(p)));
    }
    return out;
}

/// What the manuals prescribe, per profile (docs/profiles.md, "Request sequences"): a move to
/// 12.5 deg at 30 deg/s and 60 deg/s^2, homing, stop, reading the present alarm, alarm reset.
struct Sequence {
    const char* profile;
    std::vector<std::string> home;
    std::vector<std::string> move;
    std::vector<std::string> stop;
    std::string alarm_read;
    std::vector<std::string> reset;
};

std::vector<Sequence> expected_sequences() {
    return {
        // Leadshine PR mode: PR0 = absolute (1), 6250 pulses, 90 rpm, 5556 ms / 1000 rpm both
        // ramps, no pause; then the PR control word 6002h: 10h runs path 0, 20h homes, 40h stops.
        {"leadshine",
         shown({"06 6002 0020"}),
         shown({"10 6200 0007 0E 0001 0000 186A 005A 15B4 15B4 0000", "06 6002 0010"}),
         shown({"06 6002 0040"}),
         "03 22 03 00 01",
         shown({"06 0033 1111"})},
        // Oriental Motor AZ: direct data operation 0058h-0067h in one request (the trigger word
        // 0066h-0067h = 1 inside it); ZHOME and STOP are rising edges on NET-IN 007Dh.
        {"oriental-az",
         shown({"06 007D 0010", "06 007D 0000"}),
         shown({"10 0058 0010 20 0000 0000 0000 0001 0000 04E2 0000 0BB8 0000 1770 0000 1770 "
                "0000 03E8 0000 0001"}),
         shown({"06 007D 0020", "06 007D 0000"}),
         "03 00 80 00 02",
         shown({"10 0180 0002 04 0000 0001"})},
        // generic: 40001-40009 (wire 0-8), 32-bit values low word first, command 40009.
        {"generic",
         shown({"06 0008 0002"}),
         shown({"10 0000 0009 12 30D4 0000 7530 0000 EA60 0000 EA60 0000 0001"}),
         shown({"06 0008 0003"}),
         "03 00 0B 00 01",
         shown({"06 0008 0004"})},
    };
}

class ProfileSequence : public ::testing::TestWithParam<Sequence> {};

TEST_P(ProfileSequence, RequestsMatchTheManual) {
    const Sequence& e = GetParam();
    auto p = gonio::devices::load_axis_profile(e.profile);
    ASSERT_TRUE(p) << p.error().message;
    RecordingServer server;
    gonio::devices::Motion m;
    m.speed_deg_per_s = 30;
    m.accel_deg_per_s2 = 60;
    auto axis = gonio::devices::open_axis("seq",
                                          "tcp://127.0.0.1:" + std::to_string(server.port()),
                                          1,
                                          e.profile,
                                          gonio::devices::SoftLimits{-170, 170},
                                          m);
    ASSERT_TRUE(axis) << axis.error().message;
    const int status_wire = *gonio::devices::wire_address(*p, p->status.reg.address);
    const int pos_wire = *gonio::devices::wire_address(*p, p->position.address);
    const int alarm_wire = *gonio::devices::wire_address(*p, p->alarm_code.address);
    auto status_word = [&](std::initializer_list<int> bits) {
        std::uint32_t w = 0;
        for (int b : bits) {
            w |= 1U << b;
        }
        server.set_words(status_wire,
                         gonio::devices::encode_value(w, p->status.reg.width, p->word_order));
    };
    auto position = [&](double deg) {
        server.set_words(
            pos_wire,
            gonio::devices::encode_value(
                gonio::devices::degrees_to_steps(*p, deg), p->position.width, p->word_order));
    };
    const auto timeout = std::chrono::milliseconds(5000);

    // Home: the drive reports "homed, not moving" at once.
    status_word({p->status.homed, p->status.in_position});
    position(0);
    ASSERT_TRUE((*axis)->home(timeout));
    EXPECT_EQ(writes(server.take()), e.home);

    // Move: the drive reports "in position" at the target.
    position(12.5);
    auto mv = (*axis)->move_to(12.5, timeout);
    ASSERT_TRUE(mv) << mv.error().message;
    EXPECT_EQ(writes(server.take()), e.move);

    ASSERT_TRUE((*axis)->stop());
    EXPECT_EQ(writes(server.take()), e.stop);

    // Alarm read: the alarm bit is up, the present alarm register holds 0x1A5.
    status_word({p->status.alarm});
    server.set_words(alarm_wire,
                     gonio::devices::encode_value(0x1A5, p->alarm_code.width, p->word_order));
    auto st = (*axis)->status();
    ASSERT_TRUE(st) << st.error().message;
    EXPECT_EQ(st->state, gonio::devices::AxisState::kAlarm);
    EXPECT_EQ(st->alarm_code, 0x1A5);
    bool read_alarm = false;
    for (const Bytes& pdu : server.take()) {
        read_alarm = read_alarm || show(pdu) == show(hex(e.alarm_read));
    }
    EXPECT_TRUE(read_alarm) << "no request " << e.alarm_read;

    ASSERT_TRUE((*axis)->reset_alarm());
    EXPECT_EQ(writes(server.take()), e.reset);
}

INSTANTIATE_TEST_SUITE_P(Shipped,
                         ProfileSequence,
                         ::testing::ValuesIn(expected_sequences()),
                         [](const auto& info) {
                             std::string n = info.param.profile;
                             for (char& c : n) {
                                 if (c == '-') {
                                     c = '_';
                                 }
                             }
                             return n;
                         });

TEST(ProfileSequence, EveryShippedRegisterCitesTheManual) {
    for (const char* name : {"generic", "oriental-az", "leadshine"}) {
        auto p = gonio::devices::load_axis_profile(name);
        ASSERT_TRUE(p) << p.error().message;
        EXPECT_FALSE(p->position.section.empty()) << name;
        EXPECT_FALSE(p->status.reg.section.empty()) << name;
        EXPECT_FALSE(p->alarm_code.section.empty()) << name;
        for (const auto* a : {&p->move, &p->home, &p->stop, &p->reset_alarm}) {
            if (a->block.present()) {
                EXPECT_FALSE(a->block.section.empty()) << name;
            }
            if (a->trigger.kind != gonio::devices::TriggerKind::kNone) {
                EXPECT_FALSE(a->trigger.reg.section.empty()) << name;
            }
        }
    }
}

}  // namespace
