#include "gonio/devices/axis_profile.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gonio/base/data_path.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"

namespace gonio::devices {
namespace {

using nlohmann::json;

/// Reads an integer given as a JSON number or as a "0x..." / decimal string.
Expected<long long> get_int(const json& j, const std::string& path) {
    if (j.is_number_integer()) {
        return j.get<long long>();
    }
    if (j.is_string()) {
        const std::string s = j.get<std::string>();
        char* end = nullptr;
        const long long v = std::strtoll(s.c_str(), &end, 0);
        if (!s.empty() && end != nullptr && *end == '\0') {
            return v;
        }
    }
    return make_error(path + ": " + j.dump() + " is not an integer (number or \"0x...\" string)");
}

Expected<double> get_number(const json& j, const std::string& path) {
    if (j.is_number()) {
        const double v = j.get<double>();
        if (std::isfinite(v)) {
            return v;
        }
    }
    return make_error(path + ": " + j.dump() + " is not a finite number");
}

/// The optional "section" key: where the drive's manual documents a register or block.
Expected<std::string> get_section(const json& j, const std::string& path) {
    if (!j.contains("section")) {
        return std::string();
    }
    if (!j["section"].is_string() || j["section"].get<std::string>().empty()) {
        return make_error(path + ".section: expected a non-empty string (the manual's section)");
    }
    return j["section"].get<std::string>();
}

Expected<RegisterField> get_field(const json& j, const std::string& path) {
    if (!j.is_object()) {
        return make_error(path + ": expected an object {\"address\": ..., \"width\": 16|32}");
    }
    RegisterField f;
    if (!j.contains("address")) {
        return make_error(path + ".address: missing");
    }
    auto a = get_int(j["address"], path + ".address");
    if (!a) {
        return tl::unexpected(a.error());
    }
    if (*a < 0 || *a > 99999) {
        return make_error(path + ".address: " + std::to_string(*a) + " not in [0, 99999]");
    }
    f.address = static_cast<int>(*a);
    if (j.contains("width")) {
        auto w = get_int(j["width"], path + ".width");
        if (!w) {
            return tl::unexpected(w.error());
        }
        if (*w != 16 && *w != 32) {
            return make_error(path + ".width: " + std::to_string(*w) + " not in {16, 32}");
        }
        f.width = static_cast<int>(*w);
    }
    if (j.contains("signed")) {
        if (!j["signed"].is_boolean()) {
            return make_error(path + ".signed: expected true or false");
        }
        f.is_signed = j["signed"].get<bool>();
    }
    if (auto sec = get_section(j, path); !sec) {
        return tl::unexpected(sec.error());
    } else {
        f.section = *sec;
    }
    return f;
}

Expected<Quantity> get_quantity(const std::string& s, const std::string& path) {
    if (s == "target") {
        return Quantity::kTarget;
    }
    if (s == "speed") {
        return Quantity::kSpeed;
    }
    if (s == "accel") {
        return Quantity::kAccel;
    }
    if (s == "decel") {
        return Quantity::kDecel;
    }
    return make_error(path + ": \"" + s + "\" not one of target, speed, accel, decel");
}

Expected<BlockSlot> get_block_slot(const json& s, const std::string& sp) {
    BlockSlot slot;
    if (!s.is_object()) {
        return make_error(sp + ": expected an object");
    }
    if (s.contains("quantity") == s.contains("value")) {
        return make_error(sp + ": exactly one of \"quantity\" and \"value\" is required");
    }
    if (s.contains("quantity")) {
        if (!s["quantity"].is_string()) {
            return make_error(sp + ".quantity: expected a string");
        }
        auto q = get_quantity(s["quantity"].get<std::string>(), sp + ".quantity");
        if (!q) {
            return tl::unexpected(q.error());
        }
        slot.quantity = *q;
    } else {
        auto v = get_int(s["value"], sp + ".value");
        if (!v) {
            return tl::unexpected(v.error());
        }
        slot.constant = static_cast<double>(*v);
    }
    if (s.contains("width")) {
        auto w = get_int(s["width"], sp + ".width");
        if (!w) {
            return tl::unexpected(w.error());
        }
        if (*w != 16 && *w != 32) {
            return make_error(sp + ".width: " + std::to_string(*w) + " not in {16, 32}");
        }
        slot.width = static_cast<int>(*w);
    }
    if (s.contains("scale")) {
        auto sc = get_number(s["scale"], sp + ".scale");
        if (!sc) {
            return tl::unexpected(sc.error());
        }
        if (!(*sc > 0)) {
            return make_error(sp + ".scale: must be > 0");
        }
        slot.scale = *sc;
    }
    if (s.contains("inverse")) {
        if (!s["inverse"].is_boolean()) {
            return make_error(sp + ".inverse: expected true or false");
        }
        slot.inverse = s["inverse"].get<bool>();
    }
    return slot;
}

Expected<CommandBlock> get_block(const json& b, const std::string& bp) {
    if (!b.is_object() || !b.contains("address") || !b.contains("slots") ||
        !b["slots"].is_array() || b["slots"].empty()) {
        return make_error(bp + ": expected {\"address\": ..., \"slots\": [...]} with slots");
    }
    CommandBlock block;
    auto a = get_int(b["address"], bp + ".address");
    if (!a) {
        return tl::unexpected(a.error());
    }
    block.address = static_cast<int>(*a);
    auto sec = get_section(b, bp);
    if (!sec) {
        return tl::unexpected(sec.error());
    }
    block.section = *sec;
    for (size_t i = 0; i < b["slots"].size(); ++i) {
        auto slot = get_block_slot(b["slots"][i], bp + ".slots[" + std::to_string(i) + "]");
        if (!slot) {
            return tl::unexpected(slot.error());
        }
        block.slots.push_back(*slot);
    }
    return block;
}

Expected<Trigger> get_trigger(const json& t, const std::string& tp) {
    if (!t.is_object() || !t.contains("kind") || !t["kind"].is_string()) {
        return make_error(tp + ": expected {\"kind\": \"write_value\"|\"pulse_bit\", ...}");
    }
    Trigger trigger;
    auto reg = get_field(t, tp);
    if (!reg) {
        return tl::unexpected(reg.error());
    }
    trigger.reg = *reg;
    const std::string kind = t["kind"].get<std::string>();
    if (kind == "write_value") {
        trigger.kind = TriggerKind::kWriteValue;
        if (!t.contains("value")) {
            return make_error(tp + ".value: missing");
        }
        auto v = get_int(t["value"], tp + ".value");
        if (!v) {
            return tl::unexpected(v.error());
        }
        trigger.value = static_cast<std::uint32_t>(*v);
    } else if (kind == "pulse_bit") {
        trigger.kind = TriggerKind::kPulseBit;
        if (!t.contains("bit")) {
            return make_error(tp + ".bit: missing");
        }
        auto b = get_int(t["bit"], tp + ".bit");
        if (!b) {
            return tl::unexpected(b.error());
        }
        if (*b < 0 || *b >= trigger.reg.width) {
            return make_error(tp + ".bit: " + std::to_string(*b) + " outside the register");
        }
        trigger.bit = static_cast<int>(*b);
    } else {
        return make_error(tp + ".kind: \"" + kind + "\" not one of write_value, pulse_bit");
    }
    return trigger;
}

Expected<Action> get_action(const json& j, const std::string& path) {
    Action act;
    if (!j.is_object()) {
        return make_error(path + ": expected an object with \"block\" and/or \"trigger\"");
    }
    if (j.contains("block")) {
        auto block = get_block(j["block"], path + ".block");
        if (!block) {
            return tl::unexpected(block.error());
        }
        act.block = *block;
    }
    if (j.contains("trigger")) {
        auto trigger = get_trigger(j["trigger"], path + ".trigger");
        if (!trigger) {
            return tl::unexpected(trigger.error());
        }
        act.trigger = *trigger;
    }
    return act;
}

template <class T>
Expected<void> get_opt_int(const json& j, const char* key, const std::string& path, T* out) {
    if (!j.contains(key)) {
        return {};
    }
    auto v = get_int(j[key], path + "." + key);
    if (!v) {
        return tl::unexpected(v.error());
    }
    *out = static_cast<T>(*v);
    return {};
}

}  // namespace

int CommandBlock::register_count() const {
    int n = 0;
    for (const BlockSlot& s : slots) {
        n += s.width == 32 ? 2 : 1;
    }
    return n;
}

namespace {

/// The text as a JSON object whose every key is known (docs/profiles.md): a misspelt optional
/// key is an error, not a default silently kept.
Expected<json> parse_profile_json(const std::string& json_text, const std::string& source_name) {
    json j;
    try {
        j = json::parse(json_text);
    } catch (const json::parse_error& e) {
        return make_error(source_name + ": JSON parse error at byte " + std::to_string(e.byte) +
                          ": " + gonio::json_error_text(e.what()));
    }
    if (!j.is_object()) {
        return make_error(source_name + ": expected a JSON object");
    }
    auto known = read_strict_json(source_name, [&] {
        check_json_keys(j,
                        "",
                        {"name",
                         "description",
                         "source",
                         "address_base",
                         "word_order",
                         "steps_per_degree",
                         "max_speed_deg_per_s",
                         "home_speed_deg_per_s",
                         "direction",
                         "registers",
                         "status_bits",
                         "actions",
                         "timeouts",
                         "alarm_codes",
                         "position_compare"});
        const std::pair<const char*, std::vector<std::string>> sections[] = {
            {"registers", {"position", "status", "alarm_code", "probe_start", "probe_end"}},
            {"status_bits", {"moving", "in_position", "homed", "alarm", "homing", "ready"}},
            {"actions", {"move", "home", "stop", "reset_alarm"}},
            {"timeouts", {"response_ms", "retries", "backoff_ms", "poll_ms", "stall_ms"}},
            {"alarm_codes", {"overtravel", "overload", "deviation"}},
            {"position_compare", {"control", "count", "fired", "table", "latches", "entries"}}};
        for (const auto& [section, keys] : sections) {
            if (j.contains(section) && j[section].is_object()) {
                check_json_keys(j[section], section, keys);
            }
        }
    });
    if (!known) {
        return tl::unexpected(known.error());
    }
    return j;
}

/// name, description, source, address_base and word_order.
Expected<void> read_identity(const json& j, const std::string& s, AxisProfile* p) {
    auto str = [&](const char* key, std::string* out) -> Expected<void> {
        if (j.contains(key)) {
            if (!j[key].is_string()) {
                return make_error(s + ": " + key + ": expected a string");
            }
            *out = j[key].get<std::string>();
        }
        return {};
    };
    for (auto r :
         {str("name", &p->name), str("description", &p->description), str("source", &p->source)}) {
        if (!r) {
            return r;
        }
    }
    if (p->name.empty()) {
        return make_error(s + ": name: missing");
    }
    if (auto r = get_opt_int(j, "address_base", s, &p->address_base); !r) {
        return r;
    }
    if (p->address_base != 0 && p->address_base != 1 && p->address_base != 40001) {
        return make_error(s + ": address_base: " + std::to_string(p->address_base) +
                          " not in {0, 1, 40001}");
    }
    if (j.contains("word_order")) {
        const std::string wo =
            j["word_order"].is_string() ? j["word_order"].get<std::string>() : "";
        if (wo == "high_first") {
            p->word_order = WordOrder::kHighFirst;
        } else if (wo == "low_first") {
            p->word_order = WordOrder::kLowFirst;
        } else {
            return make_error(s + ": word_order: " + j["word_order"].dump() +
                              " not one of \"high_first\", \"low_first\"");
        }
    }
    return {};
}

/// steps_per_degree, the two speeds and the direction.
Expected<void> read_motion(const json& j, const std::string& s, AxisProfile* p) {
    auto num = [&](const char* key, double* out) -> Expected<void> {
        if (!j.contains(key)) {
            return {};
        }
        auto v = get_number(j[key], s + ": " + key);
        if (!v) {
            return tl::unexpected(v.error());
        }
        if (!(*v > 0)) {
            return make_error(s + ": " + key + ": must be > 0");
        }
        *out = *v;
        return {};
    };
    for (auto r : {num("steps_per_degree", &p->steps_per_degree),
                   num("max_speed_deg_per_s", &p->max_speed_deg_per_s),
                   num("home_speed_deg_per_s", &p->home_speed_deg_per_s)}) {
        if (!r) {
            return r;
        }
    }
    if (auto r = get_opt_int(j, "direction", s, &p->direction); !r) {
        return r;
    }
    if (p->direction != 1 && p->direction != -1) {
        return make_error(s + ": direction: " + std::to_string(p->direction) + " not 1 or -1");
    }
    return {};
}

/// The required registers: position, status and alarm_code.
Expected<void> read_registers(const json& j, const std::string& s, AxisProfile* p) {
    if (!j.contains("registers") || !j["registers"].is_object()) {
        return make_error(s + ": registers: missing object");
    }
    const json& regs = j["registers"];
    for (auto [key, field] : {std::pair<const char*, RegisterField*>{"position", &p->position},
                              {"status", &p->status.reg},
                              {"alarm_code", &p->alarm_code}}) {
        if (!regs.contains(key)) {
            return make_error(s + ": registers." + key + ": missing");
        }
        auto f = get_field(regs[key], s + ": registers." + key);
        if (!f) {
            return tl::unexpected(f.error());
        }
        *field = *f;
    }
    return {};
}

Expected<void> read_status_bits(const json& j, const std::string& s, AxisProfile* p) {
    if (!j.contains("status_bits") || !j["status_bits"].is_object()) {
        return make_error(s + ": status_bits: missing object");
    }
    const json& sb = j["status_bits"];
    for (auto [key, bit] : {std::pair<const char*, int*>{"moving", &p->status.moving},
                            {"in_position", &p->status.in_position},
                            {"homed", &p->status.homed},
                            {"alarm", &p->status.alarm},
                            {"homing", &p->status.homing},
                            {"ready", &p->status.ready}}) {
        if (auto r = get_opt_int(sb, key, s + ": status_bits", bit); !r) {
            return r;
        }
        if (*bit >= p->status.reg.width) {
            return make_error(s + ": status_bits." + key + ": bit " + std::to_string(*bit) +
                              " outside the " + std::to_string(p->status.reg.width) +
                              "-bit status register");
        }
    }
    if (p->status.in_position < 0 && p->status.moving < 0) {
        return make_error(s +
                          ": status_bits: needs in_position or moving to know when a move ends");
    }
    return {};
}

/// move and stop (required), home and reset_alarm (optional), and what they need.
Expected<void> read_actions(const json& j, const std::string& s, AxisProfile* p) {
    if (!j.contains("actions") || !j["actions"].is_object()) {
        return make_error(s + ": actions: missing object");
    }
    const json& acts = j["actions"];
    for (auto [key, act] : {std::pair<const char*, Action*>{"move", &p->move},
                            {"home", &p->home},
                            {"stop", &p->stop},
                            {"reset_alarm", &p->reset_alarm}}) {
        if (!acts.contains(key)) {
            if (std::string(key) == "move" || std::string(key) == "stop") {
                return make_error(s + ": actions." + key + ": missing");
            }
            continue;
        }
        auto a = get_action(acts[key], s + ": actions." + key);
        if (!a) {
            return tl::unexpected(a.error());
        }
        *act = *a;
    }
    if (p->home.supported() && p->status.homed < 0) {
        return make_error(s +
                          ": status_bits.homed: required when actions.home is given (homing "
                          "ends on the drive's homed flag)");
    }
    bool has_target = false;
    for (const BlockSlot& slot : p->move.block.slots) {
        has_target = has_target || slot.quantity == Quantity::kTarget;
    }
    if (!has_target) {
        return make_error(s + ": actions.move.block: needs a slot with quantity \"target\"");
    }
    return {};
}

Expected<void> read_timeouts(const json& j, const std::string& s, AxisProfile* p) {
    if (!j.contains("timeouts")) {
        return {};
    }
    const json& t = j["timeouts"];
    const std::string tp = s + ": timeouts";
    for (auto [key, v] : {std::pair<const char*, int*>{"response_ms", &p->timeouts.response_ms},
                          {"retries", &p->timeouts.retries},
                          {"backoff_ms", &p->timeouts.backoff_ms},
                          {"poll_ms", &p->timeouts.poll_ms},
                          {"stall_ms", &p->timeouts.stall_ms}}) {
        if (auto r = get_opt_int(t, key, tp, v); !r) {
            return r;
        }
        if (*v < 0 || *v > 600000) {
            return make_error(tp + "." + key + ": " + std::to_string(*v) + " not in [0, 600000]");
        }
    }
    if (p->timeouts.response_ms == 0) {
        return make_error(tp + ".response_ms: must be > 0");
    }
    return {};
}

Expected<void> read_alarm_codes(const json& j, const std::string& s, AxisProfile* p) {
    if (!j.contains("alarm_codes")) {
        return {};
    }
    const json& a = j["alarm_codes"];
    for (auto [key, v] : {std::pair<const char*, int*>{"overtravel", &p->alarm_codes.overtravel},
                          {"overload", &p->alarm_codes.overload},
                          {"deviation", &p->alarm_codes.deviation}}) {
        if (auto r = get_opt_int(a, key, s + ": alarm_codes", v); !r) {
            return r;
        }
    }
    return {};
}

/// The touch probe's two latches come together or not at all.
Expected<void> read_probe_registers(const json& j, const std::string& s, AxisProfile* p) {
    const json& regs = j["registers"];
    for (auto [key, field] :
         {std::pair<const char*, RegisterField*>{"probe_start", &p->probe_start},
          {"probe_end", &p->probe_end}}) {
        if (!regs.contains(key)) {
            continue;
        }
        auto f = get_field(regs[key], s + ": registers." + key);
        if (!f) {
            return tl::unexpected(f.error());
        }
        *field = *f;
    }
    if (p->probe_start.present() != p->probe_end.present()) {
        return make_error(s + ": registers: probe_start and probe_end come together");
    }
    return {};
}

/// The position compare block: its five registers and its table size, all or nothing.
Expected<void> read_position_compare(const json& j, const std::string& s, AxisProfile* p) {
    if (!j.contains("position_compare")) {
        return {};
    }
    const json& c = j["position_compare"];
    const std::string cp = s + ": position_compare";
    if (!c.is_object()) {
        return make_error(cp + ": expected an object");
    }
    PositionCompare& pc = p->compare;
    for (auto [key, field] : {std::pair<const char*, RegisterField*>{"control", &pc.control},
                              {"count", &pc.count},
                              {"fired", &pc.fired},
                              {"table", &pc.table},
                              {"latches", &pc.latches}}) {
        if (!c.contains(key)) {
            return make_error(cp + "." + key + ": missing");
        }
        auto f = get_field(c[key], cp + "." + key);
        if (!f) {
            return tl::unexpected(f.error());
        }
        *field = *f;
    }
    if (auto r = get_opt_int(c, "entries", cp, &pc.entries); !r) {
        return r;
    }
    if (pc.entries < 1 || pc.entries > 1024) {
        return make_error(cp + ".entries: " + std::to_string(pc.entries) + " not in [1, 1024]");
    }
    return {};
}

/// Every documented address must map to a wire address.
Expected<void> check_wire_addresses(const AxisProfile& p, const std::string& s) {
    std::vector<std::pair<std::string, int>> addrs = {
        {"registers.position", p.position.address},
        {"registers.status", p.status.reg.address},
        {"registers.alarm_code", p.alarm_code.address}};
    if (p.probe_start.present()) {
        addrs.push_back({"registers.probe_start", p.probe_start.address});
        addrs.push_back({"registers.probe_end", p.probe_end.address});
    }
    if (p.compare.present()) {
        const PositionCompare& c = p.compare;
        addrs.push_back({"position_compare.control", c.control.address});
        addrs.push_back({"position_compare.count", c.count.address});
        addrs.push_back({"position_compare.fired", c.fired.address});
        addrs.push_back({"position_compare.table", c.table.address});
        addrs.push_back(
            {"position_compare.table", c.table.address + c.entries * c.table.count() - 1});
        addrs.push_back({"position_compare.latches", c.latches.address});
        addrs.push_back({"position_compare.latches",
                         c.latches.address + 2 * c.entries * c.latches.count() - 1});
    }
    for (const Action* a : {&p.move, &p.home, &p.stop, &p.reset_alarm}) {
        if (a->block.present()) {
            addrs.push_back({"actions block", a->block.address + a->block.register_count() - 1});
            addrs.push_back({"actions block", a->block.address});
        }
        if (a->trigger.kind != TriggerKind::kNone) {
            addrs.push_back({"actions trigger", a->trigger.reg.address});
        }
    }
    for (const auto& [what, addr] : addrs) {
        if (auto w = wire_address(p, addr); !w) {
            return make_error(s + ": " + what + ": " + w.error().message);
        }
    }
    return {};
}

}  // namespace

Expected<AxisProfile> parse_axis_profile(const std::string& json_text,
                                         const std::string& source_name) {
    auto j = parse_profile_json(json_text, source_name);
    if (!j) {
        return tl::unexpected(j.error());
    }
    AxisProfile p;
    for (auto stage : {read_identity,
                       read_motion,
                       read_registers,
                       read_status_bits,
                       read_actions,
                       read_timeouts,
                       read_alarm_codes,
                       read_probe_registers,
                       read_position_compare}) {
        if (auto r = stage(*j, source_name, &p); !r) {
            return tl::unexpected(r.error());
        }
    }
    if (auto r = check_wire_addresses(p, source_name); !r) {
        return tl::unexpected(r.error());
    }
    return p;
}

Expected<AxisProfile> load_axis_profile(const std::string& name_or_path) {
    std::string path = name_or_path;
    const bool is_path = name_or_path.find('/') != std::string::npos ||
                         (name_or_path.size() > 5 && ends_with(name_or_path, ".json"));
    if (!is_path) {
        auto found = find_data_file("devices/" + name_or_path + ".json");
        if (!found) {
            return make_error("profile \"" + name_or_path + "\": " + found.error().message);
        }
        path = *found;
    }
    std::ifstream in(path);
    if (!in) {
        return make_error(path + ": cannot open profile");
    }
    std::ostringstream ss;
    ss << in.rdbuf();
    return parse_axis_profile(ss.str(), path);
}

Expected<int> wire_address(const AxisProfile& p, int documented) {
    const int w = documented - p.address_base;
    if (w < 0 || w > 65535) {
        return make_error("address " + std::to_string(documented) + " minus address_base " +
                          std::to_string(p.address_base) + " is outside the wire range [0, 65535]");
    }
    return w;
}

std::vector<std::uint16_t> encode_value(std::int64_t value, int width, WordOrder order) {
    const auto u = static_cast<std::uint32_t>(static_cast<std::uint64_t>(value) & 0xFFFFFFFFULL);
    if (width == 16) {
        return {static_cast<std::uint16_t>(u & 0xFFFFU)};
    }
    const auto hi = static_cast<std::uint16_t>(u >> 16);
    const auto lo = static_cast<std::uint16_t>(u & 0xFFFFU);
    if (order == WordOrder::kHighFirst) {
        return {hi, lo};
    }
    return {lo, hi};
}

std::int64_t decode_value(const std::uint16_t* words, int width, bool is_signed, WordOrder order) {
    if (width == 16) {
        return is_signed ? static_cast<std::int64_t>(static_cast<std::int16_t>(words[0]))
                         : static_cast<std::int64_t>(words[0]);
    }
    const std::uint32_t hi = order == WordOrder::kHighFirst ? words[0] : words[1];
    const std::uint32_t lo = order == WordOrder::kHighFirst ? words[1] : words[0];
    const std::uint32_t u = (hi << 16) | lo;
    return is_signed ? static_cast<std::int64_t>(static_cast<std::int32_t>(u))
                     : static_cast<std::int64_t>(u);
}

Expected<std::vector<std::uint16_t>> encode_block(const AxisProfile& p,
                                                  const CommandBlock& block,
                                                  const BlockInputs& in) {
    std::vector<std::uint16_t> out;
    int addr = block.address;
    for (const BlockSlot& s : block.slots) {
        double q = 0;
        const char* what = "constant";
        switch (s.quantity) {
            case Quantity::kConstant:
                q = s.constant;
                break;
            case Quantity::kTarget:
                q = static_cast<double>(in.target_steps);
                what = "target";
                break;
            case Quantity::kSpeed:
                q = in.speed_steps_per_s;
                what = "speed";
                break;
            case Quantity::kAccel:
                q = in.accel_steps_per_s2;
                what = "accel";
                break;
            case Quantity::kDecel:
                q = in.decel_steps_per_s2;
                what = "decel";
                break;
        }
        double wire = q;
        if (s.quantity != Quantity::kConstant) {
            if (s.inverse) {
                // A ramp time is inversely proportional to the rate: a zero rate has no time.
                if (!(q > 0)) {
                    return make_error(std::string(what) + " = " + std::to_string(q) +
                                      " must be > 0 for an inverse (ramp-time) field at register " +
                                      std::to_string(addr));
                }
                wire = s.scale / q;
            } else {
                wire = s.scale * q;
            }
        }
        const double rounded = std::round(wire);
        const double lo = s.width == 16 ? -32768.0 : -2147483648.0;
        const double hi = s.width == 16 ? 65535.0 : 4294967295.0;
        if (!std::isfinite(rounded) || rounded < lo || rounded > hi) {
            return make_error(std::string(what) + " = " + std::to_string(q) + " encodes to " +
                              std::to_string(wire) + ", which does not fit the " +
                              std::to_string(s.width) + "-bit field at register " +
                              std::to_string(addr) + " (profile \"" + p.name + "\")");
        }
        for (std::uint16_t w :
             encode_value(static_cast<std::int64_t>(rounded), s.width, p.word_order)) {
            out.push_back(w);
        }
        addr += s.width == 32 ? 2 : 1;
    }
    return out;
}

BlockInputs decode_block(const AxisProfile& p,
                         const CommandBlock& block,
                         const std::uint16_t* words) {
    BlockInputs in;
    size_t k = 0;
    for (const BlockSlot& s : block.slots) {
        const bool is_signed = s.quantity == Quantity::kTarget;
        const double wire =
            static_cast<double>(decode_value(words + k, s.width, is_signed, p.word_order));
        k += s.width == 32 ? 2 : 1;
        double q = 0;
        if (s.inverse) {
            // A zero ramp time means an instantaneous ramp: report an infinite rate as 0 = invalid.
            q = wire > 0 ? s.scale / wire : 0;
        } else {
            q = wire / s.scale;
        }
        switch (s.quantity) {
            case Quantity::kConstant:
                break;
            case Quantity::kTarget:
                in.target_steps = static_cast<std::int64_t>(wire);
                break;
            case Quantity::kSpeed:
                in.speed_steps_per_s = q;
                break;
            case Quantity::kAccel:
                in.accel_steps_per_s2 = q;
                break;
            case Quantity::kDecel:
                in.decel_steps_per_s2 = q;
                break;
        }
    }
    return in;
}

std::int64_t degrees_to_steps(const AxisProfile& p, double deg) {
    return static_cast<std::int64_t>(std::llround(deg * p.steps_per_degree * p.direction));
}

double steps_to_degrees(const AxisProfile& p, double steps) {
    return steps / p.steps_per_degree * p.direction;
}

}  // namespace gonio::devices
