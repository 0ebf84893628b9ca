#include "gonio/sim/motor_controller_server.h"

#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <sys/select.h>
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
    modbus_mapping_t* map = nullptr;
    std::set<int> regs;   ///< Valid holding-register wire addresses.
    std::set<int> coils;  ///< Valid coil wire addresses.
    int shutter_coil = -1;
    std::uint64_t requests = 0;
    // Clock: simulated time = sim_base + (wall - wall_base) * scale.
    double sim_base = 0;
    Clock::time_point wall_base;
    double scale = 1;
    double last_decel = 0;

    ~Unit() {
        if (map != nullptr) {
            modbus_mapping_free(map);
        }
    }
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
            map->tab_registers[w + static_cast<int>(k)] = words[k];
        }
    }
    std::uint32_t get(const RegisterField& f) const {
        return static_cast<std::uint32_t>(devices::decode_value(
            map->tab_registers + wire(profile, f.address), f.width, false, profile.word_order));
    }
};

struct ActiveFault {
    Fault f;
    int remaining = 0;
};

enum class Verdict { kReply, kException, kDrop, kSilent };

/// MBAP header (transaction id, protocol id, length, unit id), Modbus Messaging on TCP/IP V1.0b.
constexpr int kTcpHeaderLength = 7;

}  // namespace

struct MotorControllerServer::Impl {
    mutable std::mutex mu;
    std::map<int, std::unique_ptr<Unit>> units;
    std::deque<ActiveFault> reply_faults;
    std::uint64_t total_requests = 0;
    ServerOptions options;
    modbus_t* ctx = nullptr;
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
        if (ctx != nullptr) {
            modbus_free(ctx);
            ctx = nullptr;
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
                p, p.move.block, u.map->tab_registers + wire(p, p.move.block.address));
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
            std::uint16_t* r = u.map->tab_registers + kFaultRegister;
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
                                                            : u.map->tab_registers[a];
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

    /// Handles one complete request (TCP ADU or RTU frame including CRC) and answers it.
    Verdict handle(const std::uint8_t* q, int len, int header) {
        if (len < header + 1) {
            return Verdict::kSilent;
        }
        const int unit_id = q[header - 1];
        const int fc = q[header];
        const int addr = len >= header + 3 ? (q[header + 1] << 8) | q[header + 2] : 0;
        int qty = 1;
        if ((fc == 1 || fc == 2 || fc == 3 || fc == 4 || fc == 15 || fc == 16) &&
            len >= header + 5) {
            qty = (q[header + 3] << 8) | q[header + 4];
        }
        std::chrono::milliseconds delay{0};
        int exception = 0;
        {
            std::lock_guard<std::mutex> lock(mu);
            ++total_requests;
            Unit* u = unit_locked(unit_id);
            if (u == nullptr) {
                // RTU: an absent drive is silent. TCP: a gateway says its target did not answer.
                if (options.transport == Transport::kRtu) {
                    return Verdict::kSilent;
                }
                modbus_reply_exception(ctx, q, MODBUS_EXCEPTION_GATEWAY_TARGET);
                return Verdict::kException;
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
                    delay = f.delay;
                } else if (f.kind == FaultKind::kDropConnection) {
                    return options.transport == Transport::kTcp ? Verdict::kDrop : Verdict::kSilent;
                } else {
                    exception = f.exception_code;
                }
                break;
            }
        }
        if (delay.count() > 0) {
            std::this_thread::sleep_for(delay);  // The simulated drive is slow to answer.
        }
        std::lock_guard<std::mutex> lock(mu);
        Unit* u = unit_locked(unit_id);
        if (u == nullptr) {
            return Verdict::kSilent;
        }
        if (exception != 0) {
            modbus_reply_exception(ctx, q, static_cast<unsigned>(exception));
            return Verdict::kException;
        }
        // Register-for-register: only the profile's registers (and the fault block) exist.
        bool valid = qty >= 1;
        if (fc == 3 || fc == 6 || fc == 16) {
            for (int a = addr; valid && a < addr + qty; ++a) {
                valid = u->regs.count(a) != 0;
            }
        } else if (fc == 1 || fc == 5 || fc == 15) {
            for (int a = addr; valid && a < addr + qty; ++a) {
                valid = u->coils.count(a) != 0;
            }
        } else {
            modbus_reply_exception(ctx, q, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
            return Verdict::kException;
        }
        if (!valid) {
            modbus_reply_exception(ctx, q, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
            return Verdict::kException;
        }
        const double t = u->now(Clock::now());
        refresh(*u, t);
        std::vector<std::uint16_t> before;
        const bool writes_regs = fc == 6 || fc == 16;
        if (writes_regs) {
            before.assign(u->map->tab_registers + addr, u->map->tab_registers + addr + qty);
        }
        modbus_reply(ctx, q, len, u->map);
        if (writes_regs) {
            after_write(*u, addr, addr + qty, before, t);
        }
        return Verdict::kReply;
    }

    void serve_tcp() {
        std::vector<int> clients;
        std::vector<std::uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH);
        while (running) {
            fd_set set;
            FD_ZERO(&set);
            FD_SET(wake[0], &set);
            FD_SET(listen_fd, &set);
            int maxfd = std::max(wake[0], listen_fd);
            for (int c : clients) {
                FD_SET(c, &set);
                maxfd = std::max(maxfd, c);
            }
            if (::select(maxfd + 1, &set, nullptr, nullptr, nullptr) < 0) {
                if (errno == EINTR) {
                    continue;
                }
                break;
            }
            if (FD_ISSET(wake[0], &set)) {
                break;
            }
            if (FD_ISSET(listen_fd, &set)) {
                const int c = ::accept(listen_fd, nullptr, nullptr);
                if (c >= 0) {
                    clients.push_back(c);
                }
            }
            for (size_t i = 0; i < clients.size();) {
                const int c = clients[i];
                if (!FD_ISSET(c, &set)) {
                    ++i;
                    continue;
                }
                modbus_set_socket(ctx, c);
                const int rc = modbus_receive(ctx, query.data());
                Verdict v = Verdict::kSilent;
                if (rc > 0) {
                    v = handle(query.data(), rc, kTcpHeaderLength);
                }
                if (rc < 0 || v == Verdict::kDrop) {
                    ::close(c);
                    clients.erase(clients.begin() + static_cast<long>(i));
                    continue;
                }
                ++i;
            }
        }
        for (int c : clients) {
            ::close(c);
        }
    }

    /// Length of the RTU request frame starting at buf (0 = need more bytes, -1 = unknown
    /// function: resynchronise). Request layouts from the Modbus Application Protocol V1.1b3.
    static int rtu_frame_length(const std::vector<std::uint8_t>& buf) {
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
                return buf.size() < 7 ? 0 : 9 + buf[6];
            default:
                return -1;
        }
    }

    void serve_rtu() {
        std::vector<std::uint8_t> buf;
        std::uint8_t chunk[512];
        while (running) {
            fd_set set;
            FD_ZERO(&set);
            FD_SET(wake[0], &set);
            FD_SET(pty_master, &set);
            const int maxfd = std::max(wake[0], pty_master);
            // A partial frame that stays incomplete for 50 ms is noise: drop it (the RTU
            // inter-frame silence is 3.5 characters; a pty has no line timing).
            timeval tv{0, 50000};
            const int rc = ::select(maxfd + 1, &set, nullptr, nullptr, buf.empty() ? nullptr : &tv);
            if (rc < 0) {
                if (errno == EINTR) {
                    continue;
                }
                break;
            }
            if (rc == 0) {
                buf.clear();
                continue;
            }
            if (FD_ISSET(wake[0], &set)) {
                break;
            }
            const ssize_t n = ::read(pty_master, chunk, sizeof chunk);
            if (n <= 0) {
                continue;
            }
            buf.insert(buf.end(), chunk, chunk + n);
            for (;;) {
                const int flen = rtu_frame_length(buf);
                if (flen < 0) {
                    buf.clear();
                    break;
                }
                if (flen == 0 || buf.size() < static_cast<size_t>(flen)) {
                    break;
                }
                const std::uint16_t crc = crc16(buf.data(), static_cast<size_t>(flen - 2));
                const bool ok = buf[static_cast<size_t>(flen - 2)] == (crc & 0xFF) &&
                                buf[static_cast<size_t>(flen - 1)] == (crc >> 8);
                if (!ok) {
                    buf.clear();  // Garbled: wait for the master to retry.
                    break;
                }
                std::vector<std::uint8_t> frame(buf.begin(), buf.begin() + flen);
                buf.erase(buf.begin(), buf.begin() + flen);
                handle(frame.data(), flen, 1);
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
        nu->map = modbus_mapping_new(0x10000, 0, 0x10000, 0);
        if (nu->map == nullptr) {
            return make_error("sim: cannot allocate the register map");
        }
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
        nu->map = modbus_mapping_new(0x10000, 0, 0x10000, 0);
        if (nu->map == nullptr) {
            return make_error("sim: cannot allocate the register map");
        }
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
    if (::pipe(impl_->wake) != 0) {
        return make_error(std::string("sim: pipe: ") + std::strerror(errno));
    }
    if (options.transport == Transport::kTcp) {
        impl_->ctx = modbus_new_tcp("127.0.0.1", options.port);
        if (impl_->ctx == nullptr) {
            return make_error(std::string("sim: modbus_new_tcp: ") + modbus_strerror(errno));
        }
        impl_->listen_fd = modbus_tcp_listen(impl_->ctx, 16);
        if (impl_->listen_fd < 0) {
            const std::string msg = modbus_strerror(errno);
            impl_->close_all();
            return make_error("sim: cannot listen on 127.0.0.1:" + std::to_string(options.port) +
                              ": " + msg);
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
        impl_->ctx = modbus_new_rtu(name, options.baud, 'N', 8, 1);
        if (impl_->ctx == nullptr) {
            impl_->close_all();
            return make_error(std::string("sim: modbus_new_rtu: ") + modbus_strerror(errno));
        }
        modbus_set_socket(impl_->ctx, m);
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
        s.shutter_open = u->map->tab_bits[u->shutter_coil] != 0;
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
