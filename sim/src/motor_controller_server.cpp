#include "gonio/sim/motor_controller_server.h"

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

namespace gonio::sim {
namespace {

using devices::Action;
using devices::AxisProfile;
using devices::RegisterField;
using devices::TriggerKind;
using Clock = std::chrono::steady_clock;

/// CRC-16/MODBUS (polynomial 0xA001 reflected, initial 0xFFFF), Modbus over Serial Line V1.02,
/// section 6.2.2; transmitted low byte first.
std::uint16_t crc16(const std::uint8_t* data, size_t n) {
    std::uint16_t crc = 0xFFFF;
    for (size_t i = 0; i < n; ++i) {
        crc ^= data[i];
        for (int b = 0; b < 8; ++b) {
            crc = (crc & 1U) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001U)
                                  : static_cast<std::uint16_t>(crc >> 1);
        }
    }
    return crc;
}

int wire(const AxisProfile& p, int documented) {
    auto w = devices::wire_address(p, documented);
    return w ? *w : -1;
}

struct Unit {
    int id = 0;
    bool has_motor = false;
    AxisProfile profile;
    MotorSimConfig cfg;
    std::unique_ptr<MotorSim> sim;
    double spd = 1;  ///< Signed steps per degree (profile scale times direction).
    std::vector<std::uint16_t> tab =
        std::vector<std::uint16_t>(0x10000, 0);                              ///< Holding registers.
    std::vector<std::uint8_t> bits = std::vector<std::uint8_t>(0x10000, 0);  ///< Coils.
    std::set<int> regs;       ///< Valid holding-register wire addresses.
    std::set<int> read_only;  ///< Registers the drive writes itself (status, position, alarm).
    std::set<int> coils;      ///< Valid coil wire addresses.
    int shutter_coil = -1;
    std::uint64_t requests = 0;
    // Clock: simulated time = sim_base + (wall - wall_base) * scale.
    double sim_base = 0;
    Clock::time_point wall_base;
    double scale = 1;
    double last_decel = 0;

    double now(Clock::time_point wall) const {
        return sim_base + std::chrono::duration<double>(wall - wall_base).count() * scale;
    }
    void add_field(const RegisterField& f) {
        const int w = wire(profile, f.address);
        for (int k = 0; k < f.count(); ++k) {
            regs.insert(w + k);
        }
    }
    void add_action(const Action& a) {
        if (a.block.present()) {
            const int w = wire(profile, a.block.address);
            for (int k = 0; k < a.block.register_count(); ++k) {
                regs.insert(w + k);
            }
        }
        if (a.trigger.kind != TriggerKind::kNone) {
            add_field(a.trigger.reg);
        }
    }
    void put(const RegisterField& f, std::int64_t v) {
        const auto words = devices::encode_value(v, f.width, profile.word_order);
        const int w = wire(profile, f.address);
        for (size_t k = 0; k < words.size(); ++k) {
            tab[static_cast<size_t>(w) + k] = words[k];
        }
    }
    std::uint32_t get(const RegisterField& f) const {
        return static_cast<std::uint32_t>(devices::decode_value(
            tab.data() + wire(profile, f.address), f.width, false, profile.word_order));
    }
};

struct ActiveFault {
    Fault f;
    int remaining = 0;
};

using Bytes = std::vector<std::uint8_t>;

/// Complete frames served per connection per turn of the event loop (fairness under a flood).
constexpr int kFramesPerTurn = 8;
/// Unserved input held per connection; beyond it the connection is not read until served.
constexpr size_t kMaxInputBytes = 4096;
/// Kernel send buffer of a client socket: small, so that a client that does not read shows up in
/// our own bounded output buffer soon.
constexpr int kSocketSendBuffer = 16 * 1024;

/// MBAP header (transaction id, protocol id, length, unit id), Modbus Messaging on TCP/IP V1.0b.
constexpr int kTcpHeaderLength = 7;

}  // namespace

struct MotorControllerServer::Impl {
    mutable std::mutex mu;
    std::map<int, std::unique_ptr<Unit>> units;
    std::deque<ActiveFault> reply_faults;
    std::uint64_t total_requests = 0;
    ServerOptions options;
    bool blip_pending = false;  ///< A simulated blip was requested (taken by the event loop).
    std::chrono::milliseconds blip_length{0};
    int listen_fd = -1;
    int pty_master = -1;
    int pty_slave_keep = -1;
    std::string pty_path;
    int bound_port = 0;
    int wake[2] = {-1, -1};
    std::thread thread;
    std::atomic<bool> running{false};

    ~Impl() { close_all(); }

    void close_all() {
        if (listen_fd >= 0) {
            ::close(listen_fd);
            listen_fd = -1;
        }
        if (pty_master >= 0) {
            ::close(pty_master);
            pty_master = -1;
        }
        if (pty_slave_keep >= 0) {
            ::close(pty_slave_keep);
            pty_slave_keep = -1;
        }
        for (int& fd : wake) {
            if (fd >= 0) {
                ::close(fd);
                fd = -1;
            }
        }
    }

    Unit* unit_locked(int id) {
        auto it = units.find(id);
        return it == units.end() ? nullptr : it->second.get();
    }

    /// Writes the drive's readable state into its registers.
    void refresh(Unit& u, double t) {
        if (!u.has_motor) {
            return;
        }
        MotorSim& m = *u.sim;
        m.update(t);
        const devices::StatusBits& sb = u.profile.status;
        std::uint32_t w = 0;
        auto set = [&](int bit, bool on) {
            if (bit >= 0 && on) {
                w |= 1U << bit;
            }
        };
        set(sb.moving, m.moving());
        set(sb.in_position, m.in_position());
        set(sb.homed, m.homed());
        set(sb.alarm, m.alarm_code() != 0);
        set(sb.homing, m.homing());
        set(sb.ready, m.alarm_code() == 0 && !m.moving());
        u.put(sb.reg, w);
        u.put(u.profile.alarm_code, m.alarm_code());
        u.put(u.profile.position, m.read_counter_steps());
    }

    void fire(Unit& u, const char* action, double t) {
        MotorSim& m = *u.sim;
        const AxisProfile& p = u.profile;
        const double aspd = std::fabs(u.spd);
        if (std::strcmp(action, "move") == 0) {
            const auto in = devices::decode_block(
                p, p.move.block, u.tab.data() + wire(p, p.move.block.address));
            const double decel =
                in.decel_steps_per_s2 > 0 ? in.decel_steps_per_s2 : in.accel_steps_per_s2;
            u.last_decel = decel;
            m.start_move(t, in.target_steps, in.speed_steps_per_s, in.accel_steps_per_s2, decel);
        } else if (std::strcmp(action, "home") == 0) {
            const double v = p.home_speed_deg_per_s * aspd;
            m.start_home(t, v, 4 * v);
        } else if (std::strcmp(action, "stop") == 0) {
            m.stop(t, u.last_decel > 0 ? u.last_decel : 4 * p.home_speed_deg_per_s * aspd);
        } else {
            m.reset_alarm();
        }
    }

    /// After a write covering wire registers [lo, hi): runs the actions whose trigger fired.
    void after_write(Unit& u, int lo, int hi, const std::vector<std::uint16_t>& before, double t) {
        const AxisProfile& p = u.profile;
        // Fault registers.
        if (lo <= kFaultRegister && kFaultRegister < hi) {
            std::uint16_t* r = u.tab.data() + kFaultRegister;
            if (r[0] >= 1 && r[0] <= 5) {
                Fault f;
                f.kind = static_cast<FaultKind>(r[0] - 1);
                f.unit = u.id;
                f.count = r[1] > 0 ? r[1] : 1;
                f.delay = std::chrono::milliseconds(r[2]);
                if (f.kind == FaultKind::kException) {
                    f.exception_code = r[3] > 0 ? r[3] : 6;
                } else {
                    f.alarm_code = r[3];
                }
                f.fraction = r[4] > 0 ? r[4] / 1000.0 : 0.5;
                inject_locked(f);
            }
            r[0] = 0;
        }
        if (!u.has_motor) {
            return;
        }
        const std::pair<const char*, const Action*> actions[] = {
            {"move", &p.move}, {"home", &p.home}, {"stop", &p.stop}, {"reset", &p.reset_alarm}};
        for (const auto& [name, act] : actions) {
            const devices::Trigger& tr = act->trigger;
            if (tr.kind == TriggerKind::kNone) {
                continue;
            }
            const int w = wire(p, tr.reg.address);
            if (w + tr.reg.count() <= lo || w >= hi) {
                continue;
            }
            const std::uint32_t now_v = u.get(tr.reg);
            if (tr.kind == TriggerKind::kWriteValue) {
                if (now_v == tr.value) {
                    fire(u, name, t);
                    u.put(tr.reg, 0);  // The drive consumes the command.
                }
            } else {
                // Rising edge of an input bit.
                std::vector<std::uint16_t> old_words(static_cast<size_t>(tr.reg.count()));
                for (int k = 0; k < tr.reg.count(); ++k) {
                    const int a = w + k;
                    old_words[static_cast<size_t>(k)] = (a >= lo && a < hi)
                                                            ? before[static_cast<size_t>(a - lo)]
                                                            : u.tab[static_cast<size_t>(a)];
                }
                const auto old_v = static_cast<std::uint32_t>(
                    devices::decode_value(old_words.data(), tr.reg.width, false, p.word_order));
                const std::uint32_t mask = 1U << tr.bit;
                if ((old_v & mask) == 0 && (now_v & mask) != 0) {
                    fire(u, name, t);
                }
            }
        }
    }

    void inject_locked(const Fault& f) {
        if (f.kind == FaultKind::kAlarmMidMove || f.kind == FaultKind::kStall) {
            for (auto& [id, u] : units) {
                if (!u->has_motor || (f.unit != 0 && f.unit != id)) {
                    continue;
                }
                if (f.kind == FaultKind::kAlarmMidMove) {
                    u->sim->arm_alarm(
                        f.fraction,
                        f.alarm_code != 0 ? f.alarm_code : u->profile.alarm_codes.overload);
                } else {
                    u->sim->arm_stall(f.fraction, u->profile.alarm_codes.deviation);
                }
            }
            return;
        }
        reply_faults.push_back({f, std::max(1, f.count)});
    }

    /// A reply PDU for `fc` carrying exception `code` (Modbus Application Protocol V1.1b3,
    /// section 7: the function code with its high bit set, then the code).
    static Bytes exception_pdu(int fc, int code) {
        return {static_cast<std::uint8_t>((fc | 0x80) & 0xFF), static_cast<std::uint8_t>(code)};
    }

    /// Are wire addresses [addr, addr + qty) all present in `valid` (and, for writes, none of them
    /// read-only)?
    static bool range_ok(const Unit& u, const std::set<int>& valid, int addr, int qty, bool write) {
        if (addr + qty > 0x10000) {
            return false;
        }
        for (int a = addr; a < addr + qty; ++a) {
            if (valid.count(a) == 0 || (write && u.read_only.count(a) != 0)) {
                return false;
            }
        }
        return true;
    }

    /// Executes one request PDU on a unit and returns the response PDU. The checks follow the
    /// service flowcharts of the Modbus Application Protocol V1.1b3 (section 6): an unsupported
    /// function is exception 1; a quantity out of range, a byte count that disagrees with it or a
    /// PDU of the wrong length is exception 3; an address range outside the drive's registers (or
    /// a write to a register the drive writes itself) is exception 2. Call with `mu` held.
    Bytes execute(Unit& u, const Bytes& pdu) {
        const int fc = pdu[0];
        const size_t n = pdu.size();
        auto u16 = [&](size_t i) { return (pdu[i] << 8) | pdu[i + 1]; };
        const double t = u.now(Clock::now());
        switch (fc) {
            case 1:
            case 3: {
                if (n != 5) {
                    return exception_pdu(fc, 3);
                }
                const int addr = u16(1);
                const int qty = u16(3);
                if (qty < 1 || qty > (fc == 1 ? 2000 : 125)) {
                    return exception_pdu(fc, 3);
                }
                if (!range_ok(u, fc == 1 ? u.coils : u.regs, addr, qty, false)) {
                    return exception_pdu(fc, 2);
                }
                refresh(u, t);
                Bytes r{static_cast<std::uint8_t>(fc)};
                if (fc == 3) {
                    r.push_back(static_cast<std::uint8_t>(2 * qty));
                    for (int k = 0; k < qty; ++k) {
                        const std::uint16_t v = u.tab[static_cast<size_t>(addr + k)];
                        r.push_back(static_cast<std::uint8_t>(v >> 8));
                        r.push_back(static_cast<std::uint8_t>(v & 0xFF));
                    }
                } else {
                    const int bc = (qty + 7) / 8;
                    r.push_back(static_cast<std::uint8_t>(bc));
                    r.resize(r.size() + static_cast<size_t>(bc), 0);
                    for (int k = 0; k < qty; ++k) {
                        if (u.bits[static_cast<size_t>(addr + k)] != 0) {
                            r[2 + static_cast<size_t>(k / 8)] |=
                                static_cast<std::uint8_t>(1U << (k % 8));
                        }
                    }
                }
                return r;
            }
            case 5: {
                if (n != 5) {
                    return exception_pdu(fc, 3);
                }
                const int addr = u16(1);
                const int v = u16(3);
                if (v != 0x0000 && v != 0xFF00) {
                    return exception_pdu(fc, 3);
                }
                if (!range_ok(u, u.coils, addr, 1, true)) {
                    return exception_pdu(fc, 2);
                }
                u.bits[static_cast<size_t>(addr)] = v != 0 ? 1 : 0;
                return pdu;
            }
            case 15: {
                if (n < 6) {
                    return exception_pdu(fc, 3);
                }
                const int addr = u16(1);
                const int qty = u16(3);
                const int bc = pdu[5];
                if (qty < 1 || qty > 0x07B0 || bc != (qty + 7) / 8 ||
                    n != 6 + static_cast<size_t>(bc)) {
                    return exception_pdu(fc, 3);
                }
                if (!range_ok(u, u.coils, addr, qty, true)) {
                    return exception_pdu(fc, 2);
                }
                for (int k = 0; k < qty; ++k) {
                    u.bits[static_cast<size_t>(addr + k)] =
                        (pdu[6 + static_cast<size_t>(k / 8)] >> (k % 8)) & 1U;
                }
                return Bytes(pdu.begin(), pdu.begin() + 5);
            }
            case 6:
            case 16: {
                int addr = 0;
                int qty = 1;
                size_t data = 3;
                if (fc == 6) {
                    if (n != 5) {
                        return exception_pdu(fc, 3);
                    }
                    addr = u16(1);
                } else {
                    if (n < 6) {
                        return exception_pdu(fc, 3);
                    }
                    addr = u16(1);
                    qty = u16(3);
                    const int bc = pdu[5];
                    if (qty < 1 || qty > 0x7B || bc != 2 * qty ||
                        n != 6 + static_cast<size_t>(bc)) {
                        return exception_pdu(fc, 3);
                    }
                    data = 6;
                }
                if (!range_ok(u, u.regs, addr, qty, true)) {
                    return exception_pdu(fc, 2);
                }
                refresh(u, t);
                std::vector<std::uint16_t> before(u.tab.begin() + addr, u.tab.begin() + addr + qty);
                for (int k = 0; k < qty; ++k) {
                    u.tab[static_cast<size_t>(addr + k)] =
                        static_cast<std::uint16_t>(u16(data + 2 * static_cast<size_t>(k)));
                }
                after_write(u, addr, addr + qty, before, t);
                return fc == 6 ? pdu : Bytes(pdu.begin(), pdu.begin() + 5);
            }
            default:
                return exception_pdu(fc, 1);
        }
    }

    /// What the transport does with a request.
    struct Answer {
        enum Kind { kReply, kSilent, kDrop } kind = kSilent;
        Bytes pdu;
        std::chrono::milliseconds delay{0};
    };

    /// Looks up the unit, applies injected reply faults and executes the request.
    Answer process(int unit_id, const Bytes& pdu, bool rtu) {
        std::lock_guard<std::mutex> lock(mu);
        ++total_requests;
        Answer a;
        const int fc = pdu[0];
        if (rtu && unit_id == 0) {
            // Broadcast (Modbus over Serial Line V1.02, section 2.1): writes are executed by every
            // unit, nobody answers; a broadcast read means nothing and is ignored.
            if (fc == 5 || fc == 6 || fc == 15 || fc == 16) {
                for (auto& [id, u] : units) {
                    ++u->requests;
                    (void)execute(*u, pdu);
                }
            }
            return a;
        }
        Unit* u = unit_locked(unit_id);
        if (u == nullptr) {
            // RTU: an absent drive is silent. TCP: a gateway says its target did not answer.
            if (!rtu) {
                a.kind = Answer::kReply;
                a.pdu = exception_pdu(fc, 0x0B);
            }
            return a;
        }
        ++u->requests;
        for (auto it = reply_faults.begin(); it != reply_faults.end(); ++it) {
            if (it->f.unit != 0 && it->f.unit != unit_id) {
                continue;
            }
            const Fault f = it->f;
            if (--it->remaining <= 0) {
                reply_faults.erase(it);
            }
            if (f.kind == FaultKind::kDelayReply) {
                a.delay = f.delay;  // The simulated drive is slow to answer.
            } else if (f.kind == FaultKind::kDropConnection) {
                a.kind = rtu ? Answer::kSilent : Answer::kDrop;
                return a;
            } else {
                a.kind = Answer::kReply;
                a.pdu = exception_pdu(fc, f.exception_code);
                return a;
            }
            break;
        }
        a.kind = Answer::kReply;
        a.pdu = execute(*u, pdu);
        return a;
    }

    void log(const std::string& line) {
        if (options.log != nullptr) {
            std::fprintf(options.log, "sim: %s\n", line.c_str());
            std::fflush(options.log);
        }
    }

    /// One TCP client: its own input and output buffers, never a blocking call.
    struct Conn {
        int fd = -1;
        std::uint64_t id = 0;
        Bytes in;
        Clock::time_point partial_since;  ///< When the incomplete frame in `in` began.
        Bytes out;
        std::deque<std::pair<Clock::time_point, Bytes>> delayed;  ///< Replies held back.
        bool backlog = false;  ///< Complete frames left in `in` for the next turn.
    };

    /// Queues a reply behind any delayed one (replies leave in request order).
    static void queue_reply(Conn& c,
                            Bytes adu,
                            std::chrono::milliseconds delay,
                            Clock::time_point now) {
        if (delay.count() > 0 || !c.delayed.empty()) {
            Clock::time_point due = now + delay;
            if (!c.delayed.empty()) {
                due = std::max(due, c.delayed.back().first);
            }
            c.delayed.emplace_back(due, std::move(adu));
            return;
        }
        c.out.insert(c.out.end(), adu.begin(), adu.end());
    }

    /// Parses and answers at most `budget` complete MBAP frames of a connection. False: the stream
    /// cannot be trusted any more (the connection is closed).
    bool serve_frames(Conn& c, int budget, Clock::time_point now) {
        size_t off = 0;
        int done = 0;
        while (c.in.size() - off >= static_cast<size_t>(kTcpHeaderLength)) {
            if (done == budget) {
                c.backlog = true;
                break;
            }
            const std::uint8_t* h = c.in.data() + off;
            const int pid = (h[2] << 8) | h[3];
            const int len = (h[4] << 8) | h[5];
            // The length counts the unit id and the PDU: a PDU has 1 to 253 bytes.
            if (len < 2 || len > 254) {
                log("client " + std::to_string(c.id) + ": MBAP length " + std::to_string(len) +
                    " not in [2, 254]; connection closed (the frame boundaries are lost)");
                return false;
            }
            if (c.in.size() - off < static_cast<size_t>(6 + len)) {
                break;
            }
            if (pid == 0) {
                Bytes pdu(h + kTcpHeaderLength, h + 6 + len);
                Answer a = process(h[6], pdu, false);
                if (a.kind == Answer::kDrop) {
                    return false;
                }
                if (a.kind == Answer::kReply) {
                    const size_t rl = a.pdu.size() + 1;
                    Bytes adu{h[0],
                              h[1],
                              0,
                              0,
                              static_cast<std::uint8_t>(rl >> 8),
                              static_cast<std::uint8_t>(rl & 0xFF),
                              h[6]};
                    adu.insert(adu.end(), a.pdu.begin(), a.pdu.end());
                    queue_reply(c, std::move(adu), a.delay, now);
                }
            }
            // A protocol id other than 0 is not Modbus: the frame is discarded unanswered.
            off += static_cast<size_t>(6 + len);
            ++done;
        }
        if (done < budget) {
            c.backlog = false;
        }
        if (off > 0) {
            c.in.erase(c.in.begin(), c.in.begin() + static_cast<long>(off));
            c.partial_since = now;
        }
        return true;
    }

    /// Writes what the socket takes now. False: the peer is gone.
    static bool flush(int fd, Bytes& out) {
        while (!out.empty()) {
            const ssize_t n = ::send(fd, out.data(), out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n < 0) {
                if (errno == EINTR) {
                    continue;
                }
                return errno == EAGAIN || errno == EWOULDBLOCK;
            }
            out.erase(out.begin(), out.begin() + n);
        }
        return true;
    }

    static int make_listener(int port, std::string* err) {
        const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        if (fd < 0) {
            *err = std::strerror(errno);
            return -1;
        }
        const int one = 1;
        ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        sockaddr_in sa{};
        sa.sin_family = AF_INET;
        sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        sa.sin_port = htons(static_cast<std::uint16_t>(port));
        if (::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0 ||
            ::listen(fd, 128) != 0) {
            *err = std::strerror(errno);
            ::close(fd);
            return -1;
        }
        return fd;
    }

    void drain_wake() {
        char buf[64];
        while (::read(wake[0], buf, sizeof buf) > 0) {
        }
    }

    /// Takes a pending blip request: returns the time the link comes back (or nullopt).
    std::optional<Clock::time_point> take_blip() {
        std::lock_guard<std::mutex> lock(mu);
        if (!blip_pending) {
            return std::nullopt;
        }
        blip_pending = false;
        return Clock::now() + blip_length;
    }

    void serve_tcp() {
        std::vector<std::unique_ptr<Conn>> conns;
        std::uint64_t next_id = 1;
        std::uint64_t refused = 0;
        // A descriptor kept in reserve: when the process runs out of descriptors, it is released
        // to accept and close the pending connection, so the listener does not spin.
        int spare = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
        bool down = false;
        Clock::time_point down_until = Clock::now();
        std::vector<pollfd> fds;
        const auto frame_timeout = std::chrono::milliseconds(options.frame_timeout_ms);
        auto close_conn = [&](size_t i) {
            ::close(conns[i]->fd);
            conns.erase(conns.begin() + static_cast<long>(i));
        };
        while (running) {
            auto now = Clock::now();
            if (auto b = take_blip()) {
                // The gateway loses power: every connection and the listener go away.
                for (auto& c : conns) {
                    ::close(c->fd);
                }
                conns.clear();
                if (listen_fd >= 0) {
                    ::close(listen_fd);
                    listen_fd = -1;
                }
                down = true;
                down_until = *b;
                log("link down for " + std::to_string(blip_length.count()) +
                    " ms (simulated blip)");
            }
            if (down && now >= down_until) {
                std::string err;
                listen_fd = make_listener(bound_port, &err);
                if (listen_fd >= 0) {
                    down = false;
                    log("link up again on 127.0.0.1:" + std::to_string(bound_port));
                } else {
                    down_until = now + std::chrono::milliseconds(50);
                }
            }
            // Poll timeout: the next delayed reply, partial-frame deadline or blip end.
            auto next = now + std::chrono::milliseconds(1000);
            bool busy = false;
            for (const auto& c : conns) {
                if (!c->delayed.empty()) {
                    next = std::min(next, c->delayed.front().first);
                }
                if (!c->in.empty() && frame_timeout.count() > 0) {
                    next = std::min(next, c->partial_since + frame_timeout);
                }
                busy = busy || c->backlog;
            }
            if (down) {
                next = std::min(next, down_until);
            }
            fds.clear();
            fds.push_back({wake[0], POLLIN, 0});
            fds.push_back({listen_fd, POLLIN, 0});  // A negative fd is ignored by poll().
            for (const auto& c : conns) {
                // A connection with unserved input is not read further (its sender waits, nobody
                // else does).
                const short want_in = c->in.size() < kMaxInputBytes ? POLLIN : 0;
                fds.push_back(
                    {c->fd, static_cast<short>(want_in | (c->out.empty() ? 0 : POLLOUT)), 0});
            }
            const auto wait_ms = std::chrono::duration_cast<std::chrono::milliseconds>(next - now);
            const int timeout =
                busy ? 0 : static_cast<int>(std::max<long long>(0, wait_ms.count() + 1));
            const int rc = ::poll(fds.data(), fds.size(), timeout);
            if (rc < 0 && errno != EINTR) {
                break;
            }
            now = Clock::now();
            if ((fds[0].revents & POLLIN) != 0) {
                drain_wake();
                continue;  // Stop or blip: re-check at the top.
            }
            if (listen_fd >= 0 && (fds[1].revents & POLLIN) != 0) {
                for (int k = 0; k < 64; ++k) {
                    const int c =
                        ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
                    if (c < 0) {
                        if ((errno == EMFILE || errno == ENFILE) && spare >= 0) {
                            ::close(spare);
                            const int x = ::accept(listen_fd, nullptr, nullptr);
                            if (x >= 0) {
                                ::close(x);
                            }
                            spare = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
                            log("out of file descriptors: refused a connection");
                            continue;
                        }
                        break;
                    }
                    if (static_cast<int>(conns.size()) >= options.max_connections) {
                        ::close(c);
                        if (refused++ % 100 == 0) {
                            log("connection limit " + std::to_string(options.max_connections) +
                                " reached: refused a connection (" + std::to_string(refused) +
                                " refused so far)");
                        }
                        continue;
                    }
                    const int one = 1;
                    ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
                    ::setsockopt(
                        c, SOL_SOCKET, SO_SNDBUF, &kSocketSendBuffer, sizeof kSocketSendBuffer);
                    auto conn = std::make_unique<Conn>();
                    conn->fd = c;
                    conn->id = next_id++;
                    conns.push_back(std::move(conn));
                }
            }
            // Existing connections (the ones accepted just now are served next turn).
            for (size_t i = 0, pi = 2; i < conns.size(); ++pi) {
                Conn& c = *conns[i];
                const short re = pi < fds.size() && fds[pi].fd == c.fd ? fds[pi].revents : 0;
                bool ok = true;
                if ((re & (POLLIN | POLLHUP | POLLERR)) != 0 && c.in.size() < kMaxInputBytes) {
                    std::uint8_t buf[4096];
                    const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
                    if (n > 0) {
                        if (c.in.empty()) {
                            c.partial_since = now;
                        }
                        c.in.insert(c.in.end(), buf, buf + n);
                    } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
                        ok = false;
                    }
                }
                if (ok && (!c.in.empty())) {
                    ok = serve_frames(c, kFramesPerTurn, now);
                }
                while (ok && !c.delayed.empty() && c.delayed.front().first <= now) {
                    c.out.insert(c.out.end(),
                                 c.delayed.front().second.begin(),
                                 c.delayed.front().second.end());
                    c.delayed.pop_front();
                }
                if (ok && !c.out.empty()) {
                    ok = flush(c.fd, c.out);
                }
                if (ok && c.out.size() > options.max_output_bytes) {
                    log("client " + std::to_string(c.id) + " does not read its replies (" +
                        std::to_string(c.out.size()) + " bytes pending, limit " +
                        std::to_string(options.max_output_bytes) + "): connection closed");
                    ok = false;
                }
                if (ok && !c.in.empty() && !c.backlog && frame_timeout.count() > 0 &&
                    now - c.partial_since > frame_timeout) {
                    log("client " + std::to_string(c.id) + ": incomplete frame (" +
                        std::to_string(c.in.size()) + " bytes) for more than " +
                        std::to_string(options.frame_timeout_ms) + " ms: connection closed");
                    ok = false;
                }
                if (!ok) {
                    close_conn(i);
                    continue;
                }
                ++i;
            }
        }
        for (auto& c : conns) {
            ::close(c->fd);
        }
        if (spare >= 0) {
            ::close(spare);
        }
    }

    /// Length of the RTU request frame at the start of buf (0 = need more bytes). Request layouts
    /// from the Modbus Application Protocol V1.1b3. A function this server does not know has no
    /// known length: the frame is the shortest prefix whose last two bytes are its CRC.
    static size_t rtu_frame_length(const Bytes& buf) {
        if (buf.size() < 2) {
            return 0;
        }
        switch (buf[1]) {
            case 1:
            case 2:
            case 3:
            case 4:
            case 5:
            case 6:
                return 8;
            case 15:
            case 16:
                return buf.size() < 7 ? 0 : 9 + static_cast<size_t>(buf[6]);
            default:
                for (size_t n = 4; n <= buf.size(); ++n) {
                    const std::uint16_t crc = crc16(buf.data(), n - 2);
                    if (buf[n - 2] == (crc & 0xFF) && buf[n - 1] == (crc >> 8)) {
                        return n;
                    }
                }
                return 0;
        }
    }

    void serve_rtu() {
        Bytes buf;
        Bytes out;
        std::deque<std::pair<Clock::time_point, Bytes>> delayed;
        bool down = false;
        Clock::time_point down_until = Clock::now();
        std::uint8_t chunk[512];
        Clock::time_point partial_since = Clock::now();
        // A partial frame that stays incomplete for 50 ms is noise: drop it (the RTU inter-frame
        // silence is 3.5 characters; a pty has no line timing).
        const auto partial_timeout = std::chrono::milliseconds(50);
        while (running) {
            auto now = Clock::now();
            if (auto b = take_blip()) {
                down = true;
                down_until = *b;
                buf.clear();
                log("line silent for " + std::to_string(blip_length.count()) +
                    " ms (simulated blip)");
            }
            if (down && now >= down_until) {
                down = false;
            }
            auto next = now + std::chrono::milliseconds(1000);
            if (!buf.empty()) {
                next = std::min(next, partial_since + partial_timeout);
            }
            if (!delayed.empty()) {
                next = std::min(next, delayed.front().first);
            }
            if (down) {
                next = std::min(next, down_until);
            }
            pollfd fds[2] = {
                {wake[0], POLLIN, 0},
                {pty_master, static_cast<short>(POLLIN | (out.empty() ? 0 : POLLOUT)), 0}};
            const auto wait_ms = std::chrono::duration_cast<std::chrono::milliseconds>(next - now);
            const int rc =
                ::poll(fds, 2, static_cast<int>(std::max<long long>(0, wait_ms.count() + 1)));
            if (rc < 0 && errno != EINTR) {
                break;
            }
            now = Clock::now();
            if ((fds[0].revents & POLLIN) != 0) {
                drain_wake();
                continue;
            }
            if (!buf.empty() && now - partial_since > partial_timeout) {
                buf.clear();
            }
            if ((fds[1].revents & POLLIN) != 0) {
                const ssize_t n = ::read(pty_master, chunk, sizeof chunk);
                if (n > 0 && !down) {
                    if (buf.empty()) {
                        partial_since = now;
                    }
                    buf.insert(buf.end(), chunk, chunk + n);
                }
            }
            for (;;) {
                const size_t flen = rtu_frame_length(buf);
                if (flen == 0 || buf.size() < flen) {
                    if (buf.size() > 256) {
                        buf.clear();  // Longer than any RTU frame: noise.
                    }
                    break;
                }
                const std::uint16_t crc = crc16(buf.data(), flen - 2);
                if (buf[flen - 2] != (crc & 0xFF) || buf[flen - 1] != (crc >> 8)) {
                    buf.clear();  // Garbled: wait for the master to retry.
                    break;
                }
                const int unit_id = buf[0];
                Bytes pdu(buf.begin() + 1, buf.begin() + static_cast<long>(flen) - 2);
                buf.erase(buf.begin(), buf.begin() + static_cast<long>(flen));
                partial_since = now;
                Answer a = process(unit_id, pdu, true);
                if (a.kind != Answer::kReply) {
                    continue;
                }
                Bytes adu{static_cast<std::uint8_t>(unit_id)};
                adu.insert(adu.end(), a.pdu.begin(), a.pdu.end());
                const std::uint16_t c2 = crc16(adu.data(), adu.size());
                adu.push_back(static_cast<std::uint8_t>(c2 & 0xFF));
                adu.push_back(static_cast<std::uint8_t>(c2 >> 8));
                if (a.delay.count() > 0 || !delayed.empty()) {
                    auto due = now + a.delay;
                    if (!delayed.empty()) {
                        due = std::max(due, delayed.back().first);
                    }
                    delayed.emplace_back(due, std::move(adu));
                } else {
                    out.insert(out.end(), adu.begin(), adu.end());
                }
            }
            while (!delayed.empty() && delayed.front().first <= now) {
                out.insert(out.end(), delayed.front().second.begin(), delayed.front().second.end());
                delayed.pop_front();
            }
            if (!out.empty()) {
                const ssize_t n = ::write(pty_master, out.data(), out.size());
                if (n > 0) {
                    out.erase(out.begin(), out.begin() + n);
                }
                if (out.size() > options.max_output_bytes) {
                    out.clear();  // Nobody reads the line.
                }
            }
        }
    }
};

std::vector<std::uint16_t> fault_registers(const Fault& f) {
    const auto clamp16 = [](long long v) {
        return static_cast<std::uint16_t>(std::clamp<long long>(v, 0, 0xFFFF));
    };
    const int code = f.kind == FaultKind::kException ? f.exception_code : f.alarm_code;
    return {clamp16(1 + static_cast<int>(f.kind)),
            clamp16(f.count),
            clamp16(f.delay.count()),
            clamp16(code),
            clamp16(std::llround(f.fraction * 1000))};
}

Expected<FaultKind> parse_fault_kind(const std::string& name) {
    if (name == "delay") {
        return FaultKind::kDelayReply;
    }
    if (name == "drop") {
        return FaultKind::kDropConnection;
    }
    if (name == "exception") {
        return FaultKind::kException;
    }
    if (name == "alarm") {
        return FaultKind::kAlarmMidMove;
    }
    if (name == "stall") {
        return FaultKind::kStall;
    }
    return make_error("fault \"" + name + "\" not one of delay, drop, exception, alarm, stall");
}

MotorControllerServer::MotorControllerServer() : impl_(new Impl) {}

MotorControllerServer::~MotorControllerServer() {
    stop();
}

Expected<void> MotorControllerServer::add_unit(int unit,
                                               const devices::AxisProfile& profile,
                                               const MotorSimConfig& cfg) {
    if (unit < 1 || unit > 247) {
        return make_error("sim: unit " + std::to_string(unit) + " not in [1, 247]");
    }
    if (!(cfg.time_scale > 0) || !std::isfinite(cfg.time_scale)) {
        return make_error("sim: unit " + std::to_string(unit) + ": time_scale must be > 0");
    }
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u != nullptr && u->has_motor) {
        return make_error("sim: unit " + std::to_string(unit) + " already has a drive");
    }
    if (u == nullptr) {
        auto nu = std::make_unique<Unit>();
        nu->id = unit;
        for (int k = 0; k < kFaultRegisterCount; ++k) {
            nu->regs.insert(kFaultRegister + k);
        }
        u = nu.get();
        impl_->units[unit] = std::move(nu);
    }
    u->has_motor = true;
    u->profile = profile;
    u->cfg = cfg;
    u->spd = profile.steps_per_degree * profile.direction;
    u->sim = std::make_unique<MotorSim>(cfg, u->spd);
    u->sim->set_overtravel_code(profile.alarm_codes.overtravel);
    u->scale = cfg.time_scale;
    u->wall_base = Clock::now();
    u->sim_base = 0;
    u->add_field(profile.position);
    u->add_field(profile.status.reg);
    u->add_field(profile.alarm_code);
    // The drive writes these itself: a client's write is refused (exception 2).
    for (const RegisterField* f : {&profile.position, &profile.status.reg, &profile.alarm_code}) {
        const int w = wire(profile, f->address);
        for (int k = 0; k < f->count(); ++k) {
            u->read_only.insert(w + k);
        }
    }
    for (const Action* a : {&profile.move, &profile.home, &profile.stop, &profile.reset_alarm}) {
        u->add_action(*a);
    }
    for (int r : u->regs) {
        if (r < 0) {
            return make_error("sim: profile \"" + profile.name + "\" has an invalid address");
        }
    }
    impl_->refresh(*u, 0);
    return {};
}

Expected<void> MotorControllerServer::add_shutter(int unit, int coil) {
    if (unit < 1 || unit > 247 || coil < 0 || coil > 0xFFFF) {
        return make_error("sim: shutter unit " + std::to_string(unit) + " coil " +
                          std::to_string(coil) + " out of range");
    }
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr) {
        auto nu = std::make_unique<Unit>();
        nu->id = unit;
        for (int k = 0; k < kFaultRegisterCount; ++k) {
            nu->regs.insert(kFaultRegister + k);
        }
        nu->wall_base = Clock::now();
        u = nu.get();
        impl_->units[unit] = std::move(nu);
    }
    u->coils.insert(coil);
    u->shutter_coil = coil;
    return {};
}

Expected<void> MotorControllerServer::start(const ServerOptions& options) {
    if (impl_->running) {
        return make_error("sim: server already running");
    }
    impl_->close_all();
    impl_->options = options;
    if (::pipe2(impl_->wake, O_NONBLOCK | O_CLOEXEC) != 0) {
        return make_error(std::string("sim: pipe: ") + std::strerror(errno));
    }
    if (options.transport == Transport::kTcp) {
        std::string err;
        impl_->listen_fd = Impl::make_listener(options.port, &err);
        if (impl_->listen_fd < 0) {
            impl_->close_all();
            return make_error("sim: cannot listen on 127.0.0.1:" + std::to_string(options.port) +
                              ": " + err);
        }
        sockaddr_in sa{};
        socklen_t sl = sizeof sa;
        ::getsockname(impl_->listen_fd, reinterpret_cast<sockaddr*>(&sa), &sl);
        impl_->bound_port = ntohs(sa.sin_port);
    } else {
        const int m = ::posix_openpt(O_RDWR | O_NOCTTY);
        if (m < 0 || ::grantpt(m) != 0 || ::unlockpt(m) != 0) {
            if (m >= 0) {
                ::close(m);
            }
            return make_error(std::string("sim: pseudo-terminal: ") + std::strerror(errno));
        }
        impl_->pty_master = m;
        const char* name = ::ptsname(m);
        if (name == nullptr) {
            impl_->close_all();
            return make_error(std::string("sim: ptsname: ") + std::strerror(errno));
        }
        impl_->pty_path = name;
        termios tio{};
        ::tcgetattr(m, &tio);
        ::cfmakeraw(&tio);
        ::tcsetattr(m, TCSANOW, &tio);
        // Keep the slave side open so the master never sees a hang-up between clients; it is
        // never read (clients read their own descriptor).
        impl_->pty_slave_keep = ::open(name, O_RDWR | O_NOCTTY);
        if (impl_->pty_slave_keep >= 0) {
            termios st{};
            ::tcgetattr(impl_->pty_slave_keep, &st);
            ::cfmakeraw(&st);
            ::tcsetattr(impl_->pty_slave_keep, TCSANOW, &st);
        }
        ::fcntl(m, F_SETFL, ::fcntl(m, F_GETFL) | O_NONBLOCK);
    }
    impl_->running = true;
    impl_->thread = std::thread([this] {
        if (impl_->options.transport == Transport::kTcp) {
            impl_->serve_tcp();
        } else {
            impl_->serve_rtu();
        }
    });
    return {};
}

void MotorControllerServer::stop() {
    if (!impl_->running) {
        return;
    }
    impl_->running = false;
    const char c = 'x';
    (void)!::write(impl_->wake[1], &c, 1);
    if (impl_->thread.joinable()) {
        impl_->thread.join();
    }
    impl_->close_all();
}

bool MotorControllerServer::running() const {
    return impl_->running;
}

int MotorControllerServer::port() const {
    return impl_->bound_port;
}

std::string MotorControllerServer::device_path() const {
    return impl_->pty_path;
}

std::string MotorControllerServer::address() const {
    if (impl_->options.transport == Transport::kTcp) {
        return "tcp://127.0.0.1:" + std::to_string(impl_->bound_port);
    }
    return "rtu:" + impl_->pty_path + "?baud=" + std::to_string(impl_->options.baud) + "&parity=N";
}

void MotorControllerServer::blip(std::chrono::milliseconds down, bool drive_power_loss) {
    {
        std::lock_guard<std::mutex> lock(impl_->mu);
        impl_->blip_pending = true;
        impl_->blip_length = down;
        if (drive_power_loss) {
            // The drives lose power too: a move under way is lost (the stage coasts to a stop at
            // once in this model) and the position counter keeps its value.
            const auto wall = Clock::now();
            for (auto& [id, u] : impl_->units) {
                if (u->has_motor) {
                    u->sim->stop(u->now(wall), 1e12);
                }
            }
        }
    }
    const char c = 'b';
    (void)!::write(impl_->wake[1], &c, 1);
}

void MotorControllerServer::inject(const Fault& f) {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->inject_locked(f);
}

void MotorControllerServer::clear_faults() {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->reply_faults.clear();
    for (auto& [id, u] : impl_->units) {
        if (u->has_motor) {
            u->sim->disarm();
        }
    }
}

double MotorControllerServer::position_deg(int unit) const {
    auto s = snapshot(unit);
    return s ? s->position_deg : std::numeric_limits<double>::quiet_NaN();
}

std::map<int, double> MotorControllerServer::positions_deg() const {
    std::map<int, double> out;
    std::lock_guard<std::mutex> lock(impl_->mu);
    const auto wall = Clock::now();
    for (auto& [id, u] : impl_->units) {
        if (u->has_motor) {
            u->sim->update(u->now(wall));
            out[id] = u->sim->load_steps() / u->spd;
        }
    }
    return out;
}

Expected<UnitSnapshot> MotorControllerServer::snapshot(int unit) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr) {
        return make_error("sim: no unit " + std::to_string(unit));
    }
    UnitSnapshot s;
    if (u->shutter_coil >= 0) {
        s.shutter_open = u->bits[static_cast<size_t>(u->shutter_coil)] != 0;
    }
    if (u->has_motor) {
        MotorSim& m = *u->sim;
        m.update(u->now(Clock::now()));
        s.position_deg = m.load_steps() / u->spd;
        s.motor_deg = m.motor_steps() / u->spd;
        s.counter_deg = static_cast<double>(m.counter_steps()) / u->spd;
        s.moving = m.moving();
        s.homed = m.homed();
        s.alarm_code = m.alarm_code();
    }
    return s;
}

bool MotorControllerServer::shutter_open(int unit) const {
    auto s = snapshot(unit);
    return s && s->shutter_open;
}

std::uint64_t MotorControllerServer::request_count(int unit) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    if (unit == 0) {
        return impl_->total_requests;
    }
    Unit* u = impl_->unit_locked(unit);
    return u == nullptr ? 0 : u->requests;
}

void MotorControllerServer::set_time_scale(double time_scale) {
    if (!(time_scale > 0) || !std::isfinite(time_scale)) {
        return;
    }
    std::lock_guard<std::mutex> lock(impl_->mu);
    const auto wall = Clock::now();
    for (auto& [id, u] : impl_->units) {
        u->sim_base = u->now(wall);
        u->wall_base = wall;
        u->scale = time_scale;
    }
}

}  // namespace gonio::sim
