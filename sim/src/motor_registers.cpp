#include "gonio/sim/motor_registers.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <set>

#include "gonio/devices/modbus_codec.h"

namespace gonio::sim {
namespace {

namespace mb = devices::modbus;
using devices::Action;
using devices::AxisProfile;
using devices::RegisterField;
using devices::TriggerKind;
using Bytes = std::vector<std::uint8_t>;
using Clock = std::chrono::steady_clock;

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
    std::size_t pulses_taken = 0;  ///< Compare pulses handed to the wire so far.

    double now(Clock::time_point wall) const {
        return sim_base + std::chrono::duration<double>(wall - wall_base).count() * scale;
    }
    Clock::time_point wall_of(double t) const {
        return wall_base + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>((t - sim_base) / scale));
    }
    int wire_of(const RegisterField& f, int offset) const {
        return wire(profile, f.address) + offset;
    }
    void put_at(int w, int width, std::int64_t v) {
        const auto words = devices::encode_value(v, width, profile.word_order);
        for (size_t k = 0; k < words.size(); ++k) {
            tab[static_cast<size_t>(w) + k] = words[k];
        }
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

}  // namespace

struct MotorRegisters::Impl {
    mutable std::mutex mu;
    std::map<int, std::unique_ptr<Unit>> units;
    std::deque<ActiveFault> reply_faults;
    std::uint64_t total_requests = 0;

    Unit* unit_locked(int id) const {
        auto it = units.find(id);
        return it == units.end() ? nullptr : it->second.get();
    }

    /// A unit without a drive (shutter only, or before add_unit): the fault registers only.
    Unit* make_unit_locked(int id) {
        auto nu = std::make_unique<Unit>();
        nu->id = id;
        for (int k = 0; k < kFaultRegisterCount; ++k) {
            nu->regs.insert(kFaultRegister + k);
        }
        nu->wall_base = Clock::now();
        Unit* u = nu.get();
        units[id] = std::move(nu);
        return u;
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
        if (u.profile.compare.present()) {
            u.put(u.profile.compare.fired, static_cast<std::int64_t>(m.pulses_fired(t)));
        }
    }

    /// A write to the compare control: 1 arms the table's first `count` entries (the pulse count
    /// and the latches start afresh), 0 disarms.
    void compare_control(Unit& u, double t) {
        const devices::PositionCompare& pc = u.profile.compare;
        const std::uint32_t v = u.get(pc.control);
        std::vector<double> steps;
        if (v == 1) {
            const int n = std::clamp(static_cast<int>(u.get(pc.count)), 0, pc.entries);
            for (int k = 0; k < n; ++k) {
                const int w = u.wire_of(pc.table, k * pc.table.count());
                steps.push_back(static_cast<double>(devices::decode_value(
                    u.tab.data() + w, pc.table.width, pc.table.is_signed, u.profile.word_order)));
            }
            const int lw = u.wire_of(pc.latches, 0);
            std::fill(u.tab.begin() + lw,
                      u.tab.begin() + lw + 2 * pc.entries * pc.latches.count(),
                      std::uint16_t{0});
        }
        u.sim->arm_compare(t, std::move(steps));
        u.pulses_taken = 0;
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
        if (p.compare.present()) {
            const int cw = wire(p, p.compare.control.address);
            if (cw < hi && cw + p.compare.control.count() > lo) {
                compare_control(u, t);
            }
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

    /// Are wire addresses [addr, addr + qty) all present in `valid` (and, for writes, none of them
    /// read-only)? The codec has already refused ranges that run past 0xFFFF.
    static bool range_ok(const Unit& u, const std::set<int>& valid, int addr, int qty, bool write) {
        for (int a = addr; a < addr + qty; ++a) {
            if (valid.count(a) == 0 || (write && u.read_only.count(a) != 0)) {
                return false;
            }
        }
        return true;
    }

    /// Executes one request PDU on a unit and returns the response PDU. Call with `mu` held.
    Bytes execute(Unit& u, const Bytes& pdu) {
        const std::uint8_t fc = pdu.empty() ? 0 : pdu[0];
        // Functions 2 and 4 (discrete inputs, input registers): the drives have none.
        if (fc == 0x02 || fc == 0x04) {
            return mb::exception_pdu(fc, mb::ExceptionCode::kIllegalFunction);
        }
        auto req = mb::parse_request(pdu.data(), pdu.size());
        if (!req) {
            return mb::exception_pdu(fc, req.error().code);
        }
        const mb::Request& r = *req;
        const int addr = r.address;
        const int qty = r.quantity;
        const double t = u.now(Clock::now());
        switch (r.function) {
            case mb::Function::kReadCoils: {
                if (!range_ok(u, u.coils, addr, qty, false)) {
                    return mb::exception_pdu(fc, mb::ExceptionCode::kIllegalDataAddress);
                }
                std::vector<bool> bits(static_cast<std::size_t>(qty));
                for (int k = 0; k < qty; ++k) {
                    bits[static_cast<std::size_t>(k)] =
                        u.bits[static_cast<std::size_t>(addr + k)] != 0;
                }
                return mb::encode_response(mb::make_response(r, {}, bits));
            }
            case mb::Function::kReadHoldingRegisters: {
                if (!range_ok(u, u.regs, addr, qty, false)) {
                    return mb::exception_pdu(fc, mb::ExceptionCode::kIllegalDataAddress);
                }
                refresh(u, t);
                const std::vector<std::uint16_t> values(u.tab.begin() + addr,
                                                        u.tab.begin() + addr + qty);
                return mb::encode_response(mb::make_response(r, values));
            }
            case mb::Function::kWriteSingleCoil:
            case mb::Function::kWriteMultipleCoils: {
                if (!range_ok(u, u.coils, addr, qty, true)) {
                    return mb::exception_pdu(fc, mb::ExceptionCode::kIllegalDataAddress);
                }
                for (int k = 0; k < qty; ++k) {
                    u.bits[static_cast<std::size_t>(addr + k)] =
                        r.coils[static_cast<std::size_t>(k)] ? 1 : 0;
                }
                return mb::encode_response(mb::make_response(r));
            }
            case mb::Function::kWriteSingleRegister:
            case mb::Function::kWriteMultipleRegisters: {
                if (!range_ok(u, u.regs, addr, qty, true)) {
                    return mb::exception_pdu(fc, mb::ExceptionCode::kIllegalDataAddress);
                }
                refresh(u, t);
                const std::vector<std::uint16_t> before(u.tab.begin() + addr,
                                                        u.tab.begin() + addr + qty);
                std::copy(r.registers.begin(), r.registers.end(), u.tab.begin() + addr);
                after_write(u, addr, addr + qty, before, t);
                return mb::encode_response(mb::make_response(r));
            }
            default:
                return mb::exception_pdu(fc, mb::ExceptionCode::kIllegalFunction);
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

MotorRegisters::MotorRegisters() : impl_(new Impl) {}

MotorRegisters::~MotorRegisters() = default;

Expected<void> MotorRegisters::add_unit(int unit,
                                        const devices::AxisProfile& profile,
                                        const MotorSimConfig& cfg) {
    if (unit < 1 || unit > 247) {
        return make_error("sim: unit " + std::to_string(unit) + " not in [1, 247]");
    }
    if (!(cfg.time_scale > 0) || !std::isfinite(cfg.time_scale)) {
        return make_error("sim: unit " + std::to_string(unit) + ": time_scale must be > 0");
    }
    {
        // Every register of the profile lies in the 16-bit address space (a 32-bit field at
        // 0xFFFF would not), checked before the unit changes.
        Unit probe;
        probe.profile = profile;
        probe.add_field(profile.position);
        probe.add_field(profile.status.reg);
        probe.add_field(profile.alarm_code);
        for (const Action* a :
             {&profile.move, &profile.home, &profile.stop, &profile.reset_alarm}) {
            probe.add_action(*a);
        }
        for (int r : probe.regs) {
            if (r < 0 || r >= static_cast<int>(mb::kAddressSpace)) {
                return make_error("sim: profile \"" + profile.name +
                                  "\" has a register outside wire addresses 0x0000..0xFFFF");
            }
        }
    }
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u != nullptr && u->has_motor) {
        return make_error("sim: unit " + std::to_string(unit) + " already has a drive");
    }
    if (u == nullptr) {
        u = impl_->make_unit_locked(unit);
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
    if (profile.probe_start.present()) {
        u->add_field(profile.probe_start);
        u->add_field(profile.probe_end);
    }
    const devices::PositionCompare& pc = profile.compare;
    if (pc.present()) {
        u->add_field(pc.control);
        u->add_field(pc.count);
        u->add_field(pc.fired);
        for (int k = 0; k < pc.entries * pc.table.count(); ++k) {
            u->regs.insert(u->wire_of(pc.table, k));
        }
        for (int k = 0; k < 2 * pc.entries * pc.latches.count(); ++k) {
            u->regs.insert(u->wire_of(pc.latches, k));
            u->read_only.insert(u->wire_of(pc.latches, k));
        }
    }
    // The drive writes these itself: a client's write is refused (exception 2).
    for (const RegisterField* f : {&profile.position,
                                   &profile.status.reg,
                                   &profile.alarm_code,
                                   &profile.probe_start,
                                   &profile.probe_end,
                                   &pc.fired}) {
        if (!f->present()) {
            continue;
        }
        const int w = wire(profile, f->address);
        for (int k = 0; k < f->count(); ++k) {
            u->read_only.insert(w + k);
        }
    }
    for (const Action* a : {&profile.move, &profile.home, &profile.stop, &profile.reset_alarm}) {
        u->add_action(*a);
    }
    impl_->refresh(*u, 0);
    return {};
}

Expected<void> MotorRegisters::add_shutter(int unit, int coil) {
    if (unit < 1 || unit > 247 || coil < 0 || coil > 0xFFFF) {
        return make_error("sim: shutter unit " + std::to_string(unit) + " coil " +
                          std::to_string(coil) + " out of range");
    }
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr) {
        u = impl_->make_unit_locked(unit);
    }
    u->coils.insert(coil);
    u->shutter_coil = coil;
    return {};
}

Reply MotorRegisters::process(int unit_id, const Bytes& pdu, bool serial) {
    std::lock_guard<std::mutex> lock(impl_->mu);
    ++impl_->total_requests;
    Reply a;
    const std::uint8_t fc = pdu.empty() ? 0 : pdu[0];
    if (serial && unit_id == 0) {
        // Broadcast (Modbus over Serial Line V1.02, section 2.1): writes are executed by every
        // unit, nobody answers; a broadcast read means nothing and is ignored.
        if (fc == 5 || fc == 6 || fc == 15 || fc == 16) {
            for (auto& [id, u] : impl_->units) {
                ++u->requests;
                (void)impl_->execute(*u, pdu);
            }
        }
        return a;
    }
    Unit* u = impl_->unit_locked(unit_id);
    if (u == nullptr) {
        // RTU: an absent drive is silent. TCP: a gateway says its target did not answer.
        if (!serial) {
            a.kind = Reply::Kind::kSend;
            a.pdu = mb::exception_pdu(fc, mb::ExceptionCode::kGatewayTargetDeviceFailedToRespond);
        }
        return a;
    }
    ++u->requests;
    auto& faults = impl_->reply_faults;
    for (auto it = faults.begin(); it != faults.end(); ++it) {
        if (it->f.unit != 0 && it->f.unit != unit_id) {
            continue;
        }
        const Fault f = it->f;
        if (--it->remaining <= 0) {
            faults.erase(it);
        }
        if (f.kind == FaultKind::kDelayReply) {
            a.delay = f.delay;  // The simulated drive is slow to answer.
        } else if (f.kind == FaultKind::kDropConnection) {
            a.kind = serial ? Reply::Kind::kSilent : Reply::Kind::kDrop;
            return a;
        } else {
            a.kind = Reply::Kind::kSend;
            a.pdu = mb::exception_pdu(
                fc, static_cast<mb::ExceptionCode>(static_cast<std::uint8_t>(f.exception_code)));
            return a;
        }
        break;
    }
    a.kind = Reply::Kind::kSend;
    a.pdu = impl_->execute(*u, pdu);
    return a;
}

void MotorRegisters::inject(const Fault& f) {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->inject_locked(f);
}

void MotorRegisters::clear_faults() {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->reply_faults.clear();
    for (auto& [id, u] : impl_->units) {
        if (u->has_motor) {
            u->sim->disarm();
        }
    }
}

void MotorRegisters::power_loss() {
    std::lock_guard<std::mutex> lock(impl_->mu);
    const auto wall = Clock::now();
    for (auto& [id, u] : impl_->units) {
        if (u->has_motor) {
            u->sim->stop(u->now(wall), 1e12);
        }
    }
}

double MotorRegisters::position_deg(int unit) const {
    auto s = snapshot(unit);
    return s ? s->position_deg : std::numeric_limits<double>::quiet_NaN();
}

std::map<int, double> MotorRegisters::positions_deg() const {
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

std::vector<double> MotorRegisters::path_deg(int unit, const std::vector<double>& after_s) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr || !u->has_motor) {
        return std::vector<double>(after_s.size(), std::numeric_limits<double>::quiet_NaN());
    }
    const double now = u->now(Clock::now());
    u->sim->update(now);
    std::vector<double> t;
    t.reserve(after_s.size());
    for (double a : after_s) {
        t.push_back(now + a);
    }
    std::vector<double> out = u->sim->load_steps_at(t);
    for (double& v : out) {
        v /= u->spd;
    }
    return out;
}

void MotorRegisters::latch_exposure(int unit, double exposure_s) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr || !u->has_motor || !u->profile.probe_start.present()) {
        return;
    }
    const double now = u->now(Clock::now());
    u->sim->update(now);
    std::vector<double> motor;
    u->sim->load_steps_at({now, now + std::max(0.0, exposure_s)}, &motor);
    const double offset = u->sim->counter_offset();
    u->put(u->profile.probe_start, std::llround(motor[0] + offset));
    u->put(u->profile.probe_end, std::llround(motor[1] + offset));
}

std::vector<ComparePulse> MotorRegisters::take_pulses(bool* armed) {
    std::vector<ComparePulse> out;
    bool any = false;
    std::lock_guard<std::mutex> lock(impl_->mu);
    const auto wall = Clock::now();
    for (auto& [id, u] : impl_->units) {
        if (!u->has_motor || !u->profile.compare.present()) {
            continue;
        }
        const MotorSim& m = *u->sim;
        const std::vector<double>& times = m.compare_times();
        any = any || u->pulses_taken < times.size() || u->get(u->profile.compare.control) == 1;
        const std::size_t fired = m.pulses_fired(u->now(wall));
        for (std::size_t k = u->pulses_taken; k < fired; ++k) {
            out.push_back(ComparePulse{id, k + 1, u->wall_of(times[k])});
        }
        u->pulses_taken = std::max(u->pulses_taken, fired);
    }
    std::sort(out.begin(), out.end(), [](const ComparePulse& a, const ComparePulse& b) {
        return a.at < b.at;
    });
    if (armed != nullptr) {
        *armed = any;
    }
    return out;
}

std::vector<double> MotorRegisters::path_deg_at(int unit,
                                                Clock::time_point at,
                                                const std::vector<double>& after_s) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr || !u->has_motor) {
        return std::vector<double>(after_s.size(), std::numeric_limits<double>::quiet_NaN());
    }
    const double t0 = u->now(at);
    std::vector<double> t;
    t.reserve(after_s.size());
    for (double a : after_s) {
        t.push_back(t0 + a);
    }
    std::vector<double> out = u->sim->history_steps_at(t);
    for (double& v : out) {
        v /= u->spd;
    }
    return out;
}

void MotorRegisters::latch_pulse(int unit,
                                 std::size_t index,
                                 Clock::time_point at,
                                 double exposure_s) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    Unit* u = impl_->unit_locked(unit);
    if (u == nullptr || !u->has_motor) {
        return;
    }
    const double t0 = u->now(at);
    std::vector<double> motor;
    u->sim->history_steps_at({t0, t0 + std::max(0.0, exposure_s)}, &motor);
    const double offset = u->sim->counter_offset();
    const std::int64_t c0 = std::llround(motor[0] + offset);
    const std::int64_t c1 = std::llround(motor[1] + offset);
    const AxisProfile& p = u->profile;
    if (p.probe_start.present()) {
        u->put(p.probe_start, c0);
        u->put(p.probe_end, c1);
    }
    const devices::PositionCompare& pc = p.compare;
    if (pc.present() && index >= 1 && index <= static_cast<std::size_t>(pc.entries)) {
        const int k = static_cast<int>(index) - 1;
        u->put_at(u->wire_of(pc.latches, 2 * k * pc.latches.count()), pc.latches.width, c0);
        u->put_at(u->wire_of(pc.latches, (2 * k + 1) * pc.latches.count()), pc.latches.width, c1);
    }
}

Expected<UnitSnapshot> MotorRegisters::snapshot(int unit) const {
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

bool MotorRegisters::shutter_open(int unit) const {
    auto s = snapshot(unit);
    return s && s->shutter_open;
}

std::uint64_t MotorRegisters::request_count(int unit) const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    if (unit == 0) {
        return impl_->total_requests;
    }
    Unit* u = impl_->unit_locked(unit);
    return u == nullptr ? 0 : u->requests;
}

void MotorRegisters::set_time_scale(double time_scale) {
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
